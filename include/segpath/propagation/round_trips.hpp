// Round trips taken out of the propagations (propagation/propagate.hpp for the paper's weighting,
// propagation/path_conditioned.hpp): a chain a -> b -> a between backtrack partners (in segment
// filtering a segment and the one that drew it) uses a segment twice, which no weighting's
// derivation covers: the kernel path integral's estimate sums chains of distinct samples. A
// sweep sums every junction, so a's values would also hold the chains a -> b -> a -> ...; the
// Jacobi form of a non-backtracking walk takes them out again. With P_k(a -> b) the part of a's
// values after sweep k that starts with the junction a -> b (J(a, b) applied to b's values) and
// V the values,
//   P_k(a -> b) = J(a, b) (V_{k-1}(b) - P_{k-1}(b -> a)),   V_k(a) -= J(a, b) P_{k-1}(b -> a),
// P_{-1} = 0, for every pair joined both ways (in segment filtering rare: a draw that lands in
// the voxel it came from). Rare, but each lap of such a pair gains K f_r G w twice, which near a
// glossy lobe's peak is far above 1: k sweeps raised it to the k / 2-th power (a firefly of 2.2e5
// in one pixel of PhF on Cornell box 3, docs/filtering.md).
#pragma once

#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/conditioned_junction.hpp"
#include "segpath/propagation/junction_support.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <ranges>
#include <span>
#include <utility>
#include <vector>

namespace segpath::detail {

/// A support where every segment starts once and that names the groups each segment starts
/// and ends in (Clustering's clusters): segment s's starting slot lies in
/// starting_slots(cluster_of_x(s)), its ending slot in ending_slots(cluster_of_y(s)), and
/// no_cluster names none. for_each_round_trip then finds the pairs without an index of its own.
template <class J>
concept NamesSegmentGroups = J::single_start && requires(const J& j, std::uint32_t s) {
  { j.cluster_of_x(s) } -> std::convertible_to<std::uint32_t>;
  { j.cluster_of_y(s) } -> std::convertible_to<std::uint32_t>;
};

/// visit(g_a, i_a, j_b, g_b, i_b, j_a) for each pair a, b = backtrack[a] (each pair once,
/// whichever way round it is given) whose two junctions a -> b and b -> a exist over `support`:
/// a ends in group g_a at ending slot i_a, where b starts at starting slot j_b, and the other
/// way round. joins(i, j): whether ending slot i joins starting slot j. Returns the bytes of
/// the indices the search held, freed on return: none where the support names each segment's
/// groups (NamesSegmentGroups: a pair's starting slots are then searched in its two groups
/// alone, which costs at most a non-factorised sweep of them), else an ending slot's group and,
/// where every segment starts once, each segment's starting slot.
template <JunctionSupport J, class Joins, class Visit>
std::size_t for_each_round_trip(const J& support, std::span<const std::uint32_t> backtrack, const Joins& joins, const Visit& visit) {
  if (backtrack.empty()) return 0;
  const std::size_t n = std::min<std::size_t>(backtrack.size(), support.segment_count());  // a partner outside the support has none
  const auto ending_segment = support.ending_segments();
  const auto starting_segment = support.starting_segments();
  const auto ending_slots = std::uint32_t(std::ranges::size(ending_segment));
  // The starting slot of segment b in group g, by a search of g's starts (a disk's neighbours,
  // or a cluster that b starts in); no_cluster: none.
  auto search_start = [&](std::size_t g, std::uint32_t b) {
    const SlotRange starting = support.starting_slots(g);
    for (std::uint32_t j = starting.begin; j < starting.end; ++j)
      if (starting_segment[j] == b) return j;
    return no_cluster;
  };
  auto visit_if_joined = [&](std::uint32_t ga, std::uint32_t ia, std::uint32_t jb, std::uint32_t gb, std::uint32_t ib, std::uint32_t ja) {
    if (jb == no_cluster || ja == no_cluster || !joins(ia, jb) || !joins(ib, ja)) return;
    visit(std::size_t(ga), ia, jb, std::size_t(gb), ib, ja);
  };
  auto partner_of = [&](std::uint32_t a) -> std::uint32_t {
    const std::uint32_t b = backtrack[a];
    if (b >= n || b == a || (backtrack[b] == a && b < a)) return no_cluster;  // each pair once
    return b;
  };
  if constexpr (NamesSegmentGroups<J>) {
    for (std::uint32_t ia = 0; ia < ending_slots; ++ia) {
      const std::uint32_t a = ending_segment[ia], b = partner_of(a);
      if (b == no_cluster) continue;
      const std::uint32_t ib = support.ending_slot_of(b), ga = support.cluster_of_y(a), gb = support.cluster_of_y(b);
      // b must start where a ends and a where b ends: only then search the two groups' starts.
      if (ib == no_cluster || ga == no_cluster || gb == no_cluster || support.cluster_of_x(b) != ga || support.cluster_of_x(a) != gb)
        continue;
      visit_if_joined(ga, ia, search_start(ga, b), gb, ib, search_start(gb, a));
    }
    return 0;
  } else {
    std::vector<std::uint32_t> group_of(ending_slots, no_cluster);
    for (std::size_t g = 0; g < support.group_count(); ++g)
      for (std::uint32_t i = support.ending_slots(g).begin; i < support.ending_slots(g).end; ++i) group_of[i] = std::uint32_t(g);
    // Where every segment starts once, its one starting slot if in g; else a search of g's
    // starts (a disk's neighbours).
    std::vector<std::uint32_t> start_slot;
    if constexpr (J::single_start) {
      start_slot.assign(support.segment_count(), no_cluster);
      for (std::uint32_t j = 0; j < std::uint32_t(std::ranges::size(starting_segment)); ++j) start_slot[starting_segment[j]] = j;
    }
    auto start_in = [&](std::size_t g, std::uint32_t b) {
      if constexpr (J::single_start) {
        return support.starting_slots(g).contains(start_slot[b]) ? start_slot[b] : no_cluster;
      } else {
        return search_start(g, b);
      }
    };
    for (std::uint32_t ia = 0; ia < ending_slots; ++ia) {
      const std::uint32_t a = ending_segment[ia], b = partner_of(a);
      if (b == no_cluster) continue;
      const std::uint32_t ib = support.ending_slot_of(b);
      if (ib == no_cluster || group_of[ia] == no_cluster || group_of[ib] == no_cluster) continue;
      visit_if_joined(group_of[ia], ia, start_in(group_of[ia], b), group_of[ib], ib, start_in(group_of[ib], a));
    }
    return (group_of.capacity() + start_slot.capacity()) * sizeof(std::uint32_t);
  }
}

/// The parts P of every round-trip entry at the last depth + 1 budgets. With chains of several
/// pieces (segment_budget.hpp) sweep k reads a start b of p_b pieces at the budget k + 1 - p_b,
/// so the part of it to take out is the one at that budget, which sweep k - p_b computed.
template <class V>
class PartsByBudget {
 public:
  void reset(std::size_t entries, int depth, V zero) {
    entries_ = entries;
    rows_ = std::size_t(depth) + 1;
    zero_ = zero;
    parts_.assign(entries * rows_, zero);
  }
  /// P of entry m at budget `budget` (sweep budget - 1's); zero at budget 0 and below.
  [[nodiscard]] const V& at(int budget, std::size_t m) const noexcept {
    return budget > 0 ? parts_[std::size_t(budget) % rows_ * entries_ + m] : zero_;
  }
  /// Where sweep k writes P of entry m (budget k + 1); no row it reads (budgets k + 1 - depth
  /// to k) is overwritten.
  [[nodiscard]] V& after(int k, std::size_t m) noexcept { return parts_[std::size_t(k + 1) % rows_ * entries_ + m]; }
  [[nodiscard]] std::size_t bytes() const noexcept { return parts_.capacity() * sizeof(V); }

