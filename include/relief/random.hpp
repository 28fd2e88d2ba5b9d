#pragma once
// Counter-based randomness: a pure function of (seed, counters). Never a global RNG and never
// std::uniform_*_distribution (its output differs between standard libraries).
#include <cstdint>

namespace relief {

// SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer.
constexpr std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}
constexpr std::uint64_t hash64(std::uint64_t a, std::uint64_t b) { return mix64(a ^ mix64(b)); }
constexpr std::uint64_t hash64(std::uint64_t a, std::uint64_t b, std::uint64_t c) { return hash64(hash64(a, b), c); }
// Uniform double in [0, 1) from the top 53 bits.
constexpr double unit_double(std::uint64_t h) { return double(h >> 11) * (1.0 / 9007199254740992.0); }

}  // namespace relief
