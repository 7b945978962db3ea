// A link as text (netkf/links/link_text.hpp): its parameters by name and one-line descriptions.
#include "netkf/links/link_text.hpp"

#include "netkf/links/link_delay.hpp"
#include "netkf/links/link_statistics.hpp"
#include "netkf/links/link_trace.hpp"

#include <cstdio>
#include <string>
#include <variant>

namespace netkf {

std::vector<std::pair<std::string, double>> link_parameters(const LinkModel& model) {
  using Parameters = std::vector<std::pair<std::string, double>>;
  return std::visit(
      overloaded{[](const BernoulliLink& b) -> Parameters { return {{"loss", b.loss}}; },
                 [](const GilbertElliottLink& g) -> Parameters {
                   return {{"p", g.p}, {"r", g.r}, {"loss_good", g.loss_good}, {"loss_bad", g.loss_bad}};
                 }},
      model);
}

bool link_parameters_include_loss(const LinkModel& model) {
  for (const auto& parameter : link_parameters(model))
    if (parameter.first == "loss") return true;
  return false;
}

std::string describe_link_model(const LinkModel& model) {
  std::string text = link_model_name(model);
  for (const auto& [name, value] : link_parameters(model)) {
    char number[32];
    std::snprintf(number, sizeof number, "%.4g", value);
    text += " " + name + "=" + number;
  }
  if (!link_parameters_include_loss(model)) {
    // Both forms: the model's parameters and what they mean to a user.
    char both[96];
    std::snprintf(both, sizeof both, " (loss %.4g, mean burst %.4g)", stationary_loss(model), mean_burst_length(model));
    text += both;
  }
  return text;
}

std::string describe_link(const LinkSpec& link) {
  std::string text;
  if (link.trace) {
    text = "trace " + link.trace->path + " offset=" + std::to_string(link.trace->offset) +
           (link.trace->loop ? " loop" : " no loop");
    if (link.trace->rows) text += " (" + std::to_string(link.trace->rows->size()) + " rows)";
    text += ", empirical " + describe_link_model(link.loss);
    if (link.trace->rows && link.trace->rows->has_delay) return text + ", delay from the trace";
  } else {
    text = describe_link_model(link.loss);
  }
  if (!link.delay.none()) {
    char delay[96];
    std::snprintf(delay, sizeof delay, ", delay %.4g±%.4g ms %s", link.delay.delay_ms, link.delay.jitter_ms,
                  delay_distribution_name(link.delay.distribution).c_str());
    text += delay;
  }
  return text;
}

}  // namespace netkf