 private:
  std::size_t entries_ = 0, rows_ = 1;
  V zero_{};
  std::vector<V> parts_;
};

/// The round trips of the path-conditioned propagation (two values per segment, W and U).
template <Spectrum S>
class RoundTrips {
 public:
  using Pair = std::array<S, 2>;

  /// The pairs of for_each_round_trip: applied(g, i, j), the junction as group g's sweep
  /// applies it; record(j), starting slot j's record; pieces(j), the pieces of starting slot
  /// j's segment (at most `depth`).
  template <JunctionSupport J, class Joins, class Applied, class Record, class Pieces>
  void build(const J& support, std::span<const std::uint32_t> backtrack, const Joins& joins, const Applied& applied,
             const Record& record, const Pieces& pieces, int depth) {
    trips_.clear();
    const std::size_t search = for_each_round_trip(support, backtrack, joins,
                        [&](std::size_t ga, std::uint32_t ia, std::uint32_t jb, std::size_t gb, std::uint32_t ib, std::uint32_t ja) {
                          // Entries 2m and 2m + 1: the two directions of one pair.
                          trips_.push_back({applied(ga, ia, jb), ia, record(jb), int(pieces(jb))});
                          trips_.push_back({applied(gb, ib, ja), ib, record(ja), int(pieces(ja))});
                        });
    parts_.reset(trips_.size(), depth, ConditionedValues<S>{});
    peak_bytes_ = trips_.capacity() * sizeof(RoundTrip) + std::max(search, parts_.bytes());
  }

