// Iterative propagation (SPEC 1.8, the paper's Algorithm 1) of the recursive MMIS estimator
// (N39): with the pool clustered,
//   out(s) = L_e(s) + K_C(y_s) sum_{s' starting in C(y_s), s' != s} f_r(s, s') G(s') w(s') in(s'),
// Jacobi style (in() is gathered before each sweep), so after k iterations every path of up to
// k + 1 segments is counted once. Cost per iteration: sum over clusters of (#ending x
// #starting) link evaluations, or (#ending + #starting) for factorised clusters. Memory
// traffic: everything is kept per slot (propagation/clustering.hpp), in cluster order, so an
// iteration reads and writes in order but for in(s'), one random read per starting segment;
// out of cache it is bound by memory bandwidth and its time per segment stays flat
// (bench/propagation). Per pool, the inputs are gathered into slot order once. Memory
// O(#segments).
//
// A segment never joins itself (s' != s above; SPEC 1.8 step 5 writes the sum over every s').
// A chain that uses one sample twice is not a path sample: the expectation of the pooled sum is
// the kernel path integral over chains of distinct samples only. The self-junction of a segment
// whose two ends share a cluster (a short segment, e.g. floor -> mirror sphere -> floor) has a
// gain K f_r G w that can exceed 1 near a glossy lobe's peak, and the Jacobi sweeps then raise
// it to the k-th power: one such segment made a 700x firefly on Cornell box 1.
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

/// What propagate() keeps besides its result, reusable across calls: the inputs in slot order
/// (prepare_propagation, once per pool) and the per-iteration buffers.
template <Spectrum S>
struct PropagationWorkspace {
  using T = spectrum_scalar_t<S>;
  // Per starting slot j, segment s': the ending slot in(s') is read from (no_cluster: s' ends in
  // no cluster and in(s') = L_e(s')), G w(s'), L_e(s') G w(s'), and in(s') G w(s').
  std::vector<std::uint32_t> source;
  std::vector<T> starting_weight;
  std::vector<S> starting_emitted, starting_value;
  // Per ending slot i, segment s: L_e(s), diffuse(s) (where factorising) and out(s).
  std::vector<S> ending_emitted, ending_diffuse, out;
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
inline constexpr std::size_t propagation_blocks = 64;  // of slots, for the flat loops

template <class Body, ParallelFor P>
void for_blocks(std::size_t n, const P& parallel_for, const Body& body) {
  parallel_for(propagation_blocks, [&](std::size_t b) {
    for (std::size_t i = n * b / propagation_blocks, e = n * (b + 1) / propagation_blocks; i < e; ++i) body(i);
  });
}
}  // namespace detail

/// The per-pool half of propagate(): gathers emitted radiance, G w and the diffuse factors
/// into slot order (one random read each per slot).
template <Spectrum S, class Link, ParallelFor P = SerialFor>
void prepare_propagation(const PropagationInputs<S, Link>& in, PropagationWorkspace<S>& workspace,
                         const P& parallel_for = {}) {
  const std::size_t n = in.emitted.size();
  if (in.weighted_geometry.size() != n)
    throw std::invalid_argument("segpath::propagate: emitted and weighted_geometry differ in size");
  const bool has_factorisation = !in.factorised.empty();
  if (has_factorisation && (in.factorised.size() != in.clustering.clusters().size() || in.diffuse.size() != n))
    throw std::invalid_argument("segpath::propagate: factorisation data does not match the pool");
  const auto starting_segment = in.clustering.starting_segments();
  const auto ending_segment = in.clustering.ending_segments();
  auto& w = workspace;
  w.source.resize(starting_segment.size());
  w.starting_weight.resize(starting_segment.size());
  w.starting_emitted.resize(starting_segment.size());
  w.starting_value.resize(starting_segment.size());
  w.ending_emitted.resize(ending_segment.size());
  w.ending_diffuse.resize(has_factorisation ? ending_segment.size() : 0);
  w.out.resize(ending_segment.size());
  detail::for_blocks(starting_segment.size(), parallel_for, [&](std::size_t j) {
    const std::uint32_t sp = starting_segment[j];
    w.source[j] = in.clustering.ending_slot_of(sp);
    w.starting_weight[j] = in.weighted_geometry[sp];
    w.starting_emitted[j] = in.emitted[sp] * in.weighted_geometry[sp];
  });
  detail::for_blocks(ending_segment.size(), parallel_for, [&](std::size_t i) {
    w.ending_emitted[i] = in.emitted[ending_segment[i]];
    if (has_factorisation) w.ending_diffuse[i] = in.diffuse[ending_segment[i]];
  });
}

