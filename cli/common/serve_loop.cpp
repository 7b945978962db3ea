#include "netkf/cli/common/serve_loop.hpp"

#include <boost/asio/steady_timer.hpp>

namespace netkf::cli {

void serve(boost::asio::io_context& io, std::chrono::milliseconds interval, const std::function<bool()>& step) {
  boost::asio::steady_timer timer(io);
  std::function<void()> next = [&] {
    if (!step()) {
      io.stop();
      return;
    }
    timer.expires_after(interval);
    timer.async_wait([&](const boost::system::error_code& ec) {
      if (!ec) next();
    });
  };
  next();
  io.run();
}

bool run_until(boost::asio::io_context& io, const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    io.restart();
    io.run_for(std::chrono::milliseconds(20));
  }
  return true;
}

}  // namespace netkf::cli
