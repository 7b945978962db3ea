#include "netkf/cli/live/run_summary.hpp"
#include "netkf/cli/live/live_model.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace netkf::cli {

namespace {

constexpr const char* kNoEstimate = "no estimate received";

Measured count(std::uint64_t v) {
  Measured m;
  m.value = static_cast<double>(v);
  m.count = true;
  return m;
}

Measured value(double v) {
  Measured m;
  if (std::isnan(v)) m.missing = "not a number";
  else m.value = v;
  return m;
}

Measured missing(std::string why, bool is_count = false) {
  Measured m;
  m.missing = std::move(why);
  m.count = is_count;
  return m;
}

/// One quantity of the run, by name (summary_names, measure and the JSON all read this table).
struct RunQuantity {
  const char* name;
  Measured (*measure)(const RunSummary&);
};

/// One quantity of each link, `link.ID.name`.
struct LinkQuantity {
  const char* name;
  Measured (*measure)(const RunSummary&, const LinkSummary&);
};

Measured latency_percentile(const RunSummary& s, double p) {
  if (s.latencies_ms.empty()) return missing("no period with a fused sample");
  return value(nearest_rank_percentile(s.latencies_ms, p));
}

std::string never_reported(const LinkSummary& l) {
  return "the channel never reported link " + link_name(l.id);
}

Measured observed_rate(const LinkSummary& l, const std::optional<double>& rate) {
  if (!l.reported) return missing(never_reported(l));
  if (!rate) return missing("link " + link_name(l.id) + " carried no sample since its model was last set");
  return value(*rate);
}

const RunQuantity kRunQuantities[] = {
    {"periods", [](const RunSummary& s) { return count(s.periods); }},
    {"rms_error",
     [](const RunSummary& s) {
       if (s.periods_scored == 0) return missing("no period with both truth and estimate");
       return value(std::sqrt(s.sum_squared_error / static_cast<double>(s.periods_scored)));
     }},
    {"rms_error_final",
     [](const RunSummary& s) {
       if (s.periods_scored_final == 0) return missing("no period with both truth and estimate");
       return value(std::sqrt(s.sum_squared_error_final / static_cast<double>(s.periods_scored_final)));
     }},
    {"mean_trace_P",
     [](const RunSummary& s) {
       if (s.periods == 0) return missing(kNoEstimate);
       return value(s.sum_trace_P / static_cast<double>(s.periods));
     }},
    {"mean_trace_P_pred",
     [](const RunSummary& s) {
       if (s.periods == 0) return missing(kNoEstimate);
       return value(s.sum_trace_P_pred / static_cast<double>(s.periods));
     }},
    {"late_fraction",
     [](const RunSummary& s) {
       // Without estimates nobody counted late samples: 0 would be a vacuous pass.
       if (s.periods == 0) return missing(kNoEstimate);
       std::uint64_t delivered = 0;
       for (const auto& l : s.links) {
         if (l.id == kControlLinkId) continue;  // inputs, not samples
         // A link without counts would leave its deliveries out of the denominator.
         if (!l.reported) return missing(never_reported(l));
         delivered += l.delivered;
       }
       if (delivered == 0) return missing("the channel delivered no sample");
       return value(static_cast<double>(s.late) / static_cast<double>(delivered));
     }},
    {"fused_fraction",
     [](const RunSummary& s) {
       if (s.periods == 0 || s.sensors == 0) return missing(kNoEstimate);
       return value(static_cast<double>(s.fused) / (static_cast<double>(s.periods) * s.sensors));
     }},
    {"periods_diverging",
     [](const RunSummary& s) {
       // 0 diverging periods out of 0 proves nothing.
       if (s.periods == 0) return missing(kNoEstimate, true);
       return count(s.periods_diverging);
     }},
    {"pipeline_latency_p50_ms", [](const RunSummary& s) { return latency_percentile(s, 50.0); }},
    {"pipeline_latency_p99_ms", [](const RunSummary& s) { return latency_percentile(s, 99.0); }},
    {"cost",
     [](const RunSummary& s) {
       const auto mean = s.cost.mean();
       if (!mean) return missing("an open loop, or no truth: no cost");
       return value(*mean);
     }},
};

const LinkQuantity kLinkQuantities[] = {
    {"samples",
     [](const RunSummary&, const LinkSummary& l) {
       return l.reported ? count(l.samples) : missing(never_reported(l), true);
     }},
    {"delivered",
     [](const RunSummary&, const LinkSummary& l) {
       return l.reported ? count(l.delivered) : missing(never_reported(l), true);
     }},
    {"dropped",
     [](const RunSummary&, const LinkSummary& l) {
       return l.reported ? count(l.dropped) : missing(never_reported(l), true);
     }},
    {"observed_loss",
     [](const RunSummary&, const LinkSummary& l) {
       if (!l.reported) return missing(never_reported(l));
       if (l.samples == 0) return missing("link " + link_name(l.id) + " carried no sample");
       return value(static_cast<double>(l.dropped) / static_cast<double>(l.samples));
     }},
    {"observed_arrival_rate_since_change",
     [](const RunSummary&, const LinkSummary& l) { return observed_rate(l, l.observed_rate_since_change); }},
    {"observed_arrival_rate_window",
     [](const RunSummary&, const LinkSummary& l) { return observed_rate(l, l.observed_rate_window); }},
    {"observed_window_samples",
     [](const RunSummary&, const LinkSummary& l) {
       return l.reported ? count(l.observed_window_samples) : missing(never_reported(l), true);
     }},
    {"late",
     [](const RunSummary& s, const LinkSummary& l) {
       return s.periods > 0 ? count(l.late) : missing(kNoEstimate, true);
     }},
    {"fused",
     [](const RunSummary& s, const LinkSummary& l) {
       return s.periods > 0 ? count(l.fused) : missing(kNoEstimate, true);
     }},
};

const LinkQuantity* link_quantity(const std::string& name) {
  for (const auto& q : kLinkQuantities)
    if (name == q.name) return &q;
  return nullptr;
}

std::string trim(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  const auto last = s.find_last_not_of(" \t");
  return s.substr(first, last - first + 1);
}

std::string join(const std::vector<std::string>& parts) {
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : ", ") + p;
  return out;
}

