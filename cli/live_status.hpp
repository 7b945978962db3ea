#pragma once
// The compact live status of `netkf launch` (and `netkf ctl status`): period, per-link
// configured and observed arrival rates, Tr P, estimation error |x − x̂| (truth joined
// by k) and the theory's verdict on the operating point. Pure bookkeeping: fed records
// by the caller, no DDS, so it is unit-testable.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "live_records.hpp"
#include "netkf/scenario.hpp"

namespace netkf::cli {

/// Link model from a status record's name + parameters; nullopt when malformed.
std::optional<LinkModel> link_model_from_status(const LinkStatusRecord& status);
/// "bernoulli loss=0.3" / "gilbert_elliott p=0.05 r=0.5 loss_good=0 loss_bad=1".
std::string describe_link(const std::string& model, const std::vector<double>& params);

/// Table of links (used by `ctl status` and the launch status).
std::string render_link_table(const std::vector<LinkStatusRecord>& links);

class LiveStatus {
 public:
  explicit LiveStatus(Scenario scenario);

  void add_truth(const TruthRecord& truth);
  void add_estimate(const EstimateRecord& estimate);
  void add_link_status(const LinkStatusRecord& status);

  /// Multi-line status text. `with_theory` runs the operating-point assessment
  /// (a few ms; call about once a second).
  std::string render(bool with_theory = true);
  /// Warnings raised since the last call (e.g. a link change moved the network
  /// below the critical boundary).
  std::vector<std::string> take_warnings();

  std::optional<std::int64_t> last_period() const { return last_k_; }
  std::uint64_t estimates_seen() const { return estimates_seen_; }
  bool saw_non_finite() const { return saw_non_finite_; }

 private:
  struct LinkView {
    LinkStatusRecord last;
    double observed_rate = -1.0;  // delivered / samples_in since the previous report (< 0: unknown)
  };
  void score(std::int64_t k);

  Scenario scenario_;
  std::map<std::int64_t, std::vector<double>> truth_;     // recent truth by k
  std::map<std::int64_t, EstimateRecord> estimates_;      // recent estimates by k
  std::map<int, LinkView> links_;
  std::optional<std::int64_t> last_k_;
  std::optional<EstimateRecord> last_estimate_;
  std::uint64_t estimates_seen_ = 0;
  double sum_trace_ = 0.0;
  std::optional<double> last_error_;
  double sum_sq_error_ = 0.0;
  std::uint64_t scored_ = 0;
  bool saw_non_finite_ = false;
  std::string last_configured_verdict_;
  std::vector<std::string> warnings_;
};

}  // namespace netkf::cli
