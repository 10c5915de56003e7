// Propagation (SPEC 1.8) of the recursive MMIS estimator (N39, N40) with the path-conditioned
// weighting of a pooled bidirectional chain: unbiased where the paper's product of 1/D(s) is not.
//
// Why the paper's weight is biased. A chain s_1 ... s_k of pooled segments (s_i ends, s_{i+1}
// starts in one cluster) is weighted prod_i 1/D(s_i), each D(s_i) summing the densities of
// every technique sample in the pool (N39). Split D = D_c + D_l: D_c the camera side (sensor,
// camera successors, and whatever else a camera-side point draws), D_l the light side (light
// start, light predecessors). Which techniques a segment's D holds depends on the *sides its
// neighbours were born on*: D_c(s_i) holds s_{i-1} only if s_{i-1} is a camera technique
// sample, D_l(s_i) holds s_{i+1} only if s_{i+1} is a light technique sample. Read as MIS over
// the chain's side patterns sigma (who drew whom; SPEC 1.8 step 3's w(s) per segment), the
// paper's weight is alpha(sigma) / p_sigma with p_sigma = prod_i p_i(sigma_i | sigma_{i-1},
// sigma_{i+1}) the pooled density of the chain drawn that way and alpha_i = D_side(s_i) / D(s_i),
// and these alpha do not sum to one over sigma: each is normalised with the *actual*
// neighbours in place of the hypothesised ones (two-segment toy: expectation 1 + u (1 - v)).
//
// The path-conditioned weight. Any alpha with sum_sigma alpha(sigma) = 1 that puts no mass on
// patterns the pool cannot produce gives an estimator whose expectation is exact (SMIS, N11,
// per side pattern), and a *forward Markov* alpha, alpha(sigma) = prod_i alpha_i(sigma_i |
// sigma_{i-1}), sums to one by construction. With p_c(s_i | sigma_{i-1}) = D_c(s_i) (the pool's
// own camera sum, whose only neighbour dependence is on the predecessor), p_l(s_i | sigma_{i+1})
// = D_l(s_i), and
//   D_l'(s_i)   = D_l(s_i) without s_{i+1}'s term,
//   Lambda(s_i) = D_l'(s_i) if > 0, else q_l(s_i | s_{i+1})   (then only s_{i+1} could draw s_i),
//   e(s_i)      = [D_l'(s_i) > 0] or (q_l(s_i | s_{i+1}) > 0 and e(s_{i+1})),
//   e(s_k)      = [D_l(s_k) > 0]    (e: a light birth of s_i is possible along this continuation),
//   G(s_i)      = D(s_i) - D_l(s_i) + e(s_i) Lambda(s_i)      (s_k: D(s_k)),
// take alpha_i(camera or other) = D_c / G, alpha_i(light) = e Lambda / G, except after a
// light-born s_{i-1} with D_l'(s_{i-1}) = 0 (only s_i can have drawn it): alpha_i(light
// technique) = 1. Then the weight alpha / p_sigma of the chain as drawn is prod_i r_i with
//   r_i = 1 / G(s_i)                                   camera- or other-born s_i,
//   r_i = e Lambda / (G(s_i) D_l(s_i))                  light-born s_i,
//   r_i = 1 / D_lt(s_i)                                 forced (after the case above; 0 unless s_i
//                                                        is a light technique sample),
// where D_lt <= D_l keeps the light generators whose child tries a predecessor (exact for one
// forced segment only where light paths stop at a depth, so segment filtering's light paths
// end by Russian roulette instead and D_lt = D_l; docs/bias-notes.md),
// and r_k = 1 / D(s_k) unless forced. The camera side needs no pair density at all (alpha
// conditions on the actual predecessor, whose camera technique is in D_c already, so a camera
// technique that also draws next-event segments only has to be in D); the light side needs
// q_l(s | s') of every junction.
// Why Lambda leaves q_l out when D_l' > 0: any Lambda that does not depend on sigma keeps
// sum alpha = 1, but D_l' + q_l over-weights the realised light birth by (D_l' + q_l) / D_l'
// when s_{i+1} is not a light technique sample (a light path's last segment, a camera-born
// start); the light mass through s_{i+1} is only needed where nothing else can draw s_i
// (docs/filtering.md, "The path-conditioned weighting's checks").
// Bridges: a target successor's term leaves the bridge density B as s_{i+1}'s leaves D_l, and a
// bridge-born s_i has r_i = B' / (G B) (conditioned_junction.hpp, conditioned_coefficients).
// Assumed of the pool: a path holds at most one technique sample per cluster, fixed before it
// draws (filtering::Context::visit_grid); the light paths are a Poisson process, so that D_l' is
// the rest's density (FilteringOptions::poisson_light_paths); no chain uses a segment twice (no
// s -> s, nor a -> b -> a with its drawer: ConditionedInputs::backtrack). Bias left: docs/filtering.md.
//
// The recursion: r_i depends on s_{i+1} and on two bits, e(s_i) (from the suffix) and "forced"
// (from the predecessor), so each segment carries four values, U_e and W_e for e in {0, 1}:
// the suffix sums sum_{chains from s, e(s) = e} (prod of transfers and r of the segments after
// s) L_e, without (U) and with (W) s's own free r. A successor s' is read as W_e(s'), or
// U_e(s') / D_lt(s') where s forces it. k Jacobi iterations count chains of up to k + 1
// segments. Cost per iteration: one link and at most one q_l evaluation per junction, or O(n + m) in a
// factorised cluster (three classes of s'); memory two sets of W per segment, and of U only
// for the segments a junction can force.
#pragma once

