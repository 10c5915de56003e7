// Iterative propagation (SPEC 1.8, the paper's Algorithm 1) of the recursive MMIS estimator
// (N39): with the pool clustered,
//   out(s) = L_e(s) + K_C(y_s) sum_{s' starting in C(y_s)} f_r(s, s') G(s') w(s') in(s'),
// Jacobi style (in() is read from a copy taken before the sweep), so after k iterations every
// path of up to k + 1 segments is counted once. Cost per iteration: sum over clusters of
// (#ending x #starting) link evaluations, or (#ending + #starting) for factorised clusters,
// plus one random read per starting segment; with the segments in ending order
// (Clustering::ending_order) and a link reading per-slot data, every other read and write is in
// order: out of cache the time per segment is bound by memory bandwidth, about twice the
// in-cache time and flat beyond (bench/propagation). Memory O(#segments).
#pragma once

#include "segpath/core/parallel.hpp"
#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/disk_junctions.hpp"

#include <algorithm>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace segpath {

/// What propagation needs of a pool, per segment s (indices into the clustered span):
///  - emitted[s]: L_e(s);
///  - weighted_geometry[s]: G(s) w(s), w the MMIS weight 1 / sum_t p(s | t) (N39);
///  - link(s, s'): f_r(s, s') of (N20), for s ending and s' starting in the same cluster; or
///    link(s, s', i, j) with i the ending slot of s and j the starting slot of s' (Cluster),
///    for a link that reads what it needs from arrays in slot order (read in order by the
///    loop below) instead of at segment ids;
///  - diffuse[s] and factorised[c]: where cluster c is factorised, f_r(s, s') = diffuse[s] for
///    every s ending and s' starting in it (a Lambertian end, every s' leaving its front
///    side), so its sum is computed once per cluster: O(n + m) instead of O(n m).
template <Spectrum S, class Link>
struct PropagationInputs {
  using T = spectrum_scalar_t<S>;
  const Clustering<T>& clustering;
  std::span<const S> emitted;
  std::span<const T> weighted_geometry;
  Link link;
  std::span<const S> diffuse = {};
  std::span<const std::uint8_t> factorised = {};
};

/// The buffers of propagate() besides its result, reusable across calls: per segment
/// in(s) G w(s) next to G w(s), and per starting slot (at most one per segment) copies of both.
template <Spectrum S>
struct PropagationWorkspace {
  using T = spectrum_scalar_t<S>;
  struct Weighted {
    S value;  ///< in(s) G w(s)
    T weight;  ///< G w(s)
  };
  std::vector<Weighted> weighted;
  std::vector<T> starting_weight;
  std::vector<S> starting_value;
  /// At most.
  static constexpr std::size_t bytes_per_segment = sizeof(Weighted) + sizeof(S) + sizeof(T);
};

