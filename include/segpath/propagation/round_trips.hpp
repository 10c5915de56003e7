// Round trips taken out of the path-conditioned propagation (propagation/path_conditioned.hpp):
// a chain a -> b -> a between backtrack partners (ConditionedInputs::backtrack) uses a segment
// twice, which the weighting's derivation does not cover. A sweep sums every junction, so a's
// values would also hold the chains a -> b -> a -> ...; the Jacobi form of a non-backtracking
// walk takes them out again. With P_k(a -> b) the part of a's values after sweep k that starts
// with the junction a -> b (J(a, b) applied as apply_junction) and V the values,
//   P_k(a -> b) = J(a, b) (V_{k-1}(b) - P_{k-1}(b -> a)),   V_k(a) -= J(a, b) P_{k-1}(b -> a),
// P_{-1} = 0, for every pair joined both ways (in segment filtering rare: a draw that lands in
// the voxel it came from).
#pragma once

#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/conditioned_junction.hpp"
#include "segpath/propagation/junction_support.hpp"

#include <cstdint>
#include <ranges>
#include <span>
#include <utility>
#include <vector>

namespace segpath::detail {

template <Spectrum S>
class RoundTrips {
 public:
  using Pair = std::array<S, 2>;

  /// The pairs a, b = backtrack[a] (each pair once, whichever way round it is given) whose two
  /// junctions a -> b and b -> a exist over `support`: joins(i, j) for ending slot i and
  /// starting slot j; applied(g, i, j), the junction as group g's sweep applies it; record(j),
  /// starting slot j's record; eligible(s), whether segment s may be in a pair.
  template <JunctionSupport J, class Joins, class Applied, class Record, class Eligible>
  void build(const J& support, std::span<const std::uint32_t> backtrack, const Joins& joins, const Applied& applied,
             const Record& record, const Eligible& eligible) {
    trips_.clear();
    if (backtrack.empty()) return;
    const std::size_t n = backtrack.size();
    const auto ending_segment = support.ending_segments();
    const auto starting_segment = support.starting_segments();
    const auto ending_slots = std::uint32_t(std::ranges::size(ending_segment));
    std::vector<std::uint32_t> group_of(ending_slots, no_cluster);
    for (std::size_t g = 0; g < support.group_count(); ++g)
      for (std::uint32_t i = support.ending_slots(g).begin; i < support.ending_slots(g).end; ++i) group_of[i] = std::uint32_t(g);
    // The starting slot of segment b in group g (no_cluster: none): where every segment starts
    // once, its one starting slot if in g; else a search of g's starts (a disk's neighbours).
    std::vector<std::uint32_t> start_slot;
    if constexpr (J::single_start) {
      start_slot.assign(n, no_cluster);
      for (std::uint32_t j = 0; j < std::uint32_t(std::ranges::size(starting_segment)); ++j) start_slot[starting_segment[j]] = j;
    }
    auto start_in = [&](std::size_t g, std::uint32_t b) {
      const SlotRange starting = support.starting_slots(g);
      if constexpr (J::single_start) {
        return starting.contains(start_slot[b]) ? start_slot[b] : no_cluster;
      } else {
        for (std::uint32_t j = starting.begin; j < starting.end; ++j)
          if (starting_segment[j] == b) return j;
        return no_cluster;
      }
    };
    for (std::uint32_t ia = 0; ia < ending_slots; ++ia) {
      const std::uint32_t a = ending_segment[ia], b = backtrack[a];
      if (b >= n || b == a || (backtrack[b] == a && b < a) || !eligible(a) || !eligible(b)) continue;  // each pair once
      const std::uint32_t ib = support.ending_slot_of(b);
      if (ib == no_cluster || group_of[ia] == no_cluster || group_of[ib] == no_cluster) continue;
      const std::uint32_t jb = start_in(group_of[ia], b), ja = start_in(group_of[ib], a);
      if (jb == no_cluster || ja == no_cluster || !joins(ia, jb) || !joins(ib, ja)) continue;
      // Entries 2m and 2m + 1: the two directions of one pair.
      trips_.push_back({applied(group_of[ia], ia, jb), ia, record(jb)});
      trips_.push_back({applied(group_of[ib], ib, ja), ib, record(ja)});
    }
    part_.assign(trips_.size(), ConditionedValues<S>{});
    next_.assign(trips_.size(), ConditionedValues<S>{});
  }

  /// After a sweep: takes the round trips out of the ending slots' values (current_w, and
  /// current_u at slot_u where kept), given what the sweep read of the starts (starting_w, and
  /// starting_u at record_u where kept). In entry order: the result does not depend on the threads.
  void take_out(std::span<const Pair> starting_w, std::span<const Pair> starting_u, std::span<const std::uint32_t> record_u,
                std::span<Pair> current_w, std::span<Pair> current_u, std::span<const std::uint32_t> slot_u) {
    using T = spectrum_scalar_t<S>;
    for (std::size_t m = 0; m < trips_.size(); ++m) {
      const RoundTrip& t = trips_[m];
      const ConditionedValues<S>& back = part_[m ^ 1];  // P_{k-1}(b -> a)
      const std::uint32_t iu = record_u[t.b_record];
      ConditionedValues<S> rest;  // V_{k-1}(b), as the sweep read it, less P_{k-1}(b -> a)
      for (int e = 0; e < 2; ++e) {
        rest.w[e] = starting_w[t.b_record][e] + back.w[e] * T(-1);
        rest.u[e] = (iu != 0 ? starting_u[iu][e] : S(T(0))) + back.u[e] * T(-1);
      }
      ConditionedValues<S> part, out;
      apply_junction(t.junction, read_successor(t.junction.code, rest.u, rest.w), part);
      apply_junction(t.junction, read_successor(t.junction.code, back.u, back.w), out);
      next_[m] = part;
      for (int e = 0; e < 2; ++e) {
        current_w[t.a_slot][e] += out.w[e] * T(-1);
        if (slot_u[t.a_slot] != 0) current_u[slot_u[t.a_slot]][e] += out.u[e] * T(-1);
      }
    }
    std::swap(part_, next_);
  }

  /// The number of directed entries (two per pair).
  [[nodiscard]] std::size_t size() const noexcept { return trips_.size(); }

 private:
  /// One direction a -> b: the junction as the sweep applies it, a's ending slot, b's start record.
  struct RoundTrip {
    ConditionedJunction<S> junction;
    std::uint32_t a_slot = 0, b_record = 0;
  };
  std::vector<RoundTrip> trips_;
  std::vector<ConditionedValues<S>> part_, next_;  ///< P_{k-1} and P_k per entry
};

}  // namespace segpath::detail