#include "segpath/config.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/conditioned_junction.hpp"
#include "segpath/propagation/disk_junctions.hpp"
#include "segpath/propagation/junction_support.hpp"
#include "segpath/propagation/pair_table.hpp"
#include "segpath/propagation/round_trips.hpp"
#include "segpath/propagation/segment_budget.hpp"
#include "segpath/propagation/propagate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <ranges>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace segpath {

/// What the path-conditioned propagation needs of a pool, per segment s:
///  - emitted[s] L_e(s), geometry[s] G(s);
///  - density[s] D(s) (every technique, N39), light_density[s] D_l(s) (light start and light
///    technique samples only), light_terms[s] the number of positive terms in D_l(s),
///    light_technique_density[s] D_lt(s) <= D_l(s): the terms whose draw would itself have
///    tried a predecessor (read only for light technique samples);
///  - flags[s] (conditioned_*);
///  - link(s, s'): f_r(s, s') (N20) for s ending and s' starting in one cluster (or disk);
///  - light_pair(s, s'): q_l(s | s'), the density (with the kernel) with which a light
///    technique sample at x_{s'} draws s; 0 where s cannot be drawn so. It must be the term s'
///    adds to D_l(s) when s' is a light technique sample.
/// Over clusters, link and light_pair may also take (s, s', i, j), i the ending slot of s and j
/// the starting slot of s' (as in propagation/propagate.hpp), to read slot-ordered copies; the
/// general clusters then call that form (factorised clusters never call link, and call
/// light_pair(s, s') once per pool).
template <Spectrum S, class Link, class LightPair>
struct ConditionedInputs {
  using T = spectrum_scalar_t<S>;
  std::span<const S> emitted;
  std::span<const T> geometry, density, light_density;
  std::span<const std::uint32_t> light_terms;
  std::span<const T> light_technique_density;
  std::span<const std::uint8_t> flags;
  Link link;
  LightPair light_pair;
  /// p(s): the segments s stands for (a chain through delta bounces); empty: all 1
  /// (propagation/segment_budget.hpp).
  std::span<const std::uint16_t> pieces = {};
  /// Bridges (empty without), whose targets are the light technique samples:
  /// bridge_target_term[s] q_b(s), the term each target starting near y_s adds to the bridge
  /// density B(s) in D(s), and bridge_density[s] B(s); a junction leaves a target successor's
  /// term out of G (conditioned_coefficients).
  std::span<const T> bridge_target_term = {}, bridge_density = {};
  /// backtrack[s] (empty: none; no_cluster: none for s): a segment b that no chain goes a round
  /// trip s -> b -> s or b -> s -> b with (propagation/round_trips.hpp); in segment filtering the
  /// one that drew s or that s drew; through chains of several pieces too (read lagged).
  std::span<const std::uint32_t> backtrack = {};
};