std::string link_ids_text(const std::vector<int>& link_ids) {
  std::vector<std::string> ids;
  for (int id : link_ids) ids.push_back(link_name(id));
  return ids.empty() ? "none" : join(ids);
}

/// "0.30125", "600", "n/a": a value as the table shows it.
std::string value_text(const Measured& m) {
  if (!m.measured()) return "n/a";
  if (m.count) return std::to_string(static_cast<std::uint64_t>(m.value));
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", m.value);
  return buf;
}

bool holds(double v, CheckOp op, double threshold) {
  switch (op) {
    case CheckOp::less: return v < threshold;
    case CheckOp::less_equal: return v <= threshold;
    case CheckOp::greater: return v > threshold;
    case CheckOp::greater_equal: return v >= threshold;
  }
  return false;
}

}  // namespace

std::vector<std::string> summary_names(const std::vector<int>& link_ids) {
  std::vector<std::string> names;
  for (const auto& q : kRunQuantities) names.emplace_back(q.name);
  for (int id : link_ids)
    for (const auto& q : kLinkQuantities) names.push_back("link." + link_name(id) + "." + q.name);
  return names;
}

Measured measure(const RunSummary& summary, const std::string& name) {
  for (const auto& q : kRunQuantities)
    if (name == q.name) return q.measure(summary);
  for (const auto& l : summary.links) {
    const std::string prefix = "link." + link_name(l.id) + ".";
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    if (const auto* q = link_quantity(name.substr(prefix.size()))) return q->measure(summary, l);
  }
  throw std::invalid_argument("no quantity named '" + name + "' in the run summary");
}

