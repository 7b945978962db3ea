// The link type (netkf/links/link.hpp): its one validation, its kind and model names.
#include "netkf/links/link.hpp"

#include "link_detail.hpp"
#include "netkf/links/link_trace.hpp"

#include <cstdio>
#include <string>
#include <utility>
#include <variant>

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
  if (const auto* b = std::get_if<BernoulliLink>(&model)) {
    check_probability("loss", b->loss);
    return;
  }
  const auto& g = std::get<GilbertElliottLink>(model);
  check_probability("p", g.p);
  check_probability("r", g.r);
  check_probability("loss_good", g.loss_good);
  check_probability("loss_bad", g.loss_bad);
  // p = r = 0 leaves the chain's stationary distribution undefined (it would stay wherever it is).
  if (g.p + g.r <= 0.0) throw LinkError("p", "p and r cannot both be 0 (the chain would never move)");
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
  return std::holds_alternative<BernoulliLink>(model) ? "bernoulli" : "gilbert_elliott";
}

}  // namespace netkf
