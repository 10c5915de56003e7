// Iterative propagation (SPEC 1.8, the paper's Algorithm 1) of the recursive MMIS estimator
// (N39): with the pool clustered,
//   out(s) = L_e(s) + K_C(y_s) sum_{s' starting in C(y_s)} f_r(s, s') G(s') w(s') in(s'),
// Jacobi style (double buffered), so after k iterations every path of up to k + 1 segments is
// counted once. Cost per iteration: sum over clusters of (#ending x #starting), or
// (#ending + #starting) for factorised clusters; memory O(#segments).
#pragma once

#include "segpath/core/parallel.hpp"
#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/disk_junctions.hpp"

#include <algorithm>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <vector>

namespace segpath {

/// What propagation needs of a pool, per segment s (indices into the clustered span):
///  - emitted[s]: L_e(s);
///  - weighted_geometry[s]: G(s) w(s), w the MMIS weight 1 / sum_t p(s | t) (N39);
///  - link(s, s'): f_r(s, s') of (N20), for s ending and s' starting in the same cluster;
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

/// Runs `iterations` >= 1 Jacobi iterations from in(s) = L_e(s); returns L after them in
/// `radiance` (size = #segments). `scratch` is the second buffer (resized as needed).
/// Parallel over clusters through `parallel_for`; each out(s) is written by the one cluster
/// holding y_s and summed in the cluster's sorted order, so the result is the same on any
/// number of threads.
template <Spectrum S, class Link, ParallelFor P = SerialFor>
void propagate(const PropagationInputs<S, Link>& in, int iterations, std::vector<S>& radiance, std::vector<S>& scratch,
               const P& parallel_for = {}) {
  using T = spectrum_scalar_t<S>;
  if (iterations < 1) throw std::invalid_argument("segpath::propagate: iterations must be >= 1");
  const std::size_t n = in.emitted.size();
  if (in.weighted_geometry.size() != n)
    throw std::invalid_argument("segpath::propagate: emitted and weighted_geometry differ in size");
  const bool has_factorisation = !in.factorised.empty();
  if (has_factorisation && (in.factorised.size() != in.clustering.clusters().size() || in.diffuse.size() != n))
    throw std::invalid_argument("segpath::propagate: factorisation data does not match the pool");
  radiance.assign(in.emitted.begin(), in.emitted.end());
  scratch.assign(in.emitted.begin(), in.emitted.end());
  const auto clusters = in.clustering.clusters();
  const auto refs = in.clustering.refs();
  for (int k = 0; k < iterations; ++k) {
    const std::vector<S>& current = radiance;
    std::vector<S>& next = scratch;
    parallel_for(clusters.size(), [&](std::size_t c) {
      const Cluster<T>& cluster = clusters[c];
      if (has_factorisation && in.factorised[c]) {
        S sum(T(0));
        for (std::uint32_t r = cluster.begin; r < cluster.middle; ++r) {
          const std::uint32_t sp = refs[r].segment;
          sum += current[sp] * in.weighted_geometry[sp];
        }
        for (std::uint32_t r = cluster.middle; r < cluster.end; ++r) {
          const std::uint32_t s = refs[r].segment;
          next[s] = in.emitted[s] + in.diffuse[s] * sum * cluster.kernel;
        }
        return;
      }
      for (std::uint32_t r = cluster.middle; r < cluster.end; ++r) {
        const std::uint32_t s = refs[r].segment;
        S sum(T(0));
        for (std::uint32_t q = cluster.begin; q < cluster.middle; ++q) {
          const std::uint32_t sp = refs[q].segment;
          const T wg = in.weighted_geometry[sp];
          if (wg == T(0)) continue;
          sum += in.link(s, sp) * (current[sp] * wg);
        }
        next[s] = in.emitted[s] + sum * cluster.kernel;
      }
    });
    // Segments whose y end is in no cluster (a light at infinity, a point light) keep L_e.
    std::swap(radiance, scratch);
  }
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