  /// After sweep k: takes the round trips out of the ending slots' values (current_w, and
  /// current_u at slot_u where kept), given what the sweep read of the starts (starting_w, and
  /// starting_u at record_u where kept, at each start's budget). In entry order: the result
  /// does not depend on the threads.
  void take_out(int k, std::span<const Pair> starting_w, std::span<const Pair> starting_u, std::span<const std::uint32_t> record_u,
                std::span<Pair> current_w, std::span<Pair> current_u, std::span<const std::uint32_t> slot_u) {
    using T = spectrum_scalar_t<S>;
    for (std::size_t m = 0; m < trips_.size(); ++m) {
      const RoundTrip& t = trips_[m];
      const ConditionedValues<S>& back = parts_.at(k + 1 - t.b_pieces, m ^ 1);  // P(b -> a) at the budget b was read at
      const std::uint32_t iu = record_u[t.b_record];
      ConditionedValues<S> rest;  // V(b), as the sweep read it, less P(b -> a)
      for (int e = 0; e < 2; ++e) {
        rest.w[e] = starting_w[t.b_record][e] + back.w[e] * T(-1);
        rest.u[e] = (iu != 0 ? starting_u[iu][e] : S(T(0))) + back.u[e] * T(-1);
      }
      ConditionedValues<S> part, out;
      apply_junction(t.junction, read_successor(t.junction.code, rest.u, rest.w), part);
      apply_junction(t.junction, read_successor(t.junction.code, back.u, back.w), out);
      parts_.after(k, m) = part;
      for (int e = 0; e < 2; ++e) {
        current_w[t.a_slot][e] += out.w[e] * T(-1);
        if (slot_u[t.a_slot] != 0) current_u[slot_u[t.a_slot]][e] += out.u[e] * T(-1);
      }
    }
  }

  /// The number of directed entries (two per pair).
  [[nodiscard]] std::size_t size() const noexcept { return trips_.size(); }
  /// The most build held at once: the entries, and the search's indices or the parts.
  [[nodiscard]] std::size_t peak_bytes() const noexcept { return peak_bytes_; }

 private:
  /// One direction a -> b: the junction as the sweep applies it, a's ending slot, b's start
  /// record and pieces.
  struct RoundTrip {
    ConditionedJunction<S> junction;
    std::uint32_t a_slot = 0, b_record = 0;
    int b_pieces = 1;
  };
  std::vector<RoundTrip> trips_;
  PartsByBudget<ConditionedValues<S>> parts_;
  std::size_t peak_bytes_ = 0;
};

/// The round trips of the paper's propagation (propagation/propagate.hpp): one value per
/// segment, what a sweep reads of a start is in(b) G w(b), and the junction a -> b applied to
/// it is the gain K f_r(a, b).
template <Spectrum S>
class RadianceRoundTrips {
 public:
  using T = spectrum_scalar_t<S>;

  /// The pairs of for_each_round_trip: gain(g, i, j), K f_r of ending slot i and starting slot
  /// j in group g as its sweep applies it; record(j), starting slot j's record, weight[r] G w
  /// of record r's segment and pieces(j) the pieces of starting slot j's segment (at most
  /// `depth`).
  template <JunctionSupport J, class Joins, class Gain, class Record, class Pieces>
  void build(const J& support, std::span<const std::uint32_t> backtrack, const Joins& joins, const Gain& gain, const Record& record,
             std::span<const T> weight, const Pieces& pieces, int depth) {
    trips_.clear();
    const std::size_t search = for_each_round_trip(support, backtrack, joins,
                        [&](std::size_t ga, std::uint32_t ia, std::uint32_t jb, std::size_t gb, std::uint32_t ib, std::uint32_t ja) {
                          // Entries 2m and 2m + 1: the two directions of one pair.
                          const std::uint32_t rb = record(jb), ra = record(ja);
                          trips_.push_back({gain(ga, ia, jb), weight[rb], ia, rb, int(pieces(jb))});
                          trips_.push_back({gain(gb, ib, ja), weight[ra], ib, ra, int(pieces(ja))});
                        });
    parts_.reset(trips_.size(), depth, S(T(0)));
    peak_bytes_ = trips_.capacity() * sizeof(RoundTrip) + std::max(search, parts_.bytes());
  }

  /// After sweep k: takes the round trips out of the ending slots' values `out`, given what the
  /// sweep read of the starts (`read`: in(b) G w(b) per record, at b's budget). In entry order:
  /// the result does not depend on the threads.
  void take_out(int k, const S* read, std::span<S> out) {
    for (std::size_t m = 0; m < trips_.size(); ++m) {
      const RoundTrip& t = trips_[m];
      const S& back = parts_.at(k + 1 - t.b_pieces, m ^ 1);  // P(b -> a) at the budget b was read at
      parts_.after(k, m) = t.gain * (read[t.b_record] + back * (-t.weight));
      out[t.a_slot] += t.gain * back * (-t.weight);
    }
  }

  /// The number of directed entries (two per pair).
  [[nodiscard]] std::size_t size() const noexcept { return trips_.size(); }
  /// The most build held at once: the entries, and the search's indices or the parts.
  [[nodiscard]] std::size_t peak_bytes() const noexcept { return peak_bytes_; }

 private:
  /// One direction a -> b: the gain K f_r(a, b), G w of b, a's ending slot, b's start record
  /// and pieces.
  struct RoundTrip {
    S gain;
    T weight;
    std::uint32_t a_slot = 0, b_record = 0;
    int b_pieces = 1;
  };
  std::vector<RoundTrip> trips_;
  PartsByBudget<S> parts_;
  std::size_t peak_bytes_ = 0;
};

}  // namespace segpath::detail
