// netkf_ros2_cdr_sample KIND JSON: the CDR bytes (hex, one line) that the ros2 MCAP profile's
// codec (cli/recording/ros2_cdr_codec.hpp, Fast CDR) writes for one record given as JSON, so
// that python/tests/test_ros2_cdr.py can decode them with the pure-Python decoder and compare
// with the values it sent. KIND: estimate | truth | delivered | log.
#include <cstdio>
#include <iostream>
#include <string>

#include <nlohmann/json.hpp>

#include "netkf/cli/recording/ros2_cdr_codec.hpp"

namespace {

using nlohmann::json;

netkf::Estimate estimate_of(const json& j) {
  netkf::Estimate e;
  e.k = j.at("k").get<std::uint64_t>();
  e.revision = j.at("revision").get<std::uint32_t>();
  e.t = j.at("t").get<double>();
  const auto x = j.at("x_hat").get<std::vector<double>>();
  const auto n = static_cast<Eigen::Index>(x.size());
  e.x_hat = netkf::Vector(n);
  for (Eigen::Index i = 0; i < n; ++i) e.x_hat(i) = x[static_cast<std::size_t>(i)];
  const auto p = j.at("P").get<std::vector<double>>();  // row-major n x n
  e.P = netkf::Matrix(n, n);
  for (Eigen::Index r = 0; r < n; ++r)
    for (Eigen::Index c = 0; c < n; ++c) e.P(r, c) = p.at(static_cast<std::size_t>(r * n + c));
  e.trace_P_pred = j.at("trace_P_pred").get<double>();
  e.fused = j.at("fused").get<std::vector<int>>();
  e.late_sensors = j.at("late_sensors").get<std::vector<int>>();
  e.late_periods = j.at("late_periods").get<std::vector<std::uint64_t>>();
  e.late = static_cast<std::uint32_t>(e.late_sensors.size());
  e.late_total = j.at("late_total").get<std::uint64_t>();
  e.rejected_total = j.at("rejected_total").get<std::uint64_t>();
  e.state = j.at("state").get<std::string>() == "diverging" ? netkf::FilterState::diverging : netkf::FilterState::ok;
  e.restarts = j.at("restarts").get<std::uint32_t>();
  e.fused_at_ns = j.at("fused_at_ns").get<std::int64_t>();
  e.stamp_ns = j.at("stamp_ns").get<std::int64_t>();
  e.last_sample_stamp_ns = j.at("last_sample_stamp_ns").get<std::int64_t>();
  return e;
}

std::string hex(const std::string& bytes) {
  std::string out;
  char b[3];
  for (const unsigned char c : bytes) {
    std::snprintf(b, sizeof b, "%02x", c);
    out += b;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: netkf_ros2_cdr_sample estimate|truth|delivered|log JSON\n";
    return 2;
  }
  try {
    const std::string kind = argv[1];
    const json j = json::parse(argv[2]);
    const auto codec = netkf::cli::ros2::make_fastcdr_codec();
    std::string cdr;
    if (kind == "estimate") {
      cdr = codec->estimate(estimate_of(j));
    } else if (kind == "truth") {
      cdr = codec->truth({j.at("k").get<std::int64_t>(), j.at("t").get<double>(), j.at("x").get<std::vector<double>>(),
                          j.at("u").get<std::vector<double>>(), j.at("input_arrived").get<bool>()});
    } else if (kind == "delivered") {
      cdr = codec->delivered({j.at("sensor_id").get<int>(), j.at("k").get<std::int64_t>(), j.at("stamp").get<double>(),
                              j.at("y").get<std::vector<double>>()});
    } else if (kind == "log") {
      cdr = codec->log(j.at("stamp_ns").get<std::uint64_t>(), j.at("level").get<std::uint8_t>(),
                       j.at("name").get<std::string>(), j.at("text").get<std::string>());
    } else {
      std::cerr << "unknown kind " << kind << "\n";
      return 2;
    }
    std::cout << hex(cdr) << "\n";
  } catch (const std::exception& e) {
    std::cerr << "netkf_ros2_cdr_sample: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