/// The iterations of propagate() on a workspace prepared for the same inputs: `iterations`
/// >= 1 Jacobi iterations from in(s) = L_e(s); returns L after them in `radiance` (size =
/// #segments). Each iteration but the first gathers in(s') G w(s') into starting slot order
/// (the one random read per starting segment, in a tight loop that overlaps the misses), then
/// runs over the clusters reading and writing slot data in order; the result is scattered to
/// segment order at the end. Parallel through `parallel_for`; each out(s) is written by the one
/// cluster holding y_s and summed in the cluster's ref order, so the result is the same on any
/// number of threads.
template <Spectrum S, class Link, ParallelFor P = SerialFor>
void propagate_prepared(const PropagationInputs<S, Link>& in, int iterations, std::vector<S>& radiance,
                        PropagationWorkspace<S>& workspace, const P& parallel_for = {}) {
  using T = spectrum_scalar_t<S>;
  using Id = std::uint32_t;
  if (iterations < 1) throw std::invalid_argument("segpath::propagate: iterations must be >= 1");
  const auto clusters = in.clustering.clusters();
  const auto starting_segment = in.clustering.starting_segments();
  const auto ending_segment = in.clustering.ending_segments();
  auto& w = workspace;
  if (w.source.size() != starting_segment.size() || w.out.size() != ending_segment.size() ||
      w.ending_diffuse.size() != (in.factorised.empty() ? 0 : ending_segment.size()))
    throw std::invalid_argument("segpath::propagate_prepared: the workspace is not prepared for these inputs");
  constexpr bool by_slot = std::is_invocable_v<const Link&, Id, Id, Id, Id>;
  const bool has_factorisation = !in.factorised.empty();
  for (int k = 0; k < iterations; ++k) {
    if (k > 0) {
      detail::for_blocks(starting_segment.size(), parallel_for, [&](std::size_t j) {
        const std::uint32_t i = w.source[j];
        w.starting_value[j] = i == no_cluster ? w.starting_emitted[j] : w.out[i] * w.starting_weight[j];
      });
    }
    const std::vector<S>& values = k == 0 ? w.starting_emitted : w.starting_value;
    parallel_for(clusters.size(), [&](std::size_t c) {
      const Cluster<T>& cluster = clusters[c];
      const std::uint32_t starting = cluster.starting_count();
      const std::uint32_t first_ending = cluster.ending_slot(cluster.middle);
      const std::uint32_t last_ending = first_ending + cluster.ending_count();
      const T* weight = w.starting_weight.data() + cluster.slot;
      const S* value = values.data() + cluster.slot;
      const std::uint32_t* source = w.source.data() + cluster.slot;  // source[q] == i: s' is s
      if (has_factorisation && in.factorised[c]) {
        S sum(T(0));
        for (std::uint32_t q = 0; q < starting; ++q) sum += value[q];
        for (std::uint32_t i = first_ending; i < last_ending; ++i)
          w.out[i] = w.ending_emitted[i] + w.ending_diffuse[i] * sum * cluster.kernel;
        // A segment starting here too does not join itself: its sum again without its own term
        // (summed afresh, not subtracted, so that a dominant own term leaves no cancellation).
        for (std::uint32_t own = 0; own < starting; ++own) {
          const std::uint32_t i = source[own];
          if (i < first_ending || i >= last_ending) continue;
          S others(T(0));
          for (std::uint32_t q = 0; q < starting; ++q)
            if (q != own) others += value[q];
          w.out[i] = w.ending_emitted[i] + w.ending_diffuse[i] * others * cluster.kernel;
        }
        return;
      }
      for (std::uint32_t i = first_ending; i < last_ending; ++i) {
        S sum(T(0));
        for (std::uint32_t q = 0; q < starting; ++q) {
          if (weight[q] == T(0) || source[q] == i) continue;
          const std::uint32_t j = cluster.slot + q;
          if constexpr (by_slot) {
            sum += in.link(ending_segment[i], starting_segment[j], i, j) * value[q];
          } else {
            sum += in.link(ending_segment[i], starting_segment[j]) * value[q];
          }
        }
        w.out[i] = w.ending_emitted[i] + sum * cluster.kernel;
      }
    });
  }
  // Segments whose y end is in no cluster (a light at infinity, a point light) keep L_e.
  radiance.assign(in.emitted.begin(), in.emitted.end());
  detail::for_blocks(ending_segment.size(), parallel_for, [&](std::size_t i) { radiance[ending_segment[i]] = w.out[i]; });
}

/// prepare_propagation() and propagate_prepared().
template <Spectrum S, class Link, ParallelFor P = SerialFor>
void propagate(const PropagationInputs<S, Link>& in, int iterations, std::vector<S>& radiance,
               PropagationWorkspace<S>& workspace, const P& parallel_for = {}) {
  if (iterations < 1) throw std::invalid_argument("segpath::propagate: iterations must be >= 1");
  prepare_propagation(in, workspace, parallel_for);
  propagate_prepared(in, iterations, radiance, workspace, parallel_for);
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
