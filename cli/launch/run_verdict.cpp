#include "run_verdict.hpp"
#include "netkf/links/link_statistics.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>

namespace netkf::cli {

std::string end_text(const RunFacts& f) {
  switch (f.end) {
    case RunEnd::duration: return "duration reached";
    case RunEnd::signal: return "signal";
    case RunEnd::finished: return f.finished_why;
    case RunEnd::running: return "running";
    case RunEnd::process_failed:
    case RunEnd::recording_failed: break;
  }
  return "failure";
}

void add_snapshot_facts(const LiveSnapshot& s, RunFacts& f) {
  f.estimates = s.estimates;
  f.silent_sensors.clear();
  f.all_links_drop_everything = true;
  for (const auto& l : s.links) {
    if (l.sensor_id == kControlLinkId) continue;  // the actuation link carries inputs, not samples
    if (l.samples_total == 0) f.silent_sensors.push_back(l.sensor_id);
    if (stationary_loss(l.link.loss) < 1.0) f.all_links_drop_everything = false;
  }
}

std::optional<std::string> incomplete_run(const RunFacts& f) {
  if (f.end == RunEnd::process_failed || f.end == RunEnd::recording_failed) return std::nullopt;
  if (f.estimates == 0) {
    char ran[32];
    std::snprintf(ran, sizeof ran, "%.1f", f.ran_for_s);
    return std::string("no estimate arrived during the run (") + ran + " s): the network never got ready";
  }
  if (f.estimates >= 10 && !f.silent_sensors.empty()) {
    std::string ids;
    for (int id : f.silent_sensors) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    return "sensors " + ids + " never sent a sample to the channel: the run did not include them";
  }
  if (f.estimates >= 100 && f.fused_periods == 0 && !f.all_links_drop_everything)
    return "no sample was fused in " + std::to_string(f.estimates) +
           " periods although the links deliver: the estimator never heard the channel";
  return std::nullopt;
}

std::string diverged_text(const RunFacts& f) {
  if (!f.diverged) return {};
  return *f.diverged + (f.outages_before.empty() ? std::string("; no process of the loop stalled before it")
                                                 : "; before it: " + f.outages_before);
}

RunVerdict judge_run(const RunFacts& f) {
  RunVerdict v;
  if (f.end == RunEnd::process_failed || f.end == RunEnd::recording_failed) v.failure = f.failure;
  else if (f.diverged && !f.allow_divergence) v.failure = diverged_text(f);
  else v.failure = incomplete_run(f);
  v.summary_end = v.failure ? "failure: " + *v.failure : f.diverged ? diverged_text(f) + " (allowed)" : end_text(f);
  v.exit = v.failure ? ExitCode::run_failed : ExitCode::ok;
  return v;
}

void conclude_run(const RunSummary& summary, const std::vector<Check>& checks, const std::string& scenario_name,
                  std::ostream& table, std::ostream* summary_out, const std::string& summary_file,
                  RunVerdict& verdict) {
  const auto results = evaluate_checks(checks, summary);
  if (!results.empty()) table << render_check_table(results) << std::flush;
  std::optional<std::string> failure;
  if (!all_passed(results)) {
    std::size_t failed = 0;
    for (const auto& r : results) failed += !r.passed;
    failure = std::to_string(failed) + " of " + std::to_string(results.size()) + " checks failed";
  }
  if (summary_out) {
    nlohmann::ordered_json j{{"scenario", scenario_name}, {"end", verdict.summary_end}};
    const auto body = summary_json(summary, results);
    for (const auto& item : body.items()) j[item.key()] = item.value();
    errno = 0;
    *summary_out << j.dump(2) << "\n";
    summary_out->flush();
    if (!*summary_out) {
      const std::string why = "cannot write the summary to " + summary_file + ": " + std::strerror(errno);
      failure = failure ? *failure + "; " + why : why;
    }
  }
  // A run that failed keeps its own failure.
  if (failure && !verdict.failure) {
    verdict.failure = failure;
    verdict.exit = ExitCode::run_failed;
  }
}

}  // namespace netkf::cli
