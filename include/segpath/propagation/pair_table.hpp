// A per-junction value (f_r(s, s'), or a whole path-conditioned junction) computed once per
// pool instead of once per propagation sweep, for as many groups of a JunctionSupport as fit a
// byte budget; the junctions of the other groups are evaluated on the fly by the caller.
#pragma once

#include "segpath/core/parallel.hpp"
#include "segpath/propagation/junction_support.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace segpath {

/// Values V per (ending slot i, starting slot j) pair of a group, for the groups that fit the
/// budget: groups are taken in order, each whole or not at all (one that does not fit is
/// skipped, a later smaller one may still fit), and groups marked in `skip` (e.g. factorised
/// ones, whose pairs are never read) are left out. Within a group the values are ending-slot
/// major, each row in starting slot order. Memory: the values plus, where anything is tabled,
/// bytes_per_ending_slot per ending slot.
template <class V>
class PairTable {
 public:
  /// Besides the values, per ending slot of the support (where the table holds anything).
  static constexpr std::size_t bytes_per_ending_slot = sizeof(std::int64_t);

  /// Tables `pair(g, i, j)` (-> V; group g, ending slot i, starting slot j) for every pair of
  /// the groups that fit `budget_bytes` and are not marked in `skip` (empty, or one flag per
  /// group); pair is called once per tabled pair, in parallel over groups.
  template <JunctionSupport J, class Pair, ParallelFor P = SerialFor>
  void build(const J& support, std::size_t budget_bytes, std::span<const std::uint8_t> skip, const Pair& pair,
             const P& parallel_for = {}) {
    const std::size_t groups = support.group_count();
    constexpr std::size_t none = ~std::size_t(0);
    std::vector<std::size_t> offset(groups, none);
    const std::size_t budget = budget_bytes / sizeof(V);
    std::size_t total = 0;
    for (std::size_t g = 0; g < groups; ++g) {
      if (!skip.empty() && skip[g]) continue;
      const std::size_t pairs = std::size_t(support.ending_slots(g).size()) * support.starting_slots(g).size();
      if (pairs == 0 || total + pairs > budget) continue;
      offset[g] = total;
      total += pairs;
    }
    value_.assign(total, V{});
    row_.assign(total > 0 ? std::size_t(std::ranges::size(support.ending_segments())) : 0, no_row);
    if (total == 0) return;
    parallel_for(groups, [&](std::size_t g) {
      if (offset[g] == none) return;
      const SlotRange ending = support.ending_slots(g), starting = support.starting_slots(g);
      for (std::uint32_t i = ending.begin; i < ending.end; ++i) {
        const std::size_t base = offset[g] + std::size_t(i - ending.begin) * starting.size();
        row_[i] = std::int64_t(base) - std::int64_t(starting.begin);
        for (std::uint32_t j = starting.begin; j < starting.end; ++j) value_[base + (j - starting.begin)] = pair(g, i, j);
      }
    });
  }

  /// The value of pair (i, j), or nullptr where it is not tabled.
  [[nodiscard]] const V* find(std::uint32_t i, std::uint32_t j) const noexcept {
    if (row_.empty() || row_[i] == no_row) return nullptr;
    return value_.data() + std::size_t(row_[i] + j);
  }
  /// The row of ending slot i from its group's first starting slot `first` on (the values of
  /// pairs (i, first), (i, first + 1), ...), or nullptr where the group is not tabled.
  [[nodiscard]] const V* row(std::uint32_t i, std::uint32_t first) const noexcept { return find(i, first); }
  /// The number of tabled pairs, and the bytes of their values.
  [[nodiscard]] std::size_t size() const noexcept { return value_.size(); }
  [[nodiscard]] std::size_t value_bytes() const noexcept { return value_.size() * sizeof(V); }

 private:
  static constexpr std::int64_t no_row = -(std::int64_t(1) << 62);
  std::vector<V> value_;
  std::vector<std::int64_t> row_;  ///< per ending slot i: value_[row_[i] + j] for starting slot j, or no_row
};

}  // namespace segpath
