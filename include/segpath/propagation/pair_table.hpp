// A per-junction value (f_r(s, s'), or a whole path-conditioned junction) computed once per
// pool instead of once per propagation sweep, for as many groups of a JunctionSupport as fit a
// byte budget; the junctions of the other groups are evaluated on the fly by the caller.
#pragma once

#include "segpath/core/parallel.hpp"
#include "segpath/propagation/junction_support.hpp"

#include <algorithm>
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
///
/// The values are held in blocks of about block_bytes, each of whole groups (a larger group in
/// a block of its own), not in one array: the holes the earlier stages of a pool leave in the
/// heap fit such blocks, while an array of a hundred megabytes did not and grew the heap by
/// its size (docs/figures.md, session 39).
template <class V>
class PairTable {
  // A row is found by its address as an integer (row_), and no_row is odd: no row of a V
  // aligned to 2 bytes or more can have it.
  static_assert(alignof(V) >= 2, "segpath::PairTable: values aligned to at least 2 bytes");

 public:
  /// Besides the values, per ending slot of the support (where the table holds anything).
  static constexpr std::size_t bytes_per_ending_slot = sizeof(std::uintptr_t);
  /// The size blocks of small groups are filled up to.
  static constexpr std::size_t block_bytes = std::size_t(4) << 20;

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
    size_ = total;
    blocks_.clear();
    row_.assign(total > 0 ? std::size_t(std::ranges::size(support.ending_segments())) : 0, no_row);
    if (total == 0) return;
    // Each tabled group's block and its first value's place there (offset[g] becomes the latter).
    constexpr std::size_t block_values = std::max<std::size_t>(1, block_bytes / sizeof(V));
    std::vector<std::uint32_t> block_of(groups, 0);
    std::vector<std::size_t> block_size;
    for (std::size_t g = 0; g < groups; ++g) {
      if (offset[g] == none) continue;
      const std::size_t pairs = std::size_t(support.ending_slots(g).size()) * support.starting_slots(g).size();
      if (block_size.empty() || block_size.back() + pairs > std::max(block_values, pairs)) block_size.push_back(0);
      block_of[g] = std::uint32_t(block_size.size() - 1);
      offset[g] = block_size.back();
      block_size.back() += pairs;
    }
    blocks_.reserve(block_size.size());
    for (const std::size_t size : block_size) blocks_.emplace_back(size);
    parallel_for(groups, [&](std::size_t g) {
      if (offset[g] == none) return;
      const SlotRange ending = support.ending_slots(g), starting = support.starting_slots(g);
      V* const first = blocks_[block_of[g]].data() + offset[g];
      for (std::uint32_t i = ending.begin; i < ending.end; ++i) {
        V* const row = first + std::size_t(i - ending.begin) * starting.size();
        // Less starting.begin values, in unsigned arithmetic: find adds j values back.
        row_[i] = reinterpret_cast<std::uintptr_t>(row) - std::uintptr_t(starting.begin) * sizeof(V);
        for (std::uint32_t j = starting.begin; j < starting.end; ++j) row[j - starting.begin] = pair(g, i, j);
      }
    });
  }

  /// The value of pair (i, j), or nullptr where it is not tabled.
  [[nodiscard]] const V* find(std::uint32_t i, std::uint32_t j) const noexcept {
    if (row_.empty() || row_[i] == no_row) return nullptr;
    return reinterpret_cast<const V*>(row_[i] + std::uintptr_t(j) * sizeof(V));
  }
  /// The row of ending slot i from its group's first starting slot `first` on (the values of
  /// pairs (i, first), (i, first + 1), ...), or nullptr where the group is not tabled.
  [[nodiscard]] const V* row(std::uint32_t i, std::uint32_t first) const noexcept { return find(i, first); }
  /// The number of tabled pairs, and the bytes of their values.
  [[nodiscard]] std::size_t size() const noexcept { return size_; }
  [[nodiscard]] std::size_t value_bytes() const noexcept { return size_ * sizeof(V); }
  /// The number of blocks the values are held in.
  [[nodiscard]] std::size_t block_count() const noexcept { return blocks_.size(); }

 private:
  static constexpr std::uintptr_t no_row = ~std::uintptr_t(0);
  std::vector<std::vector<V>> blocks_;
  std::vector<std::uintptr_t> row_;  ///< per ending slot i: the address of pair (i, 0)'s value, or no_row
  std::size_t size_ = 0;
};

}  // namespace segpath
