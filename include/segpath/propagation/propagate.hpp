// Iterative propagation (SPEC 1.8, the paper's Algorithm 1) of the recursive MMIS estimator
// (N39), over any JunctionSupport (propagation/junction_support.hpp: voxel clusters or disks):
// with g the group holding y_s,
//   out(s) = L_e(s) + K_g sum_{s' starting in g, s' != s} f_r(s, s') G(s') w(s') in(s'),
// Jacobi style (in() is gathered before each sweep), so after k iterations every path of up to
// k + 1 segments is counted once. Cost per iteration: sum over groups of (#ending x
// #starting) link evaluations, or (#ending + #starting) for factorised clusters. Memory
// traffic: over clusters everything is kept per slot, in group order, so an iteration reads
// and writes in order but for in(s'), one random read per starting slot; out of cache it is
// bound by memory bandwidth and its time per segment stays flat (bench/propagation). Over disks
// (a segment starts in every disk holding its x end) what is read of a start is kept per
// segment and read at random (StartRecords). Per pool, the inputs are gathered once. Memory
// O(#segments).
//
// A segment never joins itself (s' != s above; SPEC 1.8 step 5 writes the sum over every s').
// A chain that uses one sample twice is not a path sample: the expectation of the pooled sum is
// the kernel path integral over chains of distinct samples only. The self-junction of a segment
// whose two ends share a cluster (a short segment, e.g. floor -> mirror sphere -> floor) has a
// gain K f_r G w that can exceed 1 near a glossy lobe's peak, and the Jacobi sweeps then raise
// it to the k-th power: one such segment made a 700x firefly on Cornell box 1. Nor does a chain
// go a -> b -> a between backtrack partners (PropagationInputs::backtrack, taken out after each
// sweep as propagation/round_trips.hpp derives).
#pragma once

#include "segpath/core/parallel.hpp"
#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/disk_junctions.hpp"
#include "segpath/propagation/junction_support.hpp"
#include "segpath/propagation/round_trips.hpp"
#include "segpath/propagation/segment_budget.hpp"

#include <algorithm>
#include <cstdint>
#include <ranges>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace segpath {

/// What propagation needs of a pool, per segment s (indices into the pool):
///  - support: who joins whom (a JunctionSupport: Clustering, DiskJunctions);
///  - emitted[s]: L_e(s);
///  - weighted_geometry[s]: G(s) w(s), w the MMIS weight 1 / sum_t p(s | t) (N39);
///  - link(s, s'): f_r(s, s') of (N20), for s ending and s' starting in the same group; or
///    link(s, s', i, j) with i the ending slot of s and j the starting slot of s', for a link
///    that reads what it needs from arrays in slot order (read in order by the loop below)
///    instead of at segment ids;
///  - diffuse[s] and factorised[g] (J::factorisable supports only): where group g is
///    factorised, f_r(s, s') = diffuse[s] for every s ending and s' starting in it (a
///    Lambertian end, every s' leaving its front side), so its sum is computed once per group:
///    O(n + m) instead of O(n m);
///  - backtrack[s] (empty: none; no_cluster: none for s): a segment b that no chain goes a round
///    trip s -> b -> s or b -> s -> b with (propagation/round_trips.hpp; in segment filtering
///    the segment that drew s, or the one s drew).
template <Spectrum S, class Link, JunctionSupport J = Clustering<spectrum_scalar_t<S>>>
struct PropagationInputs {
  using T = spectrum_scalar_t<S>;
  static_assert(std::is_same_v<typename J::Scalar, T>, "segpath::PropagationInputs: the support's Scalar is not the spectrum's");
  const J& support;
  std::span<const S> emitted;
  std::span<const T> weighted_geometry;
  Link link;
  std::span<const S> diffuse = {};
  std::span<const std::uint8_t> factorised = {};
  /// p(s): the segments s stands for, more than 1 for a chain through delta bounces; empty:
  /// all 1. Paths are limited by their segments, not their pooled ones (segment_budget.hpp).
  std::span<const std::uint16_t> pieces = {};
  std::span<const std::uint32_t> backtrack = {};
};

