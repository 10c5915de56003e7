// Numerical failure is data: a sample that would put NaN, Inf or a division by zero into
// an image is dropped and counted by reason instead.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace segpath {

enum class DropReason : std::uint8_t {
  non_finite,    ///< a contribution, density or position was NaN or Inf
  zero_density,  ///< a sample was returned with density <= 0
  degenerate,    ///< zero-length segment, zero-area primitive, or similar
};
inline constexpr std::size_t drop_reason_count = 3;

[[nodiscard]] constexpr const char* to_string(DropReason r) noexcept {
  switch (r) {
    case DropReason::non_finite: return "non-finite";
    case DropReason::zero_density: return "zero density";
    case DropReason::degenerate: return "degenerate";
  }
  return "unknown";
}

/// Per-reason counts of dropped samples; merge per-thread counters with +=.
struct DropCounters {
  std::array<std::uint64_t, drop_reason_count> counts{};

  constexpr void add(DropReason r) noexcept { ++counts[static_cast<std::size_t>(r)]; }
  [[nodiscard]] constexpr std::uint64_t operator[](DropReason r) const noexcept {
    return counts[static_cast<std::size_t>(r)];
  }
  [[nodiscard]] constexpr std::uint64_t total() const noexcept {
    std::uint64_t t = 0;
    for (auto c : counts) t += c;
    return t;
  }
  constexpr DropCounters& operator+=(const DropCounters& o) noexcept {
    for (std::size_t i = 0; i < drop_reason_count; ++i) counts[i] += o.counts[i];
    return *this;
  }
};

}  // namespace segpath