double nearest_rank_percentile(std::vector<double> values, double p) {
  if (values.empty() || !(p > 0.0 && p <= 100.0)) return std::numeric_limits<double>::quiet_NaN();
  // p × N is exact for whole percentages; one division, then the rank rounds up.
  const double rank = std::ceil(p * static_cast<double>(values.size()) / 100.0);
  const auto index = static_cast<std::size_t>(std::max(rank, 1.0)) - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(index), values.end());
  return values[index];
}

// ---------------------------------------------------------------- builder

RunSummaryBuilder::RunSummaryBuilder(const Scenario& scenario) {
  summary_.sensors = static_cast<int>(scenario.sensors.size());
  for (const auto& sensor : scenario.sensors) {
    LinkSummary l;
    l.id = sensor.id;
    summary_.links.push_back(l);
  }
  summary_.cost = RunningCost(scenario);
  if (scenario.actuation_link()) {  // link "control": the inputs' way to the plant
    LinkSummary l;
    l.id = kControlLinkId;
    summary_.links.push_back(l);
  }
}

RunSummaryBuilder::RunSummaryBuilder(const LiveModel& model) : RunSummaryBuilder(model.scenario()) { model_ = &model; }

const PeriodJoin& RunSummaryBuilder::join() const { return model_ ? model_->join() : own_join_; }

LinkSummary* RunSummaryBuilder::link(int sensor_id) {
  for (auto& l : summary_.links)
    if (l.id == sensor_id) return &l;
  return nullptr;
}

void RunSummaryBuilder::add_truth(const Truth& truth) {
  if (model_) take_model_score();
  else score(own_join_.add_truth(truth.k, truth.x));
  score_final(truth.k);
  summary_.cost.add(truth);
}

void RunSummaryBuilder::score_final(std::int64_t k) {
  auto f = finals_.find(k);
  const std::vector<double>* x = join().truth(k);
  if (f == finals_.end() || x == nullptr || static_cast<Eigen::Index>(x->size()) != f->second.x_hat.size()) return;
  double e2 = 0.0;
  for (std::size_t i = 0; i < x->size(); ++i) {
    const double d = (*x)[i] - f->second.x_hat(static_cast<Eigen::Index>(i));
    e2 += d * d;
  }
  auto& s = summary_;
  if (f->second.squared_error) {
    s.sum_squared_error_final += e2 - *f->second.squared_error;  // a revision replaces its period's term
  } else {
    s.sum_squared_error_final += e2;
    ++s.periods_scored_final;
  }
  f->second.squared_error = e2;
}

void RunSummaryBuilder::add_estimate(const Estimate& e) {
  auto& s = summary_;
  const auto k = static_cast<std::int64_t>(e.k);
  auto f = finals_.find(k);
  if (f == finals_.end()) f = finals_.emplace(k, Final{e.revision, e.x_hat, std::nullopt}).first;
  else if (e.revision >= f->second.revision) {
    f->second.revision = e.revision;
    f->second.x_hat = e.x_hat;
  }
  while (!finals_.empty() && finals_.begin()->first < k - PeriodJoin::kWindow) finals_.erase(finals_.begin());
  if (e.revision > 0) {
    // A correction of a period already counted: only its final error changes.
    ++s.revisions;
    score_final(k);
    return;
  }
  ++s.periods;
  s.sum_trace_P += e.trace_P();
  s.sum_trace_P_pred += e.trace_P_pred;
  s.fused += e.fused.size();
  for (int id : e.fused)
    if (auto* l = link(id)) ++l->fused;
  s.late += e.late;
  for (int id : e.late_sensors)
    if (auto* l = link(id)) ++l->late;  // a late sample of an unknown id still counts in `late`
  if (e.state == FilterState::diverging) ++s.periods_diverging;
  if (e.has_pipeline_latency()) {
    // The same latency as /metrics' netkf_pipeline_latency_seconds.
    const double ms = e.pipeline_latency_s() * 1e3;
    if (ms >= 0.0) s.latencies_ms.push_back(ms);
  }
  if (model_) take_model_score();
  else score(own_join_.add_estimate(static_cast<std::int64_t>(e.k), e.x_hat));
  score_final(k);
}

