// Keyed random numbers ("Determinism"): every random decision of a path is a pure
// function of (seed, pixel, sample, bounce, purpose, dimension), so the image does not
// depend on which thread traced a ray, in which batch, or in which order (docs/architecture.md
// invariant). SplitMix64's finaliser mixes the key; no state is carried between rays.
#pragma once
#include <cstdint>

namespace rayline::trace {

// What a random number is for; part of the key so that decisions never share numbers.
enum class Purpose : std::uint32_t { PixelJitter = 1, LightPick, LightPoint, Bounce, Roulette };

inline std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// The seed's part of every key, computed once per render instead of once per number.
struct SeedKey {
  std::uint64_t key;
  explicit SeedKey(std::uint64_t seed) : key(mix64(seed + 0x9E3779B97F4A7C15ull)) {}
};

class KeyedRng {
 public:
  KeyedRng(std::uint64_t seed, std::uint32_t pixel, std::uint32_t sample, std::uint32_t bounce, Purpose purpose)
      : KeyedRng(SeedKey(seed), pixel, sample, bounce, purpose) {}
  KeyedRng(SeedKey seed, std::uint32_t pixel, std::uint32_t sample, std::uint32_t bounce, Purpose purpose) {
    std::uint64_t k = mix64(seed.key ^ (std::uint64_t(pixel) << 32 | sample));
    k = mix64(k ^ (std::uint64_t(bounce) << 32 | std::uint32_t(purpose)));
    key_ = k;
  }
  // Dimension `dim` of this key, uniform in [0, 1) with 24 bits (exactly representable).
  float uniform(std::uint32_t dim) const {
    return float(mix64(key_ + (std::uint64_t(dim) + 1) * 0x9E3779B97F4A7C15ull) >> 40) * (1.0f / 16777216.0f);
  }

 private:
  std::uint64_t key_;
};

}  // namespace rayline::trace
