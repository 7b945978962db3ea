// The link type (netkf/links/link.hpp): its one validation, its kind and model names.
#include "netkf/links/link.hpp"

#include "link_detail.hpp"
#include "netkf/links/link_trace.hpp"

#include <cstdio>
#include <iterator>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace netkf {
namespace {

// A delay above a minute is a typo in a tool whose periods are milliseconds.
constexpr double kMaxDelayMs = 60000.0;

}  // namespace

namespace link_detail {

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

void check_probability(const char* name, double value) {
  // Written as a negated range test so that NaN is rejected too.
  if (!(value >= 0.0 && value <= 1.0))
    throw LinkError(name, std::string(name) + " must be a probability in [0, 1], got " + number_text(value));
}

}  // namespace link_detail

using link_detail::check_probability;
using link_detail::number_text;

std::string link_error_at(const std::string& path, const LinkError& error) {
  const std::string what = error.what();
  if (!error.key().empty() && what.rfind(error.key() + " ", 0) == 0) return path + "." + what;
  return path + ": " + what;
}

void validate_link_model(const LinkModel& model) {
  std::visit(overloaded{[](const BernoulliLink& b) { check_probability("loss", b.loss); },
                        [](const GilbertElliottLink& g) {
                          check_probability("p", g.p);
                          check_probability("r", g.r);
                          check_probability("loss_good", g.loss_good);
                          check_probability("loss_bad", g.loss_bad);
                          // p = r = 0 leaves the chain's stationary distribution undefined (it
                          // would stay wherever it is).
                          if (g.p + g.r <= 0.0)
                            throw LinkError("p", "p and r cannot both be 0 (the chain would never move)");
                        }},
             model);
}

void validate_link(const LinkSpec& link) {
  validate_link_model(link.loss);
  if (link.trace && link.trace->rows && link.trace->offset >= link.trace->rows->size())
    throw LinkError("offset", "offset " + std::to_string(link.trace->offset) + " is past the trace's last row");
  for (const auto& [name, value] : {std::pair{"delay_ms", link.delay.delay_ms}, {"jitter_ms", link.delay.jitter_ms}}) {
    if (!(value >= 0.0 && value <= kMaxDelayMs))
      throw LinkError(name, std::string(name) + " must be in [0, " + number_text(kMaxDelayMs) + "] ms, got " +
                                number_text(value));
  }
}

std::string link_kind(const LinkSpec& link) { return link.trace ? "trace" : link_model_name(link.loss); }

std::string link_model_name(const LinkModel& model) {
  return std::visit(overloaded{[](const BernoulliLink&) { return "bernoulli"; },
                               [](const GilbertElliottLink&) { return "gilbert_elliott"; }},
                    model);
}

std::string link_model_label(const LinkModel& model) {
  return std::visit(overloaded{[](const BernoulliLink&) { return "Bernoulli"; },
                               [](const GilbertElliottLink&) { return "Gilbert-Elliott"; }},
                    model);
}

std::vector<LinkModel> one_link_of_each_model() {
  // Not default-constructed: a change of one key (r: 0 alone) must meet a chain it leaves valid.
  static constexpr LinkModel kOneOfEach[] = {BernoulliLink{0.5}, GilbertElliottLink{0.1, 0.5, 0.0, 1.0}};
  static_assert(std::size(kOneOfEach) == std::variant_size_v<LinkModel>, "one link of each model: a model is missing");
  return {std::begin(kOneOfEach), std::end(kOneOfEach)};
}

std::optional<LinkModel> link_model_named(const std::string& name) {
  for (const LinkModel& model : one_link_of_each_model())
    if (link_model_name(model) == name) return model;
  return std::nullopt;
}

std::string link_model_choices() {
  std::string out;
  for (const LinkModel& model : one_link_of_each_model()) out += link_model_name(model) + ", ";
  out.erase(out.size() - 2);
  return out + " or trace";
}

}  // namespace netkf
