#pragma once
// Implementation of netkf::dds::post_to (kept apart so endpoints.hpp stays readable).
#include <functional>
#include <memory>
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/post.hpp>

namespace netkf::dds {

template <class T, class Executor, class Handler>
std::function<void(T&&)> post_to(Executor executor, Handler handler) {
  auto shared_handler = std::make_shared<Handler>(std::move(handler));
  return [executor, shared_handler](T&& sample) {
    boost::asio::post(executor, [shared_handler, s = std::move(sample)]() mutable { (*shared_handler)(std::move(s)); });
  };
}

}  // namespace netkf::dds