namespace detail {

template <Spectrum S, class Link, class LightPair>
void check_conditioned(const ConditionedInputs<S, Link, LightPair>& in, int iterations) {
  const std::size_t n = in.emitted.size();
  if (iterations < 1) throw std::invalid_argument("segpath::propagate_conditioned: iterations must be >= 1");
  if (in.geometry.size() != n || in.density.size() != n || in.light_density.size() != n || in.light_terms.size() != n ||
      in.light_technique_density.size() != n || in.flags.size() != n)
    throw std::invalid_argument("segpath::propagate_conditioned: the per-segment inputs differ in size");
  if (in.bridge_target_term.size() != in.bridge_density.size() || !(in.bridge_density.empty() || in.bridge_density.size() == n))
    throw std::invalid_argument("segpath::propagate_conditioned: bridge_target_term and bridge_density need one value per segment, or none");
  if (!(in.backtrack.empty() || in.backtrack.size() == n))
    throw std::invalid_argument("segpath::propagate_conditioned: backtrack needs one value per segment, or none");
}

/// The default of propagate_conditioned's by_id_done: nothing to free.
struct NoAction {
  void operator()() const noexcept {}
};

/// Frees the vectors' memory (clear() would keep it).
template <class... V>
void release(V&... vectors) noexcept {
  ((vectors = V{}), ...);
}

/// The values of a segment that ends the chain: L_e(s) in state e = [D_l(s) > 0], W with 1 / D.
template <Spectrum S, class Link, class LightPair>
ConditionedValues<S> conditioned_emission(const ConditionedInputs<S, Link, LightPair>& in, std::size_t s) noexcept {
  using T = spectrum_scalar_t<S>;
  ConditionedValues<S> v;
  const int e = in.light_density[s] > T(0) ? 1 : 0;
  v.u[e] = in.emitted[s];
  v.w[e] = in.density[s] > T(0) ? in.emitted[s] * (T(1) / in.density[s]) : S(T(0));
  return v;
}

template <Spectrum S, class Link, class LightPair>
ConditionedEmission<S> compact_emission(const ConditionedInputs<S, Link, LightPair>& in, std::size_t s) noexcept {
  using T = spectrum_scalar_t<S>;
  // NaN, not 0, for no density: D(s) = +inf gives 1 / D = 0, and W = L_e * 0 as conditioned_emission.
  const T inverse_density = in.density[s] > T(0) ? T(1) / in.density[s] : std::numeric_limits<T>::quiet_NaN();
  return {in.emitted[s], in.light_density[s] > T(0) ? -inverse_density : inverse_density};
}

/// 1 / D_lt(s') where s' is read forced (a light technique sample), else 0.
template <Spectrum S, class Link, class LightPair>
spectrum_scalar_t<S> conditioned_forced_weight(const ConditionedInputs<S, Link, LightPair>& in, std::uint32_t sp) noexcept {
  using T = spectrum_scalar_t<S>;
  const std::uint8_t fp = in.flags[sp];
  return (fp & conditioned_light_born) && (fp & conditioned_light_technique) && in.light_technique_density[sp] > T(0)
             ? T(1) / in.light_technique_density[sp]
             : T(0);
}

/// What a junction reads of the ending segment s (ConditionedEnd).
template <Spectrum S, class Link, class LightPair>
ConditionedEnd<spectrum_scalar_t<S>> conditioned_end(const ConditionedInputs<S, Link, LightPair>& in, std::size_t s) noexcept {
  using T = spectrum_scalar_t<S>;
  return {in.light_density[s], std::max(T(0), in.density[s] - in.light_density[s]), in.light_terms[s], in.flags[s]};
}

/// What a junction reads of the ending segment s about bridges (zeros without).
template <Spectrum S, class Link, class LightPair>
ConditionedBridgeEnd<spectrum_scalar_t<S>> conditioned_bridge_end(const ConditionedInputs<S, Link, LightPair>& in,
                                                                  std::size_t s) noexcept {
  using T = spectrum_scalar_t<S>;
  if (in.bridge_target_term.empty() || !(in.bridge_target_term[s] > T(0))) return {};
  const T q = in.bridge_target_term[s], b = in.bridge_density[s];
  return {q, (in.flags[s] & conditioned_bridge_born) && b > T(0) ? std::min(T(1), q / b) : T(0)};
}

}  // namespace detail

/// What propagate_conditioned allocated besides the arrays it keeps for every segment, in bytes.
struct ConditionedMemory {
  std::size_t junction_table = 0;  ///< the ConditionedJunction table (junction_cache_bytes at most)
  std::size_t lagged = 0;          ///< the lagged values of chains and their watches: 0 without chains
  std::size_t forced_values = 0;   ///< the U values a junction can force, their copies, the sources' U indices
  std::size_t round_trips = 0;     ///< the most the round trips held at once (RoundTrips::peak_bytes)
};

