#pragma once
// The sensor node's DDS wiring (docs/architecture.md, "sensor_node"): turns the truth x_k into
// y_{i,k} = C_i x_k + v_{i,k} and publishes it on the raw measurement topic (the channel
// emulator decides whether it reaches the estimator). It hosts one sensor, or several on one
// DDS participant (a gateway in front of many sensors, or a dense network on a small machine):
// each keeps its own C_i, R_i and noise stream and its own samples, which go out together as
// one wire::MeasurementBatch per truth (the channel still decides each on its own link). Constructed from
// its options on a participant; run() serves until stop(). The integration tests run it in
// process (tests/integration/test_node_apps.cpp); main.cpp only parses flags.
//
// Threads: the truth is measured on the DDS receive thread that delivers it: a few
// multiply-adds and a write per sensor, cheaper than the context switch a hand-off to the io
// thread would cost (endpoints.hpp). The io thread only waits for stop() (and main's signals).
// A mutex guards the simulators, uncontended except for stats() from other threads.
#include <utility>  // before Asio (Boost 1.74 + GCC 12, docs/dds-notes.md)

#include <boost/asio/io_context.hpp>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "netkf/dds/participant.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf::nodes {

struct SensorAppOptions {
  /// Ids of the scenario's sensors this process hosts (at least one, none twice).
  std::vector<int> sensor_ids;
  /// Readers of the raw samples (the channel) to wait for, bounded, before saying it is present;
  /// 0: present at once.
  int raw_readers = 0;
};

/// What the sensors did so far (for the summary lines and for tests).
struct SensorAppStats {
  struct Sensor {
    int id = 0;
    std::uint64_t measured = 0;
    std::uint64_t skipped = 0;  // truths not measured (wrong size, non-finite, not after the last)
  };
  std::vector<Sensor> sensors;  // in the order of the options
  int raw_readers = 0;          // readers matched by the raw measurement writer (the channel)
};

/// "1-64", "1,3,5-7", "3,3": the ids in their order, runs of consecutive ids shortened, as the
/// logger's and the participant's names show them (a group of 64 sensors listed one by one
/// made a participant name too long for Fast DDS: see participant.cpp).
std::string describe_sensor_ids(const std::vector<int>& ids);

class SensorApp {
 public:
  /// Throws std::invalid_argument for no id, an id named twice or not in the scenario; DdsError.
  SensorApp(const Scenario& scenario, dds::Participant& participant, SensorAppOptions options);
  ~SensorApp();
  SensorApp(const SensorApp&) = delete;
  SensorApp& operator=(const SensorApp&) = delete;

  /// Serve until stop(). Call once.
  void run();
  /// End run() soon (thread-safe; idempotent).
  void stop();
  /// The io_context run() serves (for a signal_set in main).
  boost::asio::io_context& io();

  SensorAppStats stats() const;
  /// One line per sensor: samples measured.
  void log_summary() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace netkf::nodes
