#pragma once
// A link as a person reads it: its parameters by name and a one-line description.
#include "netkf/links/link.hpp"

#include <string>
#include <utility>
#include <vector>

namespace netkf {

/// The model's parameters by name, as in a scenario file: {loss} for Bernoulli;
/// {p, r, loss_good, loss_bad} for Gilbert-Elliott.
std::vector<std::pair<std::string, double>> link_parameters(const LinkModel& model);
/// Whether the stationary loss is one of the model's parameters (Bernoulli); else a person
/// also reads the model in its user's form, loss and mean_burst (describe_link_model, the
/// channel catalogue's link).
bool link_parameters_include_loss(const LinkModel& model);
/// One line: "bernoulli loss=0.3", "gilbert_elliott p=0.05 r=0.5 loss_good=0 loss_bad=1
/// (loss 0.09091, mean burst 2)".
std::string describe_link_model(const LinkModel& model);
/// The loss model's description, then the delay when there is one ("delay 6±4 ms uniform").
std::string describe_link(const LinkSpec& link);

}  // namespace netkf
