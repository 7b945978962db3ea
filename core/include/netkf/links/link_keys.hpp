#pragma once
// A link's keys: its parameters by the names a person writes (docs/scenario-format.md,
// "Links"), how a change of some keys applies to a link, and the trace files keys name.
#include "netkf/links/link.hpp"

#include <memory>
#include <string>
#include <variant>
#include <vector>

namespace netkf {

/// One link key as written by a person: a number, or a word (`model`, `delay_distribution`).
struct LinkKey {
  std::string name;
  std::variant<double, std::string> value;
  bool operator==(const LinkKey&) const = default;
};
using LinkKeys = std::vector<LinkKey>;

/// Every key a link understands, in the order documented.
const std::vector<std::string>& link_key_names();
/// True for keys whose value is a word (model, delay_distribution, trace, loop).
bool link_key_is_word(const std::string& name);

/// The link `current` with `keys` applied; the keys not given keep their values. Rules
/// (docs/scenario-format.md, "Links"): giving `model` rebuilds the loss model from the keys
/// given (its required keys must be there); without it the keys change the current model's
/// parameters. A Gilbert-Elliott link may be given by p, r, loss_good, loss_bad or by the
/// user's form loss + mean_burst (the simple Gilbert channel: loss_good 0, loss_bad 1,
/// r = 1/mean_burst, p = r·loss/(1 − loss)); the forms do not mix. The result is validated.
/// Throws LinkError naming the first offending key; `current` is unchanged either way.
/// A trace link (model: trace, trace: FILE) reads FILE here, unless it is the current link's
/// file or in `preloaded`.
LinkSpec apply_link_keys(const LinkSpec& current, const LinkKeys& keys, const TraceRows* preloaded = nullptr);
/// A link from keys alone (`model` required).
LinkSpec link_from_keys(const LinkKeys& keys);
/// The whole link as keys (model, its parameters, delay_ms, jitter_ms, delay_distribution):
/// apply_link_keys(anything, link_keys(l)) == l.
LinkKeys link_keys(const LinkSpec& link);
/// The current value of a numeric key (for a Gilbert-Elliott link also `loss` and
/// `mean_burst` in the user's form). Throws LinkError when the key does not apply.
double link_key_value(const LinkSpec& link, const std::string& name);

/// Read a trace file for a link (link_trace.hpp's reader). Throws LinkError("trace", ...)
/// carrying the trace's FILE:LINE:COL message.
std::shared_ptr<const LinkTrace> read_link_trace_for(const std::string& path);
/// Read each trace a timeline event's `keys` name into `traces`, once per path, at start (never
/// per sample). One that cannot be read is left out: the loader read it already, so it has gone
/// since, and the event fails when it is due (journaled as such).
void read_event_traces(const LinkKeys& keys, TraceRows& traces);

}  // namespace netkf
