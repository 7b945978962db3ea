#pragma once
// What the unit tests of links, scenario events and the channel share: readable failures
// (links, keys and events printed as their keys, numbers to 17 digits) and short key builders.
#include <iomanip>
#include <ostream>
#include <string>
#include <variant>

#include "netkf/links/link.hpp"
#include "netkf/links/link_keys.hpp"
#include "netkf/model/scenario.hpp"

namespace netkf {
inline void PrintTo(const LinkKeys& keys, std::ostream* os) {
  *os << "{";
  for (const auto& k : keys) {
    *os << " " << k.name << ": ";
    if (const auto* w = std::get_if<std::string>(&k.value)) {
      *os << *w;
    } else {
      *os << std::setprecision(17) << std::get<double>(k.value);
    }
  }
  *os << " }";
}
inline void PrintTo(const LinkSpec& link, std::ostream* os) { PrintTo(link_keys(link), os); }
inline void PrintTo(const BernoulliLink& b, std::ostream* os) { PrintTo(LinkSpec(b), os); }
inline void PrintTo(const GilbertElliottLink& g, std::ostream* os) { PrintTo(LinkSpec(g), os); }
inline void PrintTo(const LinkEvent& e, std::ostream* os) {
  *os << "{ at_period: " << e.at_period << ", link: " << e.link
      << (e.kind == LinkEvent::Kind::set ? ", set: " : ", ramp over " + std::to_string(e.ramp_periods) + " to: ");
  PrintTo(e.keys, os);
  *os << " }";
}
}  // namespace netkf

namespace netkf_test {
/// A word key ("model: bernoulli") and a number key ("loss: 0.3").
inline netkf::LinkKey word(const std::string& name, const std::string& value) { return {name, value}; }
inline netkf::LinkKey num(const std::string& name, double value) { return {name, value}; }
}  // namespace netkf_test