/// `iterations` >= 1 Jacobi iterations over the groups of a JunctionSupport (clusters, disks)
/// from the emission; returns per segment W_0 + W_1 in `weighted` (L(s) with the chain
/// weights, s's own included: a sensor segment's pixel value is W G(s) weighted[s]). Parallel
/// over groups; each segment's values are written by the one group holding its y end,
/// junctions summed in increasing starting slot order, so the result does not depend on the
/// number of threads. Over clusters everything is kept per slot in group order, so an iteration
/// reads the values of each s' at random once per starting slot and the rest in order; over
/// disks what is read of a start is kept per segment and read at random (StartRecords).
/// Memory per segment: W twice (the values, updated in place, and a start's gathered copy), the
/// emission in 16 bytes and 32 bytes more (float), and two indices; U twice only for the
/// segments a junction can force (forced_weight > 0: light technique samples), with an index
/// per copy, returned in ConditionedMemory::forced_values.
///
/// `factorised[g]` (optional, one per group; J::factorisable supports only) marks groups where
/// link(s, s') = diffuse[s] for every s ending and s' starting there and light_pair(s, s') is
/// the same for every s' with conditioned_potential (Lambertian ends and starts with one
/// normal): their junctions are summed per flag class of s' (three classes), O(#ending +
/// #starting) instead of the product; each of their ending slots then keeps its three class
/// junctions (40 bytes for Rgb<float>).
///
/// `junction_cache_bytes`: the general groups whose ConditionedJunction table (a PairTable, one
/// sizeof(detail::ConditionedJunction<S>) per pair) fits in this budget, in group order, call
/// link and light_pair once per pair for the whole propagation instead of once per pair and
/// iteration. The result is the same. Returns the bytes the table, the lagged values and the U
/// values of the segments a junction can force took.
///
/// `by_id_done()` is called once, after the factorised groups' light_pair(s, s') calls and
/// before the arrays above are allocated: from then on link and light_pair are called only in
/// their slot form where they have one, so a caller may free there what only the by-id forms
/// read (segment_filtering frees the pool's end points there: algorithms/filtering/propagation.hpp).
template <JunctionSupport J, Spectrum S, class Link, class LightPair, ParallelFor P = SerialFor, class ByIdDone = detail::NoAction>
ConditionedMemory propagate_conditioned(const J& support, const ConditionedInputs<S, Link, LightPair>& in, int iterations,
                                  std::vector<S>& weighted, const P& parallel_for = {},
                                  std::span<const std::uint8_t> factorised = {}, std::span<const S> diffuse = {},
                                  std::size_t junction_cache_bytes = 0, const ByIdDone& by_id_done = {}) {
  using T = spectrum_scalar_t<S>;
  using Junction = detail::ConditionedJunction<S>;
  static_assert(std::is_same_v<typename J::Scalar, T>, "segpath::propagate_conditioned: the support's Scalar is not the spectrum's");
  detail::check_conditioned(in, iterations);
  const std::size_t n = in.emitted.size();
  detail::check_support(support, n, factorised.size(), diffuse.size(), "segpath::propagate_conditioned");
  const bool has_factorisation = !factorised.empty();
  const auto starting_segment = support.starting_segments();
  const auto ending_segment = support.ending_segments();
  const std::size_t ending_slots = std::ranges::size(ending_segment);
  const StartRecords<J> record(support);
  // Classes of s' in a factorised group: 0 not a potential light technique, 1 potential,
  // 2 light technique sample. There q_l(s | s') is the same for every potential s', so each
  // ending slot of a factorised group has three junctions, one per class, fixed for the whole
  // propagation; those of group g from class_offset[g] on. Built first: they make the last
  // by-id calls of light_pair (by_id_done).
  std::vector<std::uint32_t> class_offset;
  std::vector<detail::ClassJunctions<S>> class_junction;
  if constexpr (J::factorisable) {
    if (has_factorisation) {
      class_offset.resize(factorised.size());
      std::size_t factorised_slots = 0;
      for (std::size_t g = 0; g < factorised.size(); ++g) {
        class_offset[g] = std::uint32_t(factorised_slots);
        if (factorised[g]) factorised_slots += support.ending_slots(g).end - support.ending_slots(g).begin;
      }
      class_junction.resize(factorised_slots);
      detail::for_groups(support, parallel_for, [&](std::size_t g) {
        if (!factorised[g]) return;
        constexpr std::uint8_t class_flags[3] = {0, conditioned_potential,
                                                 conditioned_potential | conditioned_light_technique | conditioned_light_born};
        const SlotRange ending = support.ending_slots(g), starting = support.starting_slots(g);
        std::uint32_t representative = no_cluster;
        for (std::uint32_t j = starting.begin; j < starting.end; ++j)
          if (const std::uint32_t sp = starting_segment[j]; in.geometry[sp] > T(0) && (in.flags[sp] & conditioned_potential))
            representative = sp;
        for (std::uint32_t i = ending.begin; i < ending.end; ++i) {
          const T ql = representative == no_cluster ? T(0) : T(in.light_pair(ending_segment[i], representative));
          const S transfer = diffuse[ending_segment[i]] * support.kernel(g);
          const auto end_i = detail::conditioned_end(in, ending_segment[i]);
          const auto bridge_i = detail::conditioned_bridge_end(in, ending_segment[i]);
          for (int k_class = 0; k_class < 3; ++k_class)
            class_junction[class_offset[g] + (i - ending.begin)].set(
                k_class,
                detail::conditioned_coefficients(end_i, class_flags[k_class], T(1), transfer, k_class > 0 ? ql : T(0), bridge_i));
        }
      });
    }
  }
  by_id_done();
  // Everything per slot (or start record), in group order: an iteration reads the values of s'
  // at random once per record and the rest in order.
  // One set of values per ending slot, updated in place: a sweep reads the previous iteration's
  // values only through the starts' copies, gathered before it starts. W and U are kept apart:
  // a start's U is read only where a junction can force it (forced_weight > 0), so U is kept
  // only for those starts and for the ending slots they read, at the indices record_u and
  // slot_u (0: none; starting_u[0] stays zero, what every other start reads).
  using Pair = std::array<S, 2>;
  std::vector<detail::ConditionedEnd<T>> end(ending_slots);
  std::vector<detail::ConditionedBridgeEnd<T>> bridge_end(in.bridge_density.empty() ? 0 : ending_slots);
  std::vector<detail::ConditionedEmission<S>> emission(ending_slots);
  std::vector<Pair> current_w(ending_slots);
  const Pair zero{S(T(0)), S(T(0))};
  std::vector<Pair> starting_w(record.size(), zero);
  std::vector<detail::ConditionedStart<T>> start(record.size());
  for_blocks(ending_slots, parallel_for, [&](std::size_t i) {
    const std::uint32_t s = ending_segment[i];
    end[i] = detail::conditioned_end(in, s);
    if (!bridge_end.empty()) bridge_end[i] = detail::conditioned_bridge_end(in, s);
    emission[i] = detail::compact_emission(in, s);
    current_w[i] = emission[i].values().w;
  });
  auto emission_values = [&](std::uint32_t i) { return emission[i].values(); };
  for_blocks(record.size(), parallel_for, [&](std::size_t r) {
    const std::uint32_t sp = record.segment(r);
    start[r] = {in.geometry[sp], detail::conditioned_forced_weight(in, sp), support.ending_slot_of(sp),
                in.pieces.empty() ? std::uint16_t(1) : in.pieces[sp], in.flags[sp]};
  });
  std::vector<std::uint32_t> slot_u(ending_slots, 0), record_u(record.size(), 0);
  std::uint32_t forced_slots = 0, forced_records = 0;
  for (std::size_t r = 0; r < record.size(); ++r) {
    if (!(start[r].forced_weight > T(0))) continue;
    record_u[r] = ++forced_records;
    if (const std::uint32_t i = start[r].source; i != no_cluster) slot_u[i] = 1;
  }
  // Numbered in slot order, so that a sweep writes the kept U in order.
  for (std::uint32_t& u : slot_u)
    if (u != 0) u = ++forced_slots;
  // Per forceable start (record_u), its source's U (slot_u of its source; 0: none): the gather
  // reads it in order instead of slot_u at random.
  std::vector<std::uint32_t> source_u(std::size_t(forced_records) + 1, 0);
  for (std::size_t r = 0; r < record.size(); ++r)
    if (record_u[r] != 0 && start[r].source != no_cluster) source_u[record_u[r]] = slot_u[start[r].source];
  // (No slot's U is read before the first sweep has written it: at budget 0 a start reads the emission.)
  std::vector<Pair> current_u(std::size_t(forced_slots) + 1, zero), starting_u(std::size_t(forced_records) + 1, zero);
  // Storing the values of ending slot i (U only where kept).
  auto store = [&](std::uint32_t i, const ConditionedValues<S>& v) {
    current_w[i] = v.w;
    if (slot_u[i] != 0) current_u[slot_u[i]] = v.u;
  };
  // The junction of ending slot i and starting slot j of a general group with kernel K.
  auto junction = [&](std::uint32_t i, std::uint32_t j, T kernel) -> Junction {
    const std::uint32_t s = ending_segment[i], sp = starting_segment[j];
    const detail::ConditionedStart<T>& st = start[record(j)];
    S f;
    if constexpr (std::is_invocable_v<const Link&, std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t>) {
      f = in.link(s, sp, i, j);
    } else {
      f = in.link(s, sp);
    }
    T ql = T(0);
    if (detail::needs_light_pair(end[i], st.flags)) {
      if constexpr (std::is_invocable_v<const LightPair&, std::uint32_t, std::uint32_t, std::uint32_t, std::uint32_t>) {
        ql = T(in.light_pair(s, sp, i, j));
      } else {
        ql = T(in.light_pair(s, sp));
      }
    }
    return detail::conditioned_coefficients(end[i], st.flags, st.forced_weight, S(f * (kernel * st.geometry)), ql,
                                            bridge_end.empty() ? detail::ConditionedBridgeEnd<T>{} : bridge_end[i]);
  };
  // What junction j reads of starting slot j's record r: U where it forces the start, as
  // read_successor, but record_u read only then (an argument would be read for every junction).
  auto read = [&](const Junction& j, std::uint32_t r) -> const Pair& {
    return (j.code & 1) ? starting_u[record_u[r]] : starting_w[r];
  };
  // s -> s' is a junction: s' carries weight and is not s.
  auto joins = [&](std::uint32_t i, std::uint32_t j) {
    const detail::ConditionedStart<T>& st = start[record(j)];
    return st.geometry > T(0) && st.source != i;
  };
  // The junctions of the general groups that fit the budget, built once.
  PairTable<Junction> table;
  table.build(
      support, junction_cache_bytes, factorised,
      [&](std::size_t g, std::uint32_t i, std::uint32_t j) {
        return joins(i, j) ? junction(i, j, support.kernel(g)) : Junction{S(T(0)), {}, detail::no_junction};
      },
      parallel_for);
  // Budgets (segment_budget.hpp): sweep k computes A^(k + 1); a start of p pieces reads
  // A^(k + 1 - p), which lagged_w (W) and lagged_u (U, forceable starts only) keep for p > 1
  // (as for the results of chains). A start's source is its own segment's ending slot, and a
  // segment has one start record at most, so one watch per slot serves both.
  const int depth = detail::max_pieces(in.pieces, n);
  // Round trips between backtrack partners, taken out after each sweep (propagation/round_trips.hpp).
  detail::RoundTrips<S> round_trips;
  round_trips.build(
      support, in.backtrack, joins,
      [&](std::size_t g, std::uint32_t i, std::uint32_t j) -> Junction {
        // In a factorised group, the class's junction with the start's G (and forced weight).
        if constexpr (J::factorisable) {
          if (has_factorisation && factorised[g]) {
            const detail::ConditionedStart<T>& st = start[record(j)];
            const detail::ClassJunctions<S>& c = class_junction[class_offset[g] + (i - support.ending_slots(g).begin)];
            const int k_class = (st.flags & conditioned_light_technique) ? 2 : (st.flags & conditioned_potential) ? 1 : 0;
            const T scale = (c.code[k_class] & 1) ? st.geometry * st.forced_weight : st.geometry;  // forced_weight: 0 outside class 2
            return Junction{S(c.transfer * scale), c.r[k_class], c.code[k_class]};
          }
        }
        return junction(i, j, T(support.kernel(g)));
      },
      record, [&](std::uint32_t j) { return int(start[record(j)].pieces); }, depth);
  // The watches of starts come first, in record order, so that the gather reads their rings in
  // order; then those of slots that no start reads (their results only). Every watch keeps W;
  // U is kept only for the starts a junction can force, in lagged_u (watch u_watch[record_u]).
  // A watch's p is its slot's segment's (a start's source is its own segment's ending slot).
  detail::LaggedValues<Pair> lagged_w, lagged_u;
  std::vector<std::uint32_t> start_watch, u_watch;
  if (depth > 1) {
    start_watch.assign(record.size(), detail::no_watch);
    u_watch.assign(std::size_t(forced_records) + 1, detail::no_watch);
    std::vector<bool> watched(ending_slots, false);
    for (std::size_t r = 0; r < record.size(); ++r)
      if (const std::uint32_t i = start[r].source; i != no_cluster && start[r].pieces > 1) {
        start_watch[r] = lagged_w.watch(i, start[r].pieces);
        watched[i] = true;
        if (record_u[r] != 0) u_watch[record_u[r]] = lagged_u.watch(i, start[r].pieces);
      }
    for (std::size_t i = 0; i < ending_slots; ++i)
      if (const std::uint16_t p = in.pieces[ending_segment[i]]; p > 1 && !watched[i]) lagged_w.watch(std::uint32_t(i), p);
    lagged_w.allocate();
    lagged_u.allocate();
  }
  for (int k = 0; k < iterations; ++k) {
    for_blocks(record.size(), parallel_for, [&](std::size_t r) {
      const detail::ConditionedStart<T>& st = start[r];
      const std::uint32_t i = st.source;
      const bool forceable = record_u[r] != 0;  // forced_weight > 0
      const int b = depth == 1 ? k : k + 1 - int(st.pieces);
      auto gather = [&](const ConditionedValues<S>& v) {
        starting_w[r] = v.w;
        if (forceable) starting_u[record_u[r]] = v.u;
      };
      // Before budget 0 a start reads nothing (its values are still the zeros they were made
      // with); one without a source reads its emission from budget 0 on (written once).
      if (b < 0 || (i == no_cluster && b > 0)) return;
      if (i == no_cluster) {
        gather(detail::conditioned_emission(in, record.segment(r)));
      } else if (b == 0) {
        gather(emission_values(i));
      } else if (depth == 1 || start_watch[r] == detail::no_watch) {
        // The common case, field by field: through `gather` the gather is slower (figures.md).
        starting_w[r] = current_w[i];
        if (forceable) starting_u[record_u[r]] = current_u[source_u[record_u[r]]];
      } else {
        starting_w[r] = lagged_w.at(start_watch[r], b);
        if (forceable) starting_u[record_u[r]] = lagged_u.at(u_watch[record_u[r]], b);
      }
    });
    detail::for_groups(support, parallel_for, [&](std::size_t g) {
      const SlotRange ending = support.ending_slots(g), starting = support.starting_slots(g);
      if constexpr (J::factorisable) {
        if (has_factorisation && factorised[g]) {
          // The sums over the starts of each class, but for slot `skip` (none: no_cluster).
          // Summed per class with constant indices (an array indexed by the class kept every sum
          // in memory, figures.md); only a start of class 2 can be forced (record_u != 0).
          auto class_sums = [&](std::uint32_t skip) {
            Pair w0 = zero, w1 = zero, w2 = zero, u2 = zero;
            for (std::uint32_t j = starting.begin; j < starting.end; ++j) {
              const detail::ConditionedStart<T>& st = start[record(j)];
              if (!(st.geometry > T(0)) || j == skip) continue;
              const Pair& w = starting_w[record(j)];
              const S a = w[0] * st.geometry, b = w[1] * st.geometry;
              if (st.flags & conditioned_light_technique) {
                w2[0] += a;
                w2[1] += b;
                if (const std::uint32_t iu = record_u[record(j)]; iu != 0) {  // forced_weight > 0
                  const Pair& u = starting_u[iu];
                  const T forced = st.geometry * st.forced_weight;
                  u2[0] += u[0] * forced;
                  u2[1] += u[1] * forced;
                }
              } else if (st.flags & conditioned_potential) {
                w1[0] += a;
                w1[1] += b;
              } else {
                w0[0] += a;
                w0[1] += b;
              }
            }
            std::array<ConditionedValues<S>, 3> sum;
            sum[0].w = w0;
            sum[1].w = w1;
            sum[2].w = w2;
            sum[2].u = u2;
            return sum;
          };
          // Ending slot i's values from the class sums `sum` into `sums` (U and W, or W alone).
          auto add_classes = [&](std::uint32_t i, const std::array<ConditionedValues<S>, 3>& sum, auto& sums) {
            // Field by field: a ConditionedJunction built from them went through the stack.
            const detail::ClassJunctions<S>& junctions = class_junction[class_offset[g] + (i - ending.begin)];
            auto acc = sums;  // a local copy, as in add_row
            for (int k_class = 0; k_class < 3; ++k_class) {
              const std::uint8_t code = junctions.code[k_class];
              detail::apply_junction(junctions.transfer, junctions.r[k_class], code,
                                     detail::read_successor(code, sum[k_class].u, sum[k_class].w), acc);
            }
            sums = acc;
          };
          // Stored, not returned: a returned value went through the stack (figures.md).
          auto update = [&](std::uint32_t i, const std::array<ConditionedValues<S>, 3>& sum) {
            if (slot_u[i] != 0) {
              ConditionedValues<S> acc = emission_values(i);
              add_classes(i, sum, acc);
              store(i, acc);
            } else {
              Pair acc = emission_values(i).w;
              add_classes(i, sum, acc);
              current_w[i] = acc;
            }
          };
          const std::array<ConditionedValues<S>, 3> all = class_sums(no_cluster);
          for (std::uint32_t i = ending.begin; i < ending.end; ++i) update(i, all);
          // A segment starting here too does not join itself (propagation/propagate.hpp): its
          // sums again without its own start, summed afresh (no cancellation of a dominant term).
          for (std::uint32_t j = starting.begin; j < starting.end; ++j)
            if (const std::uint32_t i = start[record(j)].source; ending.contains(i)) update(i, class_sums(j));
          return;
        }
      }
      const T kernel = support.kernel(g);
      // Ending slot i's junctions into `sums` (U and W, or W alone where no junction reads its U).
      auto add_row = [&](std::uint32_t i, auto& sums) {
        auto acc = sums;  // summed in a local copy: through the reference the sweeps were slower (figures.md)
        if (const Junction* row = table.row(i, starting.begin)) {
          // Only a light-born s forces a start (conditioned_coefficients): the other rows read W.
          if (end[i].flags & conditioned_light_born) {
            for (std::uint32_t j = starting.begin; j < starting.end; ++j, ++row)
              if (row->code != detail::no_junction) detail::apply_junction(*row, read(*row, record(j)), acc);
          } else {
            for (std::uint32_t j = starting.begin; j < starting.end; ++j, ++row)
              if (row->code != detail::no_junction) detail::apply_junction(*row, starting_w[record(j)], acc);
          }
        } else {
          for (std::uint32_t j = starting.begin; j < starting.end; ++j)
            if (joins(i, j)) {
              const Junction jn = junction(i, j, kernel);
              detail::apply_junction(jn, read(jn, record(j)), acc);
            }
        }
        sums = acc;
      };
      for (std::uint32_t i = ending.begin; i < ending.end; ++i) {
        if (slot_u[i] != 0) {
          ConditionedValues<S> acc = emission_values(i);
          add_row(i, acc);
          store(i, acc);
        } else {
          Pair acc = emission_values(i).w;
          add_row(i, acc);
          current_w[i] = acc;
        }
      }
    });
    round_trips.take_out(k, starting_w, starting_u, record_u, current_w, current_u, slot_u);
    if (depth > 1) {
      lagged_w.keep(k + 1, std::span<const Pair>(current_w), parallel_for);
      lagged_u.keep_each(k + 1, [&](std::uint32_t i) -> const Pair& { return current_u[slot_u[i]]; }, parallel_for);
    }
  }
  const ConditionedMemory memory{table.value_bytes(),
      lagged_w.bytes() + lagged_u.bytes() + (start_watch.capacity() + u_watch.capacity()) * sizeof(std::uint32_t),
      (current_u.capacity() + starting_u.capacity()) * sizeof(Pair) + source_u.capacity() * sizeof(std::uint32_t),
      round_trips.peak_bytes()};
  // The propagation's peak is here: what only the sweeps read goes before the result is allocated.
  table = {};
  lagged_u = {};
  detail::release(starting_w, starting_u, current_u, start, end, emission, class_junction, class_offset, slot_u, record_u,
                  source_u, start_watch, u_watch);
  round_trips = {};
  // Segments whose y end is in no group keep their emission; each segment's value is over
  // paths of at most iterations + 1 segments, A^(iterations + 1 - p(s)).
  const auto budget_of = [&](std::size_t s) { return depth == 1 ? iterations : iterations + 1 - int(in.pieces[s]); };
  weighted.resize(n);
  for_blocks(n, parallel_for, [&](std::size_t s) {
    const ConditionedValues<S> v = detail::conditioned_emission(in, s);
    weighted[s] = budget_of(s) < 0 ? S(T(0)) : S(v.w[0] + v.w[1]);
  });
  // A segment of p > 1 pieces reads its value from its slot's ring (one watch per slot).
  for_blocks(ending_slots, parallel_for, [&](std::size_t i) {
    const std::uint32_t s = ending_segment[i];
    const int b = budget_of(s);
    if (b <= 0 || (depth > 1 && in.pieces[s] > 1)) return;  // its emission, nothing, or a ring's
    weighted[s] = current_w[i][0] + current_w[i][1];
  });
  for_blocks(lagged_w.watch_count(), parallel_for, [&](std::size_t id) {
    const std::uint32_t s = ending_segment[lagged_w.slot(std::uint32_t(id))];
    if (const int b = budget_of(s); b > 0) {
      const Pair& w = lagged_w.at(std::uint32_t(id), b);
      weighted[s] = w[0] + w[1];
    }
  });
  return memory;
}

}  // namespace segpath
