#pragma once
// The MCAP recording of a live run (netkf launch --record FILE.mcap, netkf record --out
// FILE.mcap): the records the live commands read from DDS, one MCAP channel per DDS topic,
// JSON messages with a jsonschema schema per channel; the messages and schemas are the
// dashboard's (dashboard_protocol.hpp), so Foxglove shows a recording as it shows the live run.
//
// Times (log_time = publish_time, ns): on the run's period clock, not the wall clock, so
// every channel shares one timeline that starts at period 0:
//   netkf/truth, netkf/estimate        t of the record (t_k = k * period)
//   netkf/measurement/delivered       k * period of the sample's period (its stamp is in the message)
//   netkf/link/change                 at_period * period (the first period the link applied to)
//   netkf/link/status                 t of the newest truth or estimate recorded (0 before)
//   netkf/events                      likewise: the events the records raise in the live model
//                                     (link changes, refusals, estimator restarts, silent
//                                     sensors), as foxglove.Log for Foxglove's Log panel; not
//                                     the theory's, and a change this process asked for worded
//                                     as by any reader ("from netkf ctl or another client")
// Records are written as they arrive, so log times are not strictly ordered across channels.
//
// The ros2 profile (McapOptions::profile, ros2_bag.hpp) writes the same records at the same log
// times as CDR of the wire types on the ROS 2 topic names (/netkf/truth, ...), one link status
// message per status the channel published (not the dashboard's views), and the events as ROS 2
// log messages on /rosout; its file ends with rosbag2's metadata record and a summary.
#include <cstdint>
#include <map>
#include <memory>
#include <ostream>
#include <set>
#include <string>

#include "netkf/cli/live/live_model.hpp"
#include "mcap_writer.hpp"
#include "netkf/cli/recording/recording.hpp"  // McapOptions
#include "netkf/cli/recording/ros2_bag.hpp"
#include "netkf/model/scenario.hpp"
#include "netkf/records/delivered.hpp"
#include "netkf/records/estimate.hpp"
#include "netkf/records/link_change.hpp"
#include "netkf/records/link_status.hpp"
#include "netkf/records/truth.hpp"

namespace netkf::cli {

class McapRecorder {
 public:
  /// Writes the header, schemas and channels (netkf/measurement/delivered only
  /// `with_delivered`). `out` must be binary and outlive the recorder. Throws
  /// std::invalid_argument for the ros2 profile without a codec.
  McapRecorder(std::ostream& out, const Scenario& scenario, bool with_delivered, McapOptions options = {});
  /// The same reading `model` (a launch's one live model), which its owner feeds each record
  /// before the recorder gets it (the in-time estimates only: the recorder feeds its own model
  /// just those); `model` must outlive the recorder.
  McapRecorder(std::ostream& out, LiveModel& model, bool with_delivered, McapOptions options = {});
  ~McapRecorder();
  McapRecorder(const McapRecorder&) = delete;
  McapRecorder& operator=(const McapRecorder&) = delete;

  void truth(const Truth& t);
  void estimate(const Estimate& e);
  void delivered(const DeliveredMeasurement& d);
  void link_status(const LinkStatus& l);
  void link_change(const LinkChange& c);
  /// DataEnd, Footer, closing magic (the file is complete), after the final estimates still
  /// held (late_policy fuse_within). Idempotent.
  void finish();
  bool finished() const { return writer_.finished(); }

  std::uint64_t estimates() const { return estimates_; }
  std::uint64_t messages() const { return writer_.messages(); }
  std::uint64_t events() const { return events_written_; }

 private:
  std::uint64_t period_time_ns(std::int64_t k) const;
  void write_estimate(const Estimate& e);
  /// fuse_within: write the held final revisions of the periods up to `last_final`.
  void write_finals(std::int64_t last_final);
  void note_time(double t);
  void write(std::uint16_t channel, std::uint64_t time_ns, const std::string& data);  // JSON or CDR
  void write_events();
  bool ros2() const { return options_.profile == McapProfile::ros2; }
  void add_channels();
  void add_ros2_channels();
  void write_bag_metadata();

  McapRecorder(std::ostream& out, std::unique_ptr<LiveModel> own_model, LiveModel* shared, bool with_delivered,
               McapOptions options);
  /// The events raised since the last write, or none when a record of the model's owner raised
  /// them for a repeat the recording skips.
  void drop_events();

  McapOptions options_;
  McapWriter writer_;
  // The link views the dashboard sends (late counts, arrival rates) and the events: the
  // launch's model, or (standalone) one of the recorder's own that it feeds itself.
  std::unique_ptr<LiveModel> own_model_;
  LiveModel& model_;
  LiveModel::Subscriber reader_;
  double period_s_;
  bool with_delivered_;
  int max_delay_periods_ = 0;                  // D (0: late_policy drop, no revisions)
  std::map<std::int64_t, Estimate> finals_;    // D > 0: the newest revision of k, until k is final
  std::uint16_t truth_ = 0, estimate_ = 0, delivered_ = 0, link_status_ = 0, link_change_ = 0, events_ = 0;
  std::uint64_t latest_ns_ = 0;
  std::uint64_t estimates_ = 0;
  std::uint64_t events_written_ = 0;
  std::map<ros2::Channel, std::uint16_t> ros2_channels_;  // ros2: the channel of each recorded topic
  std::set<std::string> changes_seen_;  // the journal is transient-local: a late reader gets repeats
};

}  // namespace netkf::cli
