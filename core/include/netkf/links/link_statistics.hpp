#pragma once
// What the theory needs of a link: its stationary loss and mean burst, the model of a
// measured trace, and the loss a sample later than the estimator's deadline adds.
#include "netkf/links/link.hpp"

#include <optional>

namespace netkf {

/// Stationary probability that a sample is dropped.
double stationary_loss(const LinkModel& model);
/// Mean length of a run of consecutive drops (infinite if the link never delivers).
double mean_burst_length(const LinkModel& model);
/// The arrival rate 1 − loss of a model whose drops are i.i.d. (Bernoulli); none for a model
/// with memory (Gilbert-Elliott), to which the i.i.d. closed forms of the theory do not apply.
std::optional<double> iid_arrival_rate(const LinkModel& model);

/// The theory's model of a trace: the simple Gilbert channel (loss_good 0, loss_bad 1) with
/// the trace's own loss and mean burst (r = 1/mean burst, p = r·loss/(1 − loss)), which
/// is Bernoulli when the trace's drops are i.i.d.; bernoulli 0 or 1 for a trace that
/// delivers everything or nothing. Throws LinkError("trace") on an empty trace.
LinkModel empirical_link_model(const LinkTrace& trace);

/// The loss model the estimator sees when a sample later than `deadline_ms` counts as lost:
/// Bernoulli 1 − (1 − loss)·P(delay ≤ D); Gilbert-Elliott with loss_good and loss_bad
/// thinned the same way (the delay is drawn independently of the chain, so the arrivals
/// are again a Gilbert-Elliott chain with the same p, r). Exact for i.i.d. delays; not for
/// delays that depend on the chain's state or on each other.
LinkModel effective_loss_model(const LinkSpec& link, double deadline_ms);
/// The rate at which a link's samples arrive in time, λ = (1 − stationary loss)·in_time with
/// in_time = P(delay ≤ deadline): the one place this product is written.
double arrival_rate(const LinkModel& loss, double in_time);
/// arrival_rate of the link at `deadline_ms` (= 1 − stationary loss of its effective model).
double effective_arrival_rate(const LinkSpec& link, double deadline_ms);

}  // namespace netkf
