#pragma once
// The one loop every live command runs on its io_context thread: a step every interval
// until the step says the command is over, with the DDS handlers and the dashboard served
// in between (they post to the same io_context).
#include <utility>  // before Asio (Boost 1.74 + GCC 12)

#include <boost/asio/io_context.hpp>
#include <chrono>
#include <functional>

namespace netkf::cli {

/// Run `io` with `step()` every `interval` (the first at once) until a step returns false;
/// then stop `io` and return. Handlers posted to `io` run between steps.
void serve(boost::asio::io_context& io, std::chrono::milliseconds interval, const std::function<bool()>& step);

/// Run `io` until `done()` or the timeout; true when done.
bool run_until(boost::asio::io_context& io, const std::function<bool()>& done, std::chrono::milliseconds timeout);

}  // namespace netkf::cli
