#include "netkf/cli/recording/recording.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/links/link_keys.hpp"

namespace netkf::cli {
namespace {

int max_measurement_dim(const Scenario& s) {
  int m = 0;
  for (const auto& sensor : s.sensors) m = std::max(m, static_cast<int>(sensor.C.rows()));
  return m;
}

/// The plant's input dimension m (0 without control): a closed loop's rows carry u.
int input_dim(const Scenario& s) { return s.plant.B ? static_cast<int>(s.plant.B->cols()) : 0; }

std::string events_file_of(const std::string& periods_file) { return periods_file + ".events.yaml"; }

}  // namespace

std::vector<FileArg> Recording::outputs(const std::string& periods_option, const std::optional<std::string>& periods_file,
                                        const std::string& samples_option,
                                        const std::optional<std::string>& samples_file) {
  std::vector<FileArg> files;
  if (periods_file) {
    files.push_back({periods_option, *periods_file});
    files.push_back({periods_option + "'s journal", events_file_of(*periods_file)});
  }
  if (samples_file) files.push_back({samples_option, *samples_file});
  return files;
}

McapOptions Recording::mcap_options(const std::string& periods_option, const std::optional<std::string>& periods_file,
                                    const std::optional<std::string>& profile,
                                    std::shared_ptr<const ros2::Ros2Codec> codec) {
  McapOptions o;
  if (!profile) return o;
  if (!periods_file || !is_mcap_path(*periods_file))
    fail(ExitCode::bad_usage, "--mcap-profile applies to an MCAP recording: give " + periods_option + " FILE.mcap");
  try {
    o.profile = mcap_profile_from_string(*profile);
  } catch (const std::invalid_argument& e) {
    fail(ExitCode::bad_usage, std::string("--mcap-profile: ") + e.what());
  }
  if (o.profile == McapProfile::ros2) o.codec = std::move(codec);
  o.file_name = std::filesystem::path(*periods_file).filename().string();
  return o;
}

Recording::Recording(const std::optional<std::string>& periods_file, const std::optional<std::string>& samples_file,
                     const Scenario& scenario, McapOptions mcap, LiveModel* model)
    : periods_(scenario.state_dim(), scenario.estimator.fusable_delay_periods(), input_dim(scenario),
               scenario.actuation_link() != nullptr),
      samples_(max_measurement_dim(scenario), scenario.estimator.fusable_delay_periods()),
      periods_file_(periods_file),
      samples_file_(samples_file) {
  if (periods_file && is_mcap_path(*periods_file)) {
    mcap_out_ = open_output_stream({"the recording", *periods_file});
    if (mcap.file_name.empty()) mcap.file_name = *periods_file;
    const bool with_delivered = samples_file.has_value();
    mcap_ = model ? std::make_unique<McapRecorder>(*mcap_out_, *model, with_delivered, std::move(mcap))
                  : std::make_unique<McapRecorder>(*mcap_out_, scenario, with_delivered, std::move(mcap));
    mcap_out_->flush();
  } else if (periods_file) {
    periods_out_ = open_output_stream({"the recording", *periods_file});
    *periods_out_ << PeriodCsvRecorder::header(scenario.state_dim(), scenario.estimator.fusable_delay_periods(),
                                               input_dim(scenario), scenario.actuation_link() != nullptr)
                  << "\n";
  }
  if (periods_file) {
    events_file_ = events_file_of(*periods_file);
    // An empty journal too: a replay of a run without changes is valid.
    if (!write_events()) fail(ExitCode::bad_usage, *write_error_);
  }
  if (samples_file) {
    samples_out_ = open_output_stream({"the samples recording", *samples_file});
    *samples_out_ << SampleCsvRecorder::header(max_measurement_dim(scenario),
                                               scenario.estimator.fusable_delay_periods())
                  << "\n";
  }
}

Recording::~Recording() {
  try {
    finish();
  } catch (...) {
  }
}

void Recording::truth(const Truth& t) {
  if (periods_out_) periods_.add_truth(t);
  if (mcap_) mcap_->truth(t);
}

void Recording::estimate(const Estimate& e) {
  if (periods_out_) periods_.add_estimate(e);
  if (samples_out_) samples_.add_estimate(e);
  if (mcap_) mcap_->estimate(e);
}

void Recording::delivered(const DeliveredMeasurement& d) {
  if (samples_out_) samples_.add_delivered(d);
  if (mcap_) mcap_->delivered(d);
}

void Recording::link_status(const LinkStatus& l) {
  if (mcap_) mcap_->link_status(l);
}

void Recording::link_change(const LinkChange& c) {
  if (mcap_) mcap_->link_change(c);
  if (!events_file_ || c.origin != LinkChange::Origin::request) return;
  LinkEvent e;
  e.at_period = c.at_period;
  e.link = c.sensor_id;
  e.keys = link_keys(c.link);  // the whole link: a replay sets exactly what the run had
  for (const auto& seen : journal_)
    if (seen.request_id == c.request_id && seen.event == e) return;  // transient-local repeats
  journal_.push_back({c.request_id, std::move(e)});
  journal_changed_ = true;
}

void Recording::check(const std::ostream& out, const std::string& file, int saved_errno) {
  if (out || write_error_) return;
  write_error_ = "writing " + file + " failed" + (saved_errno != 0 ? std::string(": ") + std::strerror(saved_errno) : "");
}

void Recording::flush() {
  errno = 0;
  if (periods_out_) {
    periods_.flush(*periods_out_);
    periods_out_->flush();
    check(*periods_out_, *periods_file_, errno);
  }
  if (samples_out_) {
    samples_.flush(*samples_out_);
    samples_out_->flush();
    check(*samples_out_, *samples_file_, errno);
  }
  if (mcap_) {
    mcap_out_->flush();
    check(*mcap_out_, *periods_file_, errno);
  }
  if (journal_changed_) write_events();
}

void Recording::finish() {
  // fuse_within: the last D periods' rows wait for a final estimate that no longer comes.
  if (periods_out_ || samples_out_) {
    periods_.finish_pending();
    samples_.finish_pending();
    flush();
  }
  if (mcap_ && !mcap_->finished()) {
    errno = 0;
    mcap_->finish();
    mcap_out_->flush();
    check(*mcap_out_, *periods_file_, errno);
  }
}

std::uint64_t Recording::rows() const { return mcap_ ? mcap_->estimates() : periods_.rows_written(); }

bool Recording::write_events() {
  std::vector<LinkEvent> events;
  for (const auto& j : journal_) events.push_back(j.event);
  // Written whole and renamed in place: a launch killed mid-write leaves the previous journal.
  try {
    write_output_file({"the journal", *events_file_},
                      "# Live link changes of a netkf run, with the period each applied from.\n"
                      "# Replay: netkf launch SCENARIO --events THIS_FILE (same scenario and seed).\n" +
                          events_to_yaml(events),
                      /*sync=*/false);
  } catch (const CommandError& e) {
    if (!write_error_) write_error_ = e.what();
    return false;
  }
  journal_changed_ = false;
  return true;
}

}  // namespace netkf::cli
