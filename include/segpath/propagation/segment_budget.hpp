// Path length counted in segments when pooled segments stand for several (SPEC 1.8): a chain
// through delta bounces (a camera chain probe -> glass -> floor, a light chain light -> glass
// -> floor) is one pooled segment of p(s) pieces. Jacobi sweeps alone count pooled segments,
// so with chains they would sum paths longer than max_length. With a budget c of segments
// left after s,
//   A^(c)(s) = L_e(s) + sum_s' T(s, s') A^(c - p(s'))(s'),   A^(c < 0) = 0,
// and the value of s over paths of at most B segments is A^(B - p(s))(s). The lag sits on the
// start s', whose value propagation gathers once per sweep anyway, so the group sums (and
// their factorisation) are unchanged. What it costs: for each start (and each result) of a
// chain, p values of its source slot (LaggedValues), so memory grows with the chains (with a
// watch index per start record, and per slot in propagate.hpp, where there are any).
#pragma once

#include "segpath/core/parallel.hpp"

#include <algorithm>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

namespace segpath::detail {

/// max p(s), 1 for no pieces (every segment one); throws for a p of 0 or a size mismatch.
inline int max_pieces(std::span<const std::uint16_t> pieces, std::size_t segments) {
  if (pieces.empty()) return 1;
  if (pieces.size() != segments) throw std::invalid_argument("segpath::propagate: pieces has one entry per segment or none");
  const std::uint16_t most = *std::max_element(pieces.begin(), pieces.end());
  if (*std::min_element(pieces.begin(), pieces.end()) == 0) throw std::invalid_argument("segpath::propagate: a segment has 0 pieces");
  return int(most);
}

/// The values A^(b)(slot) of watched slots over the last p budgets, one ring of p per watch.
template <class V>
class LaggedValues {
 public:
  /// Watches ending slot `slot` for a reader of p > 1 pieces; returns the watch's id.
  std::uint32_t watch(std::uint32_t slot, std::uint16_t p) {
    slot_.push_back(slot);
    pieces_.push_back(p);
    offset_.push_back(std::uint32_t(size_));
    size_ += p;
    return std::uint32_t(slot_.size() - 1);
  }
  /// Allocates the rings (after the last watch).
  void allocate() { values_.assign(size_, V{}); }
  /// Keeps A^(budget) of every watched slot, `values` indexed by ending slot.
  template <ParallelFor P>
  void keep(int budget, std::span<const V> values, const P& parallel_for) {
    keep_each(budget, [&](std::uint32_t slot) -> const V& { return values[slot]; }, parallel_for);
  }
  /// keep, the value of ending slot i being value_of(i).
  template <class ValueOf, ParallelFor P>
  void keep_each(int budget, const ValueOf& value_of, const P& parallel_for) {
    for_blocks(slot_.size(), parallel_for, [&](std::size_t w) {
      values_[offset_[w] + std::size_t(budget % pieces_[w])] = value_of(slot_[w]);
    });
  }
  /// The rings' and their watches' bytes.
  [[nodiscard]] std::size_t bytes() const noexcept {
    return values_.capacity() * sizeof(V) + (slot_.capacity() + offset_.capacity()) * sizeof(std::uint32_t) +
           pieces_.capacity() * sizeof(std::uint16_t);
  }
  [[nodiscard]] std::uint32_t watch_count() const noexcept { return std::uint32_t(slot_.size()); }
  /// The ending slot watch `id` watches.
  [[nodiscard]] std::uint32_t slot(std::uint32_t id) const noexcept { return slot_[id]; }
  /// A^(budget) of watch `id`, for budget >= 1 within its last p kept budgets.
  [[nodiscard]] const V& at(std::uint32_t id, int budget) const noexcept {
    return values_[offset_[id] + std::size_t(budget % pieces_[id])];
  }

 private:
  std::vector<std::uint32_t> slot_, offset_;
  std::vector<std::uint16_t> pieces_;
  std::vector<V> values_;
  std::size_t size_ = 0;
};

inline constexpr std::uint32_t no_watch = 0xffffffffu;

}  // namespace segpath::detail
