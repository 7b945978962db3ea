#pragma once
// How a launch judges its run once everything is recorded, without DDS: why it ended, whether
// it was a run of the scenario at all, the user's checks, and the exit status.
#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "netkf/cli/common/exit_code.hpp"
#include "netkf/cli/live/live_snapshot.hpp"
#include "netkf/cli/live/run_summary.hpp"

namespace netkf::cli {

/// Why the serve loop of a launch ended.
enum class RunEnd {
  running,          // not yet
  duration,         // --duration reached
  signal,           // SIGINT / SIGTERM
  finished,         // the run ended on its own (the plant; without the plant, its presence)
  process_failed,   // the supervisor gave up (a process died for good)
  recording_failed  // a recording could not be written (e.g. the disk is full)
};

/// What the run did, as the launch saw it at its end.
struct RunFacts {
  RunEnd end = RunEnd::running;
  std::string finished_why;             // RunEnd::finished: who ended the run
  std::string failure;                  // process_failed / recording_failed: the reason
  std::uint64_t estimates = 0;          // estimates seen
  std::uint64_t fused_periods = 0;      // estimates that fused at least one sample
  std::vector<int> silent_sensors;      // links whose sensor never sent a sample to the channel
  bool all_links_drop_everything = false;  // then an estimate without samples is right
  double ran_for_s = 0.0;
  /// The plant's word that the closed loop left plant.state_bound (its ended presence), and the
  /// outages of the loop's processes just before (OutageWatch; "" when none was seen).
  std::optional<std::string> diverged;
  std::string outages_before;
  bool allow_divergence = false;  // --allow-divergence: a run started to show an unstable loop
};

/// The end as a person reads it: "duration reached", "signal", who ended the run, "failure".
std::string end_text(const RunFacts& facts);

/// A run in which a sensor never sent anything (its process never started, never matched, or
/// the plant ran without it) or in which no estimate arrived is not a run of the scenario: it
/// fails loudly rather than ending "ok" (judged once the run had time: 10 estimates).
std::optional<std::string> incomplete_run(const RunFacts& facts);

/// A diverged closed loop as a person reads it: the plant's words and the outages before it.
std::string diverged_text(const RunFacts& facts);

/// The facts of a snapshot: silent sensors, whether every link drops every sample.
void add_snapshot_facts(const LiveSnapshot& snapshot, RunFacts& facts);

struct RunVerdict {
  ExitCode exit = ExitCode::ok;
  std::string summary_end;               // the summary's "end": the end text or "failure: why"
  std::optional<std::string> failure;    // why the run failed (exit run_failed)
};

/// The verdict before the checks: a failed run keeps its own failure, then a closed loop that
/// diverged (unless allowed), then an incomplete one.
RunVerdict judge_run(const RunFacts& facts);

/// The end of a run that asked for checks or a summary: the checks' table on `table`, the
/// summary's JSON (with the verdict's end and every check's result) on `summary_out` when
/// given. A verdict without a failure gets why the run fails its checks or the summary was not
/// written (a run that failed keeps its own failure).
void conclude_run(const RunSummary& summary, const std::vector<Check>& checks, const std::string& scenario_name,
                  std::ostream& table, std::ostream* summary_out, const std::string& summary_file, RunVerdict& verdict);

}  // namespace netkf::cli