/// What propagate() keeps besides its result, reusable across calls: the inputs in slot order
/// (prepare_propagation, once per pool) and the per-iteration buffers.
template <Spectrum S>
struct PropagationWorkspace {
  using T = spectrum_scalar_t<S>;
  // Per start record (StartRecords: the starting slot, or the segment), segment s': the ending
  // slot in(s') is read from (no_cluster: s' ends in no group and in(s') = L_e(s')), G w(s'),
  // L_e(s') G w(s'), and in(s') G w(s').
  std::vector<std::uint32_t> source;
  std::vector<T> starting_weight;
  std::vector<S> starting_emitted, starting_value;
  // Per ending slot i, segment s: L_e(s), diffuse(s) (where factorising) and out(s).
  std::vector<S> ending_emitted, ending_diffuse, out;
  /// Set by propagate: the bytes its lagged values of chains took (LaggedValues and the watch
  /// of each start and end), 0 without chains. Not in bytes() nor bytes_per_segment.
  std::size_t lagged_bytes = 0;
  /// Set by propagate: the most its round trips held at once (RadianceRoundTrips::peak_bytes),
  /// 0 without backtrack partners. Not in bytes() nor bytes_per_segment.
  std::size_t round_trip_bytes = 0;
  /// At most.
  static constexpr std::size_t bytes_per_segment = sizeof(std::uint32_t) + sizeof(T) + 5 * sizeof(S);
  [[nodiscard]] std::size_t bytes() const noexcept {
    return source.capacity() * sizeof(std::uint32_t) + starting_weight.capacity() * sizeof(T) +
           (starting_emitted.capacity() + starting_value.capacity() + ending_emitted.capacity() + ending_diffuse.capacity() +
            out.capacity()) *
               sizeof(S);
  }
};

namespace detail {
/// Groups per task of a propagation sweep.
inline constexpr std::size_t propagation_group_chunk = 256;

/// body(g) for every group of `support`, in parallel over chunks of groups.
template <JunctionSupport J, ParallelFor P, class Body>
void for_groups(const J& support, const P& parallel_for, const Body& body) {
  const std::size_t groups = support.group_count();
  for_chunks(groups, chunk_count(groups, propagation_group_chunk), parallel_for, [&](std::size_t begin, std::size_t end) {
    for (std::size_t g = begin; g < end; ++g) body(g);
  });
}

/// Throws unless a propagation's per-segment inputs, of `n` segments, cover the support and
/// its factorisation flags (if any) match it.
template <JunctionSupport J>
void check_support(const J& support, std::size_t n, std::size_t factorised, std::size_t diffuse, const char* what) {
  if (support.segment_count() > n) throw std::invalid_argument(std::string(what) + ": the support has more segments than the inputs");
  if (factorised == 0) return;
  if (!J::factorisable) throw std::invalid_argument(std::string(what) + ": this support factorises nothing");
  if (factorised != support.group_count() || diffuse != n)
    throw std::invalid_argument(std::string(what) + ": factorisation data does not match the pool");
}
}  // namespace detail

/// The per-pool half of propagate(): gathers emitted radiance, G w and the diffuse factors
/// into slot (or start record) order, one random read each per slot.
template <Spectrum S, class Link, JunctionSupport J, ParallelFor P = SerialFor>
void prepare_propagation(const PropagationInputs<S, Link, J>& in, PropagationWorkspace<S>& workspace,
                         const P& parallel_for = {}) {
  const std::size_t n = in.emitted.size();
  if (in.weighted_geometry.size() != n)
    throw std::invalid_argument("segpath::propagate: emitted and weighted_geometry differ in size");
  if (!(in.backtrack.empty() || in.backtrack.size() == n))
    throw std::invalid_argument("segpath::propagate: backtrack needs one value per segment, or none");
  detail::check_support(in.support, n, in.factorised.size(), in.diffuse.size(), "segpath::propagate");
  const bool has_factorisation = !in.factorised.empty();
  const StartRecords<J> record(in.support);
  const auto ending_segment = in.support.ending_segments();
  const std::size_t ending_slots = std::ranges::size(ending_segment);
  auto& w = workspace;
  w.source.resize(record.size());
  w.starting_weight.resize(record.size());
  w.starting_emitted.resize(record.size());
  w.starting_value.resize(record.size());
  w.ending_emitted.resize(ending_slots);
  w.ending_diffuse.resize(has_factorisation ? ending_slots : 0);
  w.out.resize(ending_slots);
  for_blocks(record.size(), parallel_for, [&](std::size_t r) {
    const std::uint32_t sp = record.segment(r);
    w.source[r] = in.support.ending_slot_of(sp);
    w.starting_weight[r] = in.weighted_geometry[sp];
    w.starting_emitted[r] = in.emitted[sp] * in.weighted_geometry[sp];
  });
  for_blocks(ending_slots, parallel_for, [&](std::size_t i) {
    w.ending_emitted[i] = in.emitted[ending_segment[i]];
    if (has_factorisation) w.ending_diffuse[i] = in.diffuse[ending_segment[i]];
  });
}