/// Runs `iterations` >= 1 Jacobi iterations from in(s) = L_e(s); returns L after them in
/// `radiance` (size = #segments). Each iteration first gathers in(s') G w(s') into starting
/// slot order (the one random read per starting segment, in a tight loop that overlaps the
/// misses), then runs over the clusters reading slot data and, in ending order, the
/// per-segment data in order; it reads in() only through the gathered copies, so out() is
/// written in place. Parallel through `parallel_for`; each out(s) is written by the one
/// cluster holding y_s and summed in the cluster's ref order, so the result is the same on
/// any number of threads and under any numbering of the segments.
template <Spectrum S, class Link, ParallelFor P = SerialFor>
void propagate(const PropagationInputs<S, Link>& in, int iterations, std::vector<S>& radiance,
               PropagationWorkspace<S>& workspace, const P& parallel_for = {}) {
  using T = spectrum_scalar_t<S>;
  if (iterations < 1) throw std::invalid_argument("segpath::propagate: iterations must be >= 1");
  const std::size_t n = in.emitted.size();
  if (in.weighted_geometry.size() != n)
    throw std::invalid_argument("segpath::propagate: emitted and weighted_geometry differ in size");
  const bool has_factorisation = !in.factorised.empty();
  if (has_factorisation && (in.factorised.size() != in.clustering.clusters().size() || in.diffuse.size() != n))
    throw std::invalid_argument("segpath::propagate: factorisation data does not match the pool");
  using Id = std::uint32_t;
  constexpr bool by_slot = std::is_invocable_v<const Link&, Id, Id, Id, Id>;
  constexpr std::size_t blocks = 64;  // of segments or starting slots, for the flat loops
  const auto clusters = in.clustering.clusters();
  const auto starting_segment = in.clustering.starting_segments();
  const auto ending_segment = in.clustering.ending_segments();
  const std::size_t slots = starting_segment.size();
  auto& weighted = workspace.weighted;
  std::vector<T>& starting_weight = workspace.starting_weight;
  std::vector<S>& starting_value = workspace.starting_value;
  radiance.resize(n);
  weighted.resize(n);
  starting_weight.resize(slots);
  starting_value.resize(slots);
  parallel_for(blocks, [&](std::size_t b) {
    for (std::size_t s = n * b / blocks, e = n * (b + 1) / blocks; s < e; ++s) {
      radiance[s] = in.emitted[s];
      weighted[s] = {in.emitted[s] * in.weighted_geometry[s], in.weighted_geometry[s]};
    }
  });
  for (int k = 0; k < iterations; ++k) {
    parallel_for(blocks, [&](std::size_t b) {
      const std::size_t j0 = slots * b / blocks, j1 = slots * (b + 1) / blocks;
      if (k == 0) {
        for (std::size_t j = j0; j < j1; ++j) {
          const auto& w = weighted[starting_segment[j]];
          starting_value[j] = w.value;
          starting_weight[j] = w.weight;
        }
      } else {
        for (std::size_t j = j0; j < j1; ++j) starting_value[j] = weighted[starting_segment[j]].value;
      }
    });
    parallel_for(clusters.size(), [&](std::size_t c) {
      const Cluster<T>& cluster = clusters[c];
      const std::uint32_t starting = cluster.starting_count();
      const std::uint32_t first_ending = cluster.ending_slot(cluster.middle), last_ending = first_ending + cluster.ending_count();
      const T* weight = starting_weight.data() + cluster.slot;
      const S* value = starting_value.data() + cluster.slot;
      auto write = [&](std::uint32_t s, const S& out) {
        radiance[s] = out;
        weighted[s].value = out * weighted[s].weight;
      };
      if (has_factorisation && in.factorised[c]) {
        S sum(T(0));
        for (std::uint32_t q = 0; q < starting; ++q) sum += value[q];
        for (std::uint32_t i = first_ending; i < last_ending; ++i) {
          const std::uint32_t s = ending_segment[i];
          write(s, in.emitted[s] + in.diffuse[s] * sum * cluster.kernel);
        }
        return;
      }
      for (std::uint32_t i = first_ending; i < last_ending; ++i) {
        const std::uint32_t s = ending_segment[i];
        S sum(T(0));
        for (std::uint32_t q = 0; q < starting; ++q) {
          if (weight[q] == T(0)) continue;
          const std::uint32_t j = cluster.slot + q;
          if constexpr (by_slot) {
            sum += in.link(s, starting_segment[j], i, j) * value[q];
          } else {
            sum += in.link(s, starting_segment[j]) * value[q];
          }
        }
        write(s, in.emitted[s] + sum * cluster.kernel);
      }
    });
    // Segments whose y end is in no cluster (a light at infinity, a point light) keep L_e.
  }
}

/// propagate() with a workspace of its own; `scratch` becomes its per-slot in(s') G w(s')
/// buffer (resized as needed).
template <Spectrum S, class Link, ParallelFor P = SerialFor>
void propagate(const PropagationInputs<S, Link>& in, int iterations, std::vector<S>& radiance, std::vector<S>& scratch,
               const P& parallel_for = {}) {
  PropagationWorkspace<S> workspace;
  workspace.starting_value.swap(scratch);
  propagate(in, iterations, radiance, workspace, parallel_for);
  scratch.swap(workspace.starting_value);
}

/// The same iteration over the disk support (propagation/disk_junctions.hpp): each out(s) sums
/// over starting_near(s), in increasing id order, with the one kernel value 1 / (pi r^2).
/// Cost per iteration: the number of junctions; parallel over segments, deterministic.
template <Spectrum S, class Link>
struct DiskPropagationInputs {
  using T = spectrum_scalar_t<S>;
  const DiskJunctions<T>& junctions;
  std::span<const S> emitted;
  std::span<const T> weighted_geometry;
  Link link;
};

template <Spectrum S, class Link, ParallelFor P = SerialFor>
void propagate(const DiskPropagationInputs<S, Link>& in, int iterations, std::vector<S>& radiance, std::vector<S>& scratch,
               const P& parallel_for = {}) {
  using T = spectrum_scalar_t<S>;
  if (iterations < 1) throw std::invalid_argument("segpath::propagate: iterations must be >= 1");
  const std::size_t n = in.emitted.size();
  if (in.weighted_geometry.size() != n || in.junctions.segment_count() != n)
    throw std::invalid_argument("segpath::propagate: emitted, weighted_geometry and the junctions differ in size");
  radiance.assign(in.emitted.begin(), in.emitted.end());
  scratch.assign(in.emitted.begin(), in.emitted.end());
  const T kernel = in.junctions.kernel();
  constexpr std::size_t chunk = 1024;
  const std::size_t chunks = (n + chunk - 1) / chunk;
  for (int k = 0; k < iterations; ++k) {
    const std::vector<S>& current = radiance;
    std::vector<S>& next = scratch;
    parallel_for(chunks, [&](std::size_t c) {
      for (std::size_t s = c * chunk; s < std::min(n, (c + 1) * chunk); ++s) {
        S sum(T(0));
        for (const std::uint32_t sp : in.junctions.starting_near(std::uint32_t(s))) {
          const T wg = in.weighted_geometry[sp];
          if (wg == T(0)) continue;
          sum += in.link(std::uint32_t(s), sp) * (current[sp] * wg);
        }
        next[s] = in.emitted[s] + sum * kernel;
      }
    });
    std::swap(radiance, scratch);
  }
}

}  // namespace segpath
