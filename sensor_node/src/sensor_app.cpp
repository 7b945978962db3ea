#include "netkf/nodes/sensor_app.hpp"

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/post.hpp>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "netkf/dds/dds.hpp"
#include "netkf/dds/presence.hpp"
#include "netkf/nodes/sensor_simulator.hpp"

namespace netkf::nodes {

namespace wire = netkf::wire;

std::string describe_sensor_ids(const std::vector<int>& ids) {
  std::string text;
  for (std::size_t i = 0; i < ids.size();) {
    std::size_t last = i;
    while (last + 1 < ids.size() && ids[last + 1] == ids[last] + 1) ++last;
    text += (text.empty() ? "" : ",") + std::to_string(ids[i]);
    if (last > i) text += (last == i + 1 ? "," : "-") + std::to_string(ids[last]);
    i = last + 1;
  }
  return text;
}

namespace {
std::vector<SensorSimulator> make_sensors(const Scenario& scenario, const std::vector<int>& ids) {
  if (ids.empty()) throw std::invalid_argument("no sensor id given");
  if (std::set<int>(ids.begin(), ids.end()).size() != ids.size())
    throw std::invalid_argument("sensor ids " + describe_sensor_ids(ids) + " name a sensor twice");
  std::vector<SensorSimulator> sensors;
  for (int id : ids) sensors.emplace_back(scenario, id);
  return sensors;
}
}  // namespace

class SensorApp::Impl {
 public:
  Impl(const Scenario& scenario, dds::Participant& participant, const SensorAppOptions& options)
      : sensors_(make_sensors(scenario, options.sensor_ids)),
        state_dim_(scenario.state_dim()) {
    // One sensor writes its samples; several write one batch per truth (fewer DDS samples,
    // wake-ups and acknowledgements: BENCHMARKS.md, "256 sensors at 100 Hz").
    if (sensors_.size() == 1) {
      raw_.emplace(participant, dds::topics::raw_measurement, 1.0 / scenario.period_s());
    } else {
      const auto batches = (sensors_.size() + dds::kMaxBatchSamples - 1) / dds::kMaxBatchSamples;  // per truth
      raw_batch_.emplace(participant, dds::topics::raw_measurement_batch,
                         static_cast<double>(batches) / scenario.period_s());
    }
    // The reader last: its callback uses everything above.
    truth_.emplace(participant, dds::topics::truth, [this](wire::Truth&& truth) { on_truth(truth); });
    // Present once it can measure and the channel's reader matched its writer (a sample written
    // before is lost): the plant waits for every sensor's presence before period 0.
    auto announce = [this, &participant, ids = options.sensor_ids, hash = dds::scenario_hash(scenario)] {
      presence_.emplace(participant, dds::presence_role::sensors, ids, hash);
    };
    if (options.raw_readers <= 0) {
      announce();
      return;
    }
    readers_matched_.emplace(
        io_, [this, wanted = options.raw_readers] { return raw_readers() >= wanted; }, std::chrono::seconds(5),
        [this, wanted = options.raw_readers, announce](bool matched) {
          if (!matched)
            spdlog::warn("after {} ms the raw samples have {} readers (want {}: the channel); present anyway",
                         readers_matched_->waited().count(), raw_readers(), wanted);
          announce();
        });
  }

  int raw_readers() const { return raw_ ? raw_->matched() : raw_batch_->matched(); }

  ~Impl() {
    // The reader first: nothing measures any more, and no callback runs into a half-destroyed object.
    truth_.reset();
  }

  void run() {
    work_.emplace(io_.get_executor());
    io_.run();
  }

  void stop() {
    boost::asio::post(io_, [this] {
      work_.reset();
      io_.stop();
    });
  }

  boost::asio::io_context& io() { return io_; }

  SensorAppStats stats() const {
    SensorAppStats s;
    {
      const std::lock_guard lock(mutex_);
      for (const auto& sensor : sensors_) s.sensors.push_back({sensor.id(), sensor.measured(), sensor.skipped()});
    }
    s.raw_readers = raw_readers();
    return s;
  }

  void log_summary() const {
    for (const auto& sensor : stats().sensors) spdlog::info("sensor {}: {} samples measured", sensor.id, sensor.measured);
  }

 private:
  // DDS receive thread
  void on_truth(const wire::Truth& truth) {
    Vector x;
    try {
      x = dds::truth_state(truth, state_dim_);
    } catch (const std::exception& e) {
      spdlog::warn("truth for period {} rejected: {}", truth.k(), e.what());
      return;
    }
    const std::lock_guard lock(mutex_);
    std::vector<wire::Measurement> samples;
    samples.reserve(sensors_.size());
    for (auto& sensor : sensors_) {
      std::string why;
      const auto y = sensor.measure(truth.k(), x, &why);
      if (!y) {
        spdlog::warn("sensor {}: period {} not measured: {}", sensor.id(), truth.k(), why);
        continue;
      }
      samples.push_back(dds::make_measurement(sensor.id(), truth.k(), dds::steady_now_ns(), *y));
    }
    if (raw_) {
      for (auto& m : samples) raw_->write(std::move(m));
    } else {
      for (auto& batch : dds::make_measurement_batches(std::move(samples))) raw_batch_->write(std::move(batch));
    }
  }

  boost::asio::io_context io_;
  std::optional<boost::asio::executor_work_guard<boost::asio::io_context::executor_type>> work_;
  mutable std::mutex mutex_;  // sensors_
  std::vector<SensorSimulator> sensors_;
  int state_dim_;
  std::optional<dds::Writer<wire::Measurement>> raw_;             // one sensor
  std::optional<dds::Writer<wire::MeasurementBatch>> raw_batch_;  // several
  std::optional<dds::Reader<wire::Truth>> truth_;
  std::optional<dds::PresenceAnnouncer> presence_;
  std::optional<dds::WhenMatched> readers_matched_;  // destroyed first: its callback creates presence_
};

SensorApp::SensorApp(const Scenario& scenario, dds::Participant& participant, SensorAppOptions options)
    : impl_(std::make_unique<Impl>(scenario, participant, options)) {}
SensorApp::~SensorApp() = default;
void SensorApp::run() { impl_->run(); }
void SensorApp::stop() { impl_->stop(); }
boost::asio::io_context& SensorApp::io() { return impl_->io(); }
SensorAppStats SensorApp::stats() const { return impl_->stats(); }
void SensorApp::log_summary() const { impl_->log_summary(); }

}  // namespace netkf::nodes