/// The iterations of propagate() on a workspace prepared for the same inputs: `iterations`
/// >= 1 Jacobi iterations from in(s) = L_e(s); returns L after them in `radiance` (size =
/// #segments). Each iteration but the first gathers in(s') G w(s') into start record order
/// (the one random read per record, in a tight loop that overlaps the misses), then
/// runs over the groups reading and writing slot data in order; the result is scattered to
/// segment order at the end. Parallel through `parallel_for`; each out(s) is written by the one
/// group holding y_s and summed in increasing starting slot order, out(s) = L_e(s) +
/// (sum_j f_r (in G w)(s'_j)) K_g, so the result is the same on any number of threads.
template <Spectrum S, class Link, JunctionSupport J, ParallelFor P = SerialFor>
void propagate_prepared(const PropagationInputs<S, Link, J>& in, int iterations, std::vector<S>& radiance,
                        PropagationWorkspace<S>& workspace, const P& parallel_for = {}) {
  using T = spectrum_scalar_t<S>;
  using Id = std::uint32_t;
  if (iterations < 1) throw std::invalid_argument("segpath::propagate: iterations must be >= 1");
  const J& support = in.support;
  const auto starting_segment = support.starting_segments();
  const auto ending_segment = support.ending_segments();
  const StartRecords<J> record(support);
  auto& w = workspace;
  if (w.source.size() != record.size() || w.out.size() != std::ranges::size(ending_segment) ||
      w.ending_diffuse.size() != (in.factorised.empty() ? 0 : w.out.size()))
    throw std::invalid_argument("segpath::propagate_prepared: the workspace is not prepared for these inputs");
  constexpr bool by_slot = std::is_invocable_v<const Link&, Id, Id, Id, Id>;
  const bool has_factorisation = !in.factorised.empty();
  // Budgets (segment_budget.hpp): sweep k computes A^(k + 1) into out; a start s' of p pieces
  // reads A^(k + 1 - p)(s'), which `lagged` keeps for p > 1 (as for the results of chains).
  const int depth = detail::max_pieces(in.pieces, in.emitted.size());
  detail::LaggedValues<S> lagged;
  std::vector<std::uint32_t> start_watch, end_watch;
  if (depth > 1) {
    start_watch.assign(record.size(), detail::no_watch);
    end_watch.assign(w.out.size(), detail::no_watch);
    for (std::size_t r = 0; r < record.size(); ++r)
      if (const std::uint16_t p = in.pieces[record.segment(r)]; p > 1 && w.source[r] != no_cluster)
        start_watch[r] = lagged.watch(w.source[r], p);
    for (std::size_t i = 0; i < end_watch.size(); ++i)
      if (const std::uint16_t p = in.pieces[ending_segment[i]]; p > 1) end_watch[i] = lagged.watch(std::uint32_t(i), p);
    lagged.allocate();
  }
  workspace.lagged_bytes = lagged.bytes() + (start_watch.capacity() + end_watch.capacity()) * sizeof(std::uint32_t);
  // Round trips between backtrack partners, taken out after each sweep (propagation/round_trips.hpp).
  detail::RadianceRoundTrips<S> round_trips;
  round_trips.build(
      support, in.backtrack,
      [&](std::uint32_t i, std::uint32_t j) { return w.starting_weight[record(j)] != T(0) && w.source[record(j)] != i; },
      [&](std::size_t g, std::uint32_t i, std::uint32_t j) -> S {
        const T kernel = support.kernel(g);
        if constexpr (J::factorisable) {
          if (has_factorisation && in.factorised[g]) return w.ending_diffuse[i] * kernel;
        }
        if constexpr (by_slot) {
          return in.link(ending_segment[i], starting_segment[j], i, j) * kernel;
        } else {
          return in.link(ending_segment[i], starting_segment[j]) * kernel;
        }
      },
      [&](std::uint32_t j) { return std::uint32_t(record(j)); }, std::span<const T>(w.starting_weight),
      [&](std::uint32_t j) { return in.pieces.empty() ? 1 : int(in.pieces[starting_segment[j]]); }, depth);
  workspace.round_trip_bytes = round_trips.peak_bytes();
  for (int k = 0; k < iterations; ++k) {
    if (depth > 1) {
      const int budget = k + 1;
      for_blocks(w.source.size(), parallel_for, [&](std::size_t r) {
        const std::uint32_t i = w.source[r];
        const int b = budget - int(in.pieces[record.segment(r)]);
        if (b < 0) {
          w.starting_value[r] = S(T(0));
        } else if (b == 0 || i == no_cluster) {
          w.starting_value[r] = w.starting_emitted[r];
        } else {
          w.starting_value[r] = (start_watch[r] == detail::no_watch ? w.out[i] : lagged.at(start_watch[r], b)) * w.starting_weight[r];
        }
      });
    } else if (k > 0) {
      for_blocks(w.source.size(), parallel_for, [&](std::size_t r) {
        const std::uint32_t i = w.source[r];
        w.starting_value[r] = i == no_cluster ? w.starting_emitted[r] : w.out[i] * w.starting_weight[r];
      });
    }
    const S* value = (k == 0 && depth == 1 ? w.starting_emitted : w.starting_value).data();
    detail::for_groups(support, parallel_for, [&](std::size_t g) {
      const SlotRange ending = support.ending_slots(g), starting = support.starting_slots(g);
      const T kernel = support.kernel(g);
      if constexpr (J::factorisable) {
        if (has_factorisation && in.factorised[g]) {
          S sum(T(0));
          for (std::uint32_t j = starting.begin; j < starting.end; ++j) sum += value[record(j)];
          for (std::uint32_t i = ending.begin; i < ending.end; ++i)
            w.out[i] = w.ending_emitted[i] + w.ending_diffuse[i] * sum * kernel;
          // A segment starting here too does not join itself: its sum again without its own
          // term (summed afresh, not subtracted, so that a dominant own term leaves no
          // cancellation).
          for (std::uint32_t own = starting.begin; own < starting.end; ++own) {
            const std::uint32_t i = w.source[record(own)];
            if (!ending.contains(i)) continue;
            S others(T(0));
            for (std::uint32_t j = starting.begin; j < starting.end; ++j)
              if (j != own) others += value[record(j)];
            w.out[i] = w.ending_emitted[i] + w.ending_diffuse[i] * others * kernel;
          }
          return;
        }
      }
      for (std::uint32_t i = ending.begin; i < ending.end; ++i) {
        S sum(T(0));
        for (std::uint32_t j = starting.begin; j < starting.end; ++j) {
          const std::uint32_t r = record(j);
          if (w.starting_weight[r] == T(0) || w.source[r] == i) continue;  // source == i: s' is s
          if constexpr (by_slot) {
            sum += in.link(ending_segment[i], starting_segment[j], i, j) * value[r];
          } else {
            sum += in.link(ending_segment[i], starting_segment[j]) * value[r];
          }
        }
        w.out[i] = w.ending_emitted[i] + sum * kernel;
      }
    });
    round_trips.take_out(k, value, std::span<S>(w.out));
    if (depth > 1) lagged.keep(k + 1, std::span<const S>(w.out), parallel_for);
  }
  // Segments whose y end is in no group (a light at infinity, a point light) keep L_e.
  radiance.assign(in.emitted.begin(), in.emitted.end());
  if (depth == 1) {
    for_blocks(w.out.size(), parallel_for, [&](std::size_t i) { radiance[ending_segment[i]] = w.out[i]; });
    return;
  }
  // Each segment's value over paths of at most iterations + 1 segments: A^(iterations + 1 - p(s)).
  for_blocks(in.emitted.size(), parallel_for, [&](std::size_t s) {
    if (iterations + 1 - int(in.pieces[s]) < 0) radiance[s] = S(T(0));
  });
  for_blocks(w.out.size(), parallel_for, [&](std::size_t i) {
    const int b = iterations + 1 - int(in.pieces[ending_segment[i]]);
    if (b > 0) radiance[ending_segment[i]] = end_watch[i] == detail::no_watch ? w.out[i] : lagged.at(end_watch[i], b);
  });
}

/// prepare_propagation() and propagate_prepared().
template <Spectrum S, class Link, JunctionSupport J, ParallelFor P = SerialFor>
void propagate(const PropagationInputs<S, Link, J>& in, int iterations, std::vector<S>& radiance,
               PropagationWorkspace<S>& workspace, const P& parallel_for = {}) {
  if (iterations < 1) throw std::invalid_argument("segpath::propagate: iterations must be >= 1");
  prepare_propagation(in, workspace, parallel_for);
  propagate_prepared(in, iterations, radiance, workspace, parallel_for);
}

/// propagate() with a workspace of its own; `scratch` becomes its per-slot in(s') G w(s')
/// buffer (resized as needed).
template <Spectrum S, class Link, JunctionSupport J, ParallelFor P = SerialFor>
void propagate(const PropagationInputs<S, Link, J>& in, int iterations, std::vector<S>& radiance, std::vector<S>& scratch,
               const P& parallel_for = {}) {
  PropagationWorkspace<S> workspace;
  workspace.starting_value.swap(scratch);
  propagate(in, iterations, radiance, workspace, parallel_for);
  scratch.swap(workspace.starting_value);
}

}  // namespace segpath
