#include "netkf/cli/recording/recording.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/links/link_keys.hpp"
#include "record_csv.hpp"
#include "record_mcap.hpp"

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

/// What a recording writes to: the CSV recorders and their streams, the MCAP recorder, the
/// journal of live changes, and the first write that failed.
struct Recording::Files {
  struct Journaled {
    std::uint64_t request_id;
    LinkEvent event;
  };

  Files(const Scenario& scenario, std::optional<std::string> periods_name, std::optional<std::string> samples_name)
      : periods(scenario.state_dim(), scenario.estimator.fusable_delay_periods(), input_dim(scenario),
                scenario.actuation_link() != nullptr),
        samples(max_measurement_dim(scenario), scenario.estimator.fusable_delay_periods()),
        periods_file(std::move(periods_name)),
        samples_file(std::move(samples_name)) {}

  PeriodCsvRecorder periods;
  SampleCsvRecorder samples;
  std::optional<std::string> periods_file;
  std::optional<std::string> samples_file;
  std::unique_ptr<std::ostream> periods_out;
  std::unique_ptr<std::ostream> samples_out;
  std::unique_ptr<std::ostream> mcap_out;
  std::unique_ptr<McapRecorder> mcap;  // declared after its stream: destroyed first
  std::optional<std::string> events_file;
  std::vector<Journaled> journal;
  bool journal_changed = false;
  std::optional<std::string> write_error;
};

Recording::Recording(const std::optional<std::string>& periods_file, const std::optional<std::string>& samples_file,
                     const Scenario& scenario, McapOptions mcap, LiveModel* model)
    : f_(std::make_unique<Files>(scenario, periods_file, samples_file)) {
  if (periods_file && is_mcap_path(*periods_file)) {
    f_->mcap_out = open_output_stream({"the recording", *periods_file});
    if (mcap.file_name.empty()) mcap.file_name = *periods_file;
    const bool with_delivered = samples_file.has_value();
    f_->mcap = model ? std::make_unique<McapRecorder>(*f_->mcap_out, *model, with_delivered, std::move(mcap))
                     : std::make_unique<McapRecorder>(*f_->mcap_out, scenario, with_delivered, std::move(mcap));
    f_->mcap_out->flush();
  } else if (periods_file) {
    f_->periods_out = open_output_stream({"the recording", *periods_file});
    *f_->periods_out << PeriodCsvRecorder::header(scenario.state_dim(), scenario.estimator.fusable_delay_periods(),
                                                  input_dim(scenario), scenario.actuation_link() != nullptr)
                     << "\n";
  }
  if (periods_file) {
    f_->events_file = events_file_of(*periods_file);
    // An empty journal too: a replay of a run without changes is valid.
    if (!write_events()) fail(ExitCode::bad_usage, *f_->write_error);
  }
  if (samples_file) {
    f_->samples_out = open_output_stream({"the samples recording", *samples_file});
    *f_->samples_out << SampleCsvRecorder::header(max_measurement_dim(scenario),
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
  if (f_->periods_out) f_->periods.add_truth(t);
  if (f_->mcap) f_->mcap->truth(t);
}

void Recording::estimate(const Estimate& e) {
  if (f_->periods_out) f_->periods.add_estimate(e);
  if (f_->samples_out) f_->samples.add_estimate(e);
  if (f_->mcap) f_->mcap->estimate(e);
}

void Recording::delivered(const DeliveredMeasurement& d) {
  if (f_->samples_out) f_->samples.add_delivered(d);
  if (f_->mcap) f_->mcap->delivered(d);
}

void Recording::link_status(const LinkStatus& l) {
  if (f_->mcap) f_->mcap->link_status(l);
}

void Recording::link_change(const LinkChange& c) {
  if (f_->mcap) f_->mcap->link_change(c);
  if (!f_->events_file || c.origin != LinkChange::Origin::request) return;
  LinkEvent e;
  e.at_period = c.at_period;
  e.link = c.sensor_id;
  e.keys = link_keys(c.link);  // the whole link: a replay sets exactly what the run had
  for (const auto& seen : f_->journal)
    if (seen.request_id == c.request_id && seen.event == e) return;  // transient-local repeats
  f_->journal.push_back({c.request_id, std::move(e)});
  f_->journal_changed = true;
}

void Recording::check(const std::ostream& out, const std::string& file, int saved_errno) {
  if (out || f_->write_error) return;
  f_->write_error = "writing " + file + " failed" + (saved_errno != 0 ? std::string(": ") + std::strerror(saved_errno) : "");
}

void Recording::flush() {
  errno = 0;
  if (f_->periods_out) {
    f_->periods.flush(*f_->periods_out);
    f_->periods_out->flush();
    check(*f_->periods_out, *f_->periods_file, errno);
  }
  if (f_->samples_out) {
    f_->samples.flush(*f_->samples_out);
    f_->samples_out->flush();
    check(*f_->samples_out, *f_->samples_file, errno);
  }
  if (f_->mcap) {
    f_->mcap_out->flush();
    check(*f_->mcap_out, *f_->periods_file, errno);
  }
  if (f_->journal_changed) write_events();
}

void Recording::finish() {
  // fuse_within: the last D periods' rows wait for a final estimate that no longer comes.
  if (f_->periods_out || f_->samples_out) {
    f_->periods.finish_pending();
    f_->samples.finish_pending();
    flush();
  }
  if (f_->mcap && !f_->mcap->finished()) {
    errno = 0;
    f_->mcap->finish();
    f_->mcap_out->flush();
    check(*f_->mcap_out, *f_->periods_file, errno);
  }
}

std::uint64_t Recording::rows() const { return f_->mcap ? f_->mcap->estimates() : f_->periods.rows_written(); }

bool Recording::wants_samples() const { return f_->samples_out != nullptr; }
bool Recording::wants_link_status() const { return f_->mcap != nullptr; }
bool Recording::journals_changes() const { return f_->events_file.has_value(); }
const std::optional<std::string>& Recording::write_error() const { return f_->write_error; }

bool Recording::write_events() {
  std::vector<LinkEvent> events;
  for (const auto& j : f_->journal) events.push_back(j.event);
  // Written whole and renamed in place: a launch killed mid-write leaves the previous journal.
  try {
    write_output_file({"the journal", *f_->events_file},
                      "# Live link changes of a netkf run, with the period each applied from.\n"
                      "# Replay: netkf launch SCENARIO --events THIS_FILE (same scenario and seed).\n" +
                          events_to_yaml(events),
                      /*sync=*/false);
  } catch (const CommandError& e) {
    if (!f_->write_error) f_->write_error = e.what();
    return false;
  }
  f_->journal_changed = false;
  return true;
}

}  // namespace netkf::cli