void RunSummaryBuilder::score(std::optional<double> squared_error) {
  if (!squared_error) return;
  summary_.sum_squared_error += *squared_error;
  ++summary_.periods_scored;
}

void RunSummaryBuilder::take_model_score() {
  // The same terms added in the same order as score() would: the same sum, bit for bit.
  summary_.sum_squared_error = model_->sum_squared_error();
  summary_.periods_scored = model_->periods_scored();
}

void RunSummaryBuilder::add_link_status(const LinkStatus& status) {
  LinkSummary* l = link(status.sensor_id);
  if (!l) return;  // not in the scenario (the live view warns about it)
  auto& last = last_[status.sensor_id];
  auto& before = before_restarts_[status.sensor_id];
  if (l->reported && (status.samples_total < last.samples || status.delivered_total < last.delivered ||
                      status.dropped_total < last.dropped)) {
    before.samples += last.samples;
    before.delivered += last.delivered;
    before.dropped += last.dropped;
  }
  last = {status.samples_total, status.delivered_total, status.dropped_total};
  l->reported = true;
  l->samples = before.samples + last.samples;
  l->delivered = before.delivered + last.delivered;
  l->dropped = before.dropped + last.dropped;
  ObservedRateWindow& window = windows_[status.sensor_id];
  window.add(status);
  l->observed_rate_since_change = observed_rate_since_change(status);
  l->observed_rate_window = window.rate();
  l->observed_window_samples = window.samples();
}

// ---------------------------------------------------------------- checks

const char* to_string(CheckOp op) {
  switch (op) {
    case CheckOp::less: return "<";
    case CheckOp::less_equal: return "<=";
    case CheckOp::greater: return ">";
    case CheckOp::greater_equal: return ">=";
  }
  return "?";
}

nlohmann::ordered_json measured_json(const Measured& m) {
  if (!m.measured()) return nullptr;
  if (m.count) return static_cast<std::uint64_t>(m.value);
  return m.value;  // an infinite value (an overflowing error) is written as null by the JSON library
}

Check parse_check_syntax(const std::string& text, const std::string& example) {
  const std::string quoted = "check '" + text + "': ";
  const std::string syntax = "write NAME<VALUE, NAME<=VALUE, NAME>VALUE or NAME>=VALUE, e.g. '" + example + "'";
  const auto pos = text.find_first_of("<>=!");
  if (pos == std::string::npos) throw std::invalid_argument(quoted + "no comparison; " + syntax);
  if (text[pos] == '=' || text[pos] == '!')
    throw std::invalid_argument(quoted + "unsupported operator (only <, <=, >, >=); " + syntax);
  Check c;
  c.text = text;
  const bool or_equal = pos + 1 < text.size() && text[pos + 1] == '=';
  c.op = text[pos] == '<' ? (or_equal ? CheckOp::less_equal : CheckOp::less)
                          : (or_equal ? CheckOp::greater_equal : CheckOp::greater);
  c.name = trim(text.substr(0, pos));
  const std::string number = trim(text.substr(pos + (or_equal ? 2 : 1)));
  if (c.name.empty()) throw std::invalid_argument(quoted + "no name on the left of '" + to_string(c.op) + "'; " + syntax);
  const char* first = number.data();
  const char* last = number.data() + number.size();
  const auto [end, ec] = std::from_chars(first, last, c.threshold);
  if (number.empty() || ec != std::errc() || end != last || !std::isfinite(c.threshold))
    throw std::invalid_argument(quoted + "the right side must be a finite number, got '" + number + "'");
  return c;
}

