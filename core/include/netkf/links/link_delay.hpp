#pragma once
// A link's delay distribution (netem's names and tables): the chance that a delivered sample
// is in time and the delay of a quantile.
#include "netkf/links/link.hpp"

#include <string>

namespace netkf {

/// "uniform", "normal", "pareto", "paretonormal"; parse throws LinkError on anything else.
std::string delay_distribution_name(DelayDistribution d);
DelayDistribution parse_delay_distribution(const std::string& name);

/// P(delay <= deadline_ms): the chance that a delivered sample is in time.
double probability_within(const LinkDelay& delay, double deadline_ms);
/// The delay of a standard quantile q in [0,1) (the inverse of probability_within): the
/// delay process draws q uniformly and returns this.
double delay_quantile(const LinkDelay& delay, double q);

}  // namespace netkf
