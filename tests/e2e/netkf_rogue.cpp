// netkf_rogue: a participant that should not be let in, for the security e2e tests. It reads
// truth, estimates and link status (counting what it receives) and forges samples: raw and
// delivered measurements of a sensor carrying a marker value, and link-control requests.
// Whether it runs without security, with another CA's identity or with a wrong role is the
// test's choice (--secure DIR --role ROLE). An endpoint DDS refuses (permissions) is reported,
// not fatal: the test reads what happened from the JSON object printed at the end.
//
// Usage: netkf_rogue --domain N --seconds S [--secure DIR --role ROLE] [--sensor ID]
//                    [--marker Y] [--raw] [--delivered] [--link-control] [--after-truth]
// --after-truth: forge only once the truth is received (for the current period), so a test can
// tell the forged samples' periods from the ones before.
// --hostile: instead of plausible forgeries, every kind of bad input each cycle: on each
// measurement topic a NaN sample, a wrong-size one, an unknown sensor id, the same sample
// twice, one far in the past and one far in the future; on link control an unknown sensor, a
// NaN loss, an unknown key and a Gilbert-Elliott link with p = r = 0.
#include <atomic>
#include <chrono>
#include <iostream>
#include <limits>
#include <vector>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "netkf/dds/dds.hpp"

namespace ndds = netkf::dds;
namespace wire = netkf::wire;

