// Seeded, portable random streams (netkf/random.hpp).
// xoshiro256++ and splitmix64 are Blackman & Vigna's generators
// (https://prng.di.unimi.it/); the normal draw is Marsaglia's polar method, which
// needs only uniform(), log and sqrt, so every platform gives the same numbers
// (std::normal_distribution is implementation-defined).
#include "netkf/random.hpp"

#include <cmath>

namespace netkf {
namespace {

constexpr std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

// FNV-1a (64 bit) of the stream name: a fixed, portable string hash
// (std::hash is implementation-defined).
std::uint64_t fnv1a(std::string_view text) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (const char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ULL;
  }
  return h;
}

}  // namespace

std::uint64_t splitmix64(std::uint64_t& state) {
  state += 0x9e3779b97f4a7c15ULL;
  std::uint64_t z = state;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

std::uint64_t derive_seed(std::uint64_t scenario_seed, std::string_view stream, std::uint64_t index) {
  // Chain the three inputs through splitmix64 so that every one of them changes
  // every output bit: seed, then the stream name's hash, then the index.
  std::uint64_t state = scenario_seed;
  state = splitmix64(state) ^ fnv1a(stream);
  state = splitmix64(state) ^ index;
  return splitmix64(state);
}

Rng::Rng(std::uint64_t seed) {
  // The xoshiro authors' recommended seeding: four splitmix64 outputs, which are
  // never all zero (splitmix64 is a bijection of a counter).
  std::uint64_t state = seed;
  for (auto& word : s_) word = splitmix64(state);
}

std::uint64_t Rng::next_u64() {
  const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
  const std::uint64_t t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double Rng::uniform() {
  // Top 53 bits -> a double in [0, 1) with uniform spacing 2^-53.
  return static_cast<double>(next_u64() >> 11) * 0x1.0p-53;
}

double Rng::standard_normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  double u = 0.0;
  double v = 0.0;
  double s = 0.0;
  do {
    u = 2.0 * uniform() - 1.0;
    v = 2.0 * uniform() - 1.0;
    s = u * u + v * v;
  } while (s >= 1.0 || s == 0.0);
  const double scale = std::sqrt(-2.0 * std::log(s) / s);
  spare_ = v * scale;
  has_spare_ = true;
  return u * scale;
}

}  // namespace netkf
