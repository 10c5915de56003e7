// The JunctionSupport concept: which segment ends join which segment starts (SPEC 1.2, 1.8
// step 2), as propagation reads it. Voxel clusters (propagation/clustering.hpp) and disks
// (propagation/disk_junctions.hpp) both model it, so each weighting's propagation is written
// once. Customization points (members of the support type J):
//   J::Scalar, J::factorisable, J::single_start, group_count(), segment_count(), ending_slots(g),
//   starting_slots(g), kernel(g), ending_segments(), starting_segments(), ending_slot_of(s).
#pragma once

#include "segpath/core/spectrum.hpp"

#include <concepts>
#include <cstddef>
#include <cstdint>
#include <ranges>
#include <utility>

namespace segpath {

/// "No slot": a segment whose y end joins nothing (not a surface point, or in no cluster).
inline constexpr std::uint32_t no_cluster = 0xffffffffu;

/// A contiguous range of slots [begin, end).
struct SlotRange {
  std::uint32_t begin = 0, end = 0;

  [[nodiscard]] constexpr std::uint32_t size() const noexcept { return end - begin; }
  [[nodiscard]] constexpr bool contains(std::uint32_t slot) const noexcept { return slot >= begin && slot < end; }
  friend constexpr bool operator==(const SlotRange&, const SlotRange&) = default;
};

namespace detail {
template <class J>
concept HasSupportScalar = requires { typename J::Scalar; } && Real<typename J::Scalar>;

template <class J>
concept HasFactorisable = requires {
  { J::factorisable } -> std::convertible_to<bool>;
  typename std::bool_constant<J::factorisable>;  // a constant expression
};

template <class J>
concept HasSingleStart = requires {
  { J::single_start } -> std::convertible_to<bool>;
  typename std::bool_constant<J::single_start>;  // a constant expression
};

template <class J>
concept HasGroups = requires(const J& j, std::size_t g) {
  { j.group_count() } -> std::convertible_to<std::size_t>;
  { j.segment_count() } -> std::convertible_to<std::size_t>;
  { j.ending_slots(g) } -> std::same_as<SlotRange>;
  { j.starting_slots(g) } -> std::same_as<SlotRange>;
};

template <class J>
concept HasGroupKernel = HasSupportScalar<J> && requires(const J& j, std::size_t g) {
  { j.kernel(g) } -> std::convertible_to<typename J::Scalar>;
};

/// A random-access range of segment ids, one per slot.
template <class R>
concept SlotSegments = std::ranges::random_access_range<R> && std::ranges::sized_range<R> &&
                       std::convertible_to<std::ranges::range_value_t<R>, std::uint32_t>;

template <class J>
concept HasSlotSegments = requires(const J& j) {
  { j.ending_segments() } -> SlotSegments;
  { j.starting_segments() } -> SlotSegments;
};

template <class J>
concept HasEndingSlotOf = requires(const J& j, std::uint32_t s) {
  { j.ending_slot_of(s) } -> std::convertible_to<std::uint32_t>;
};
}  // namespace detail

/// Junctions in slot form: the segments' ends are numbered by slot, ending slots (y ends) and
/// starting slots (x ends), and the junctions come in groups.
///  1. J::Scalar is the Real of the kernel values;
///  2. J::factorisable (a constant): whether a group may hold several ending slots, so that
///     propagation can sum a group's starts once for all its ends where the caller's link
///     factorises (voxel clusters); false: it never factorises anything (disks: one end each);
///  3. J::single_start (a constant): whether every segment has at most one starting slot
///     (clusters: its x end is in one cluster). Propagation keeps what it reads of a start
///     per starting slot, in order, where it is; per segment (read at random) where not, so
///     that its memory stays O(#segments) when a segment starts in many groups (disks);
///  4. group_count(), segment_count(); ending_slots(g) and starting_slots(g), g <
///     group_count(): the SlotRange of group g's ends and starts;
///  5. kernel(g): the kernel value K_g of every junction of group g (N19);
///  6. ending_segments()[i], starting_segments()[j]: the segment of ending slot i and of
///     starting slot j;
///  7. ending_slot_of(s): the ending slot of segment s, or no_cluster.
/// Semantics: every ending slot of g joins every starting slot of g whose segment is not its
/// own (a segment never joins itself), with kernel K_g; nothing else joins. Each segment has
/// at most one ending slot (ending_slot_of inverts ending_segments()) and may have several
/// starting slots (one per group it starts in). Propagation sums a group's starts in increasing
/// slot order: that order is part of the result.
template <class J>
concept JunctionSupport = detail::HasSupportScalar<J> && detail::HasFactorisable<J> && detail::HasSingleStart<J> && detail::HasGroups<J> &&
                          detail::HasGroupKernel<J> && detail::HasSlotSegments<J> && detail::HasEndingSlotOf<J>;

/// Where propagation keeps what it reads of a start (J::single_start): one record per starting
/// slot, the slot itself, where every segment starts at most once (read in slot order); else
/// one per segment, starting slot j reading the record of its segment.
template <JunctionSupport J>
class StartRecords {
 public:
  explicit StartRecords(const J& support)
      : starting_(std::views::all(support.starting_segments())),
        count_(J::single_start ? std::size_t(std::ranges::size(starting_)) : support.segment_count()) {}

  /// The number of records.
  [[nodiscard]] std::size_t size() const noexcept { return count_; }
  /// The record of starting slot j.
  [[nodiscard]] std::uint32_t operator()(std::uint32_t j) const noexcept {
    if constexpr (J::single_start) {
      return j;
    } else {
      return starting_[j];
    }
  }
  /// The segment of record r.
  [[nodiscard]] std::uint32_t segment(std::size_t r) const noexcept {
    if constexpr (J::single_start) {
      return starting_[r];
    } else {
      return std::uint32_t(r);
    }
  }

 private:
  decltype(std::views::all(std::declval<const J&>().starting_segments())) starting_;
  std::size_t count_;
};

}  // namespace segpath
