// PCG32 (O'Neill 2014): a small, fast generator with 2^63 independent streams, so every
// (pixel, sample index) pair gets its own reproducible stream whatever the thread count.
#pragma once

#include "segpath/core/vec.hpp"

#include <cstdint>

namespace segpath {

class Pcg32 {
 public:
  constexpr Pcg32() noexcept : Pcg32(0x853c49e6748fea9bULL, 0xda3e39cb94b95bdbULL) {}
  constexpr Pcg32(std::uint64_t seed, std::uint64_t stream) noexcept { reseed(seed, stream); }

  /// The stream of one (pixel, sample) pair under a global seed: the seed selects the
  /// sequence start, the mixed (pixel, sample) pair selects one of 2^63 streams.
  [[nodiscard]] static constexpr Pcg32 for_sample(std::uint64_t seed, std::uint64_t pixel,
                                                  std::uint64_t sample) noexcept {
    return Pcg32(mix(seed ^ mix(sample + 0x9e3779b97f4a7c15ULL)), mix(pixel * 0x100000001b3ULL + sample));
  }

  constexpr void reseed(std::uint64_t seed, std::uint64_t stream) noexcept {
    state_ = 0;
    inc_ = (stream << 1u) | 1u;
    next_u32();
    state_ += seed;
    next_u32();
  }

  constexpr std::uint32_t next_u32() noexcept {
    const std::uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    const auto rot = static_cast<std::uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }

  /// Uniform in [0, 1): 24 random bits for float (so the largest value is 1 - 2^-24),
  /// 32 for double.
  template <Real T>
  constexpr T uniform() noexcept {
    if constexpr (sizeof(T) == sizeof(float)) {
      return static_cast<T>(next_u32() >> 8) * T(0x1p-24);
    } else {
      return static_cast<T>(next_u32()) * T(0x1p-32);
    }
  }
  template <Real T>
  constexpr Vec2<T> uniform2() noexcept {
    const T a = uniform<T>();
    return Vec2<T>(a, uniform<T>());
  }

 private:
  /// SplitMix64 finaliser: decorrelates nearby (pixel, sample) indices.
  static constexpr std::uint64_t mix(std::uint64_t z) noexcept {
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }

  std::uint64_t state_ = 0;
  std::uint64_t inc_ = 1;
};

/// What segpath's samplers draw random numbers from: Pcg32, or a user's source (e.g. a
/// replayed sequence in a test, or a low-discrepancy sampler).
template <class R, class T>
concept UniformSource = Real<T> && requires(R& r) {
  { r.template uniform<T>() } -> std::same_as<T>;
};

/// Two uniforms from any UniformSource, in order (x first).
template <Real T, UniformSource<T> R>
[[nodiscard]] constexpr Vec2<T> uniform2(R& rng) noexcept {
  const T a = rng.template uniform<T>();
  return Vec2<T>(a, rng.template uniform<T>());
}

}  // namespace segpath