int main(int argc, char** argv) {
  int domain = -1, sensor = 1;
  double seconds = 5.0, marker = 31337.0;
  std::string secure, role = "observer";
  bool raw = false, delivered = false, link_control = false, after_truth = false, hostile = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--domain")
      domain = std::stoi(next());
    else if (a == "--seconds")
      seconds = std::stod(next());
    else if (a == "--secure")
      secure = next();
    else if (a == "--role")
      role = next();
    else if (a == "--sensor")
      sensor = std::stoi(next());
    else if (a == "--marker")
      marker = std::stod(next());
    else if (a == "--raw")
      raw = true;
    else if (a == "--delivered")
      delivered = true;
    else if (a == "--link-control")
      link_control = true;
    else if (a == "--after-truth")
      after_truth = true;
    else if (a == "--hostile")
      hostile = true;
    else {
      std::cerr << "netkf_rogue: unknown argument " << a << "\n";
      return 2;
    }
  }
  if (domain < 0) {
    std::cerr << "netkf_rogue: --domain is required\n";
    return 2;
  }
  nlohmann::json out{{"errors", nlohmann::json::array()}};
  auto error = [&out](const std::string& what) { out["errors"].push_back(what); };
  std::atomic<std::uint64_t> truth_n{0}, estimate_n{0}, status_n{0}, last_k{0};
  std::uint64_t raw_n = 0, delivered_n = 0, control_n = 0;
  try {
    ndds::ParticipantOptions o;
    o.domain = domain;
    o.name = "netkf-rogue";
    if (!secure.empty()) o.security = ndds::ParticipantOptions::Security{secure, ndds::role_from_name(role)};
    ndds::Participant p(o);
    std::unique_ptr<ndds::Reader<wire::Truth>> truth;
    std::unique_ptr<ndds::Reader<wire::Estimate>> estimate;
    std::unique_ptr<ndds::Reader<wire::LinkStatus>> status;
    std::unique_ptr<ndds::Writer<wire::Measurement>> raw_w, delivered_w;
    std::unique_ptr<ndds::Writer<wire::LinkControl>> control_w;
    auto attempt = [&](auto make) {
      try {
        make();
      } catch (const std::exception& e) {
        error(e.what());
      }
    };
    attempt([&] {
      truth = std::make_unique<ndds::Reader<wire::Truth>>(p, ndds::topics::truth, [&](wire::Truth&& t) {
        ++truth_n;
        last_k = t.k();
      });
    });
    attempt([&] {
      estimate = std::make_unique<ndds::Reader<wire::Estimate>>(p, ndds::topics::estimate,
                                                                [&](wire::Estimate&&) { ++estimate_n; });
    });
    attempt([&] {
      status = std::make_unique<ndds::Reader<wire::LinkStatus>>(p, ndds::topics::link_status,
                                                                [&](wire::LinkStatus&&) { ++status_n; });
    });
    if (raw)
      attempt([&] { raw_w = std::make_unique<ndds::Writer<wire::Measurement>>(p, ndds::topics::raw_measurement); });
    if (delivered)
      attempt([&] {
        delivered_w = std::make_unique<ndds::Writer<wire::Measurement>>(p, ndds::topics::delivered_measurement);
      });
    if (link_control)
      attempt([&] { control_w = std::make_unique<ndds::Writer<wire::LinkControl>>(p, ndds::topics::link_control); });

    // Forge at 50 Hz: samples for the newest period seen (or a count when nothing is seen) and
    // a request to make the sensor's link drop 95 % of its samples.
    netkf::Vector y = netkf::Vector::Constant(1, marker);
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    std::uint64_t counter = 0;
    while (std::chrono::steady_clock::now() < end) {
      if (after_truth && truth_n.load() == 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      const std::uint64_t k = last_k.load() > 0 ? last_k.load() + 1 : counter;
      if (hostile) {
        const double nan = std::numeric_limits<double>::quiet_NaN();
        const std::vector<wire::Measurement> bad{
            ndds::make_measurement(sensor, k, ndds::steady_now_ns(), netkf::Vector::Constant(1, 1.0)),  // fine once,
            ndds::make_measurement(sensor, k, ndds::steady_now_ns(), netkf::Vector::Constant(1, 1.0)),  // then a duplicate
            ndds::make_measurement(99, k, ndds::steady_now_ns(), y),                                       // unknown id
            ndds::make_measurement(sensor, k + 1000, ndds::steady_now_ns(), y),                            // far future
            ndds::make_measurement(sensor, k > 500 ? k - 500 : 0, ndds::steady_now_ns(), y)};              // far past
        for (auto* w : {raw_w.get(), delivered_w.get()}) {
          if (!w) continue;
          for (const auto& m : bad) w->write(m);
          // NaN and a wrong size: the conversion refuses to make them, so build them by hand.
          wire::Measurement m = ndds::make_measurement(sensor, k, ndds::steady_now_ns(), y);
          m.y({nan});
          w->write(m);
          m.y({1.0, 2.0});
          w->write(m);
          (w == raw_w.get() ? raw_n : delivered_n) += bad.size() + 2;
        }
        if (control_w && counter % 10 == 0) {
          const std::vector<wire::LinkControl> requests{
              ndds::make_link_control(2000 + counter, 99, {{"loss", 0.5}}),
              ndds::make_link_control(2001 + counter, sensor, {{"loss", nan}}),
              ndds::make_link_control(2002 + counter, sensor, {{"bogus", 0.5}}),
              ndds::make_link_control(2003 + counter, sensor,
                                      {{"model", std::string("gilbert_elliott")}, {"p", 0.0}, {"r", 0.0}})};
          for (const auto& c : requests) control_n += control_w->write(c) ? 1 : 0;
        }
        ++counter;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      if (raw_w && raw_w->write(ndds::make_measurement(sensor, k, ndds::steady_now_ns(), y))) ++raw_n;
      if (delivered_w && delivered_w->write(ndds::make_measurement(sensor, k, ndds::steady_now_ns(), y))) ++delivered_n;
      if (control_w && counter % 10 == 0 &&
          control_w->write(
              ndds::make_link_control(1000 + counter, sensor, {{"model", std::string("bernoulli")}, {"loss", 0.95}})))
        ++control_n;
      ++counter;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    out["matched"] = {{"raw_readers", raw_w ? raw_w->matched() : 0},
                      {"delivered_readers", delivered_w ? delivered_w->matched() : 0},
                      {"link_control_readers", control_w ? control_w->matched() : 0},
                      {"truth_writers", truth ? truth->matched() : 0},
                      {"estimate_writers", estimate ? estimate->matched() : 0},
                      {"link_status_writers", status ? status->matched() : 0}};
    out["participant"] = true;
  } catch (const std::exception& e) {
    error(e.what());
    out["participant"] = false;
  }
  out["received"] = {{"truth", truth_n.load()}, {"estimate", estimate_n.load()}, {"link_status", status_n.load()}};
  out["written"] = {{"raw", raw_n}, {"delivered", delivered_n}, {"link_control", control_n}};
  std::cout << out.dump() << "\n";
  return 0;
}