Check parse_check(const std::string& text, const std::vector<int>& link_ids) {
  const std::string quoted = "check '" + text + "': ";
  Check c = parse_check_syntax(text);
  const auto names = summary_names(link_ids);
  if (std::find(names.begin(), names.end(), c.name) != names.end()) return c;
  // link.ID.NAME with a real quantity but an id the scenario does not have: say so.
  if (c.name.rfind("link.", 0) == 0) {
    const auto dot = c.name.find('.', 5);
    if (dot != std::string::npos && link_quantity(c.name.substr(dot + 1)))
      throw std::invalid_argument(quoted + "link " + c.name.substr(5, dot - 5) +
                                  " is not in the scenario (its links: " + link_ids_text(link_ids) + ")");
  }
  std::vector<std::string> run_names;
  for (const auto& q : kRunQuantities) run_names.emplace_back(q.name);
  std::vector<std::string> link_names;
  for (const auto& q : kLinkQuantities) link_names.emplace_back(q.name);
  throw std::invalid_argument(quoted + "unknown name '" + c.name + "'; the names are " + join(run_names) +
                              ", and per link link.ID." + "{" + join(link_names) + "} for the links " +
                              link_ids_text(link_ids));
}

std::string CheckResult::verdict() const {
  if (passed) return "PASS";
  if (!measured.measured()) return "FAIL (not measured: " + measured.missing + ")";
  return "FAIL";
}

std::vector<CheckResult> evaluate_checks(const std::vector<Check>& checks, const RunSummary& summary) {
  return evaluate_checks(checks, [&summary](const std::string& name) { return measure(summary, name); });
}

std::vector<CheckResult> evaluate_checks(const std::vector<Check>& checks,
                                         const std::function<Measured(const std::string&)>& measure) {
  std::vector<CheckResult> results;
  for (const auto& c : checks) {
    CheckResult r;
    r.check = c;
    r.measured = measure(c.name);
    // A comparison with NaN is false for every operator: a value that is not there never passes.
    r.passed = r.measured.measured() && holds(r.measured.value, c.op, c.threshold);
    results.push_back(std::move(r));
  }
  return results;
}

bool all_passed(const std::vector<CheckResult>& results) {
  return std::all_of(results.begin(), results.end(), [](const CheckResult& r) { return r.passed; });
}

std::string render_check_table(const std::vector<CheckResult>& results) {
  std::size_t check_width = 5;  // "check"
  std::size_t value_width = 5;  // "value"
  for (const auto& r : results) {
    check_width = std::max(check_width, r.check.text.size());
    value_width = std::max(value_width, value_text(r.measured).size());
  }
  std::ostringstream out;
  auto row = [&](const std::string& check, const std::string& value, const std::string& verdict) {
    out << check << std::string(check_width - check.size() + 2, ' ') << value
        << std::string(value_width - value.size() + 2, ' ') << verdict << "\n";
  };
  row("check", "value", "verdict");
  std::size_t failed = 0;
  for (const auto& r : results) {
    row(r.check.text, value_text(r.measured), r.verdict());
    failed += !r.passed;
  }
  out << results.size() << (results.size() == 1 ? " check: " : " checks: ") << results.size() - failed
      << " passed, " << failed << " failed\n";
  return out.str();
}

nlohmann::ordered_json summary_json(const RunSummary& summary, const std::vector<CheckResult>& results) {
  // Insertion order: the file reads in the order of docs/experiments.md's definitions.
  nlohmann::ordered_json j;
  for (const auto& q : kRunQuantities) j[q.name] = measured_json(q.measure(summary));
  j["link"] = nlohmann::ordered_json::object();
  for (const auto& l : summary.links) {
    auto& link = j["link"][link_name(l.id)];
    for (const auto& q : kLinkQuantities) link[q.name] = measured_json(q.measure(summary, l));
  }
  j["checks"] = checks_json(results);
  j["passed"] = all_passed(results);
  return j;
}

nlohmann::ordered_json checks_json(const std::vector<CheckResult>& results) {
  auto checks = nlohmann::ordered_json::array();
  for (const auto& r : results) {
    nlohmann::ordered_json c{{"check", r.check.text},
                             {"name", r.check.name},
                             {"operator", to_string(r.check.op)},
                             {"threshold", r.check.threshold},
                             {"value", measured_json(r.measured)},
                             {"verdict", r.passed ? "PASS" : "FAIL"}};
    if (!r.measured.measured()) c["reason"] = "not measured: " + r.measured.missing;
    checks.push_back(std::move(c));
  }
  return checks;
}

}  // namespace netkf::cli
