// The recursive MMIS estimator (N39) written as the plain recursion: from a segment s, recurse
// into every candidate successor s' in the kernel support of y_s (those starting in the
// cluster of y_s), each weighted by its MMIS weight w(s') = 1 / sum over all technique samples
// of p(s' | t):
//   <L(s)> = L_e(s) + K sum_{s' != s} f_r(s, s') G(s') w(s') <L(s')>,  to a depth of `depth` links
// (a segment whose two ends share a cluster does not join itself, and a chain goes no round trip
// a -> b -> a between backtrack partners: see propagation/propagate.hpp).
// Exponential in depth: the reference that propagation (propagation/propagate.hpp) must match.
#pragma once

#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/clustering.hpp"

#include <cstdint>
#include <span>

namespace segpath {

namespace detail {
/// recursive_mmis_radiance from s, reached from `from` (no_cluster: s starts the chain).
template <Spectrum S, class Link>
[[nodiscard]] S recursive_mmis_radiance_from(const Clustering<spectrum_scalar_t<S>>& clustering, std::span<const S> emitted,
                                             std::span<const spectrum_scalar_t<S>> weighted_geometry, const Link& link,
                                             std::span<const std::uint32_t> backtrack, std::uint32_t s, std::uint32_t from,
                                             int depth) {
  using T = spectrum_scalar_t<S>;
  S value = emitted[s];
  const std::uint32_t c = clustering.cluster_of_y(s);
  if (depth == 0 || c == no_cluster) return value;
  const Cluster<T>& cluster = clustering.clusters()[c];
  // from -> s -> from is a round trip where the two are partners.
  const bool partners = from != no_cluster && !backtrack.empty() && (backtrack[s] == from || backtrack[from] == s);
  S sum(T(0));
  for (const std::uint32_t sp : clustering.starting_segments(c)) {
    if (sp == s || (partners && sp == from)) continue;
    sum += link(s, sp) * (recursive_mmis_radiance_from(clustering, emitted, weighted_geometry, link, backtrack, sp, s, depth - 1) *
                          weighted_geometry[sp]);
  }
  return value + sum * cluster.kernel;
}
}  // namespace detail

/// <L(s)> of (N39) truncated after `depth` links (depth 0: L_e(s)). `link(s, s')` is
/// f_r(s, s') (N20); `weighted_geometry[s']` is G(s') w(s'); `backtrack` as
/// PropagationInputs::backtrack (empty: no round trips are left out).
template <Spectrum S, class Link>
[[nodiscard]] S recursive_mmis_radiance(const Clustering<spectrum_scalar_t<S>>& clustering, std::span<const S> emitted,
                                        std::span<const spectrum_scalar_t<S>> weighted_geometry, const Link& link,
                                        std::uint32_t s, int depth, std::span<const std::uint32_t> backtrack = {}) {
  return detail::recursive_mmis_radiance_from(clustering, emitted, weighted_geometry, link, backtrack, s, no_cluster, depth);
}

/// The pixel estimate of (N40): sum over the sensor segments s of W G(s) w(s) <L(s)>; the caller
/// passes W G w per sensor segment as `sensor_weight`.
template <Spectrum S, class Link>
[[nodiscard]] S recursive_mmis_pixel(const Clustering<spectrum_scalar_t<S>>& clustering, std::span<const S> emitted,
                                     std::span<const spectrum_scalar_t<S>> weighted_geometry, const Link& link,
                                     std::span<const std::uint32_t> sensor_segments,
                                     std::span<const spectrum_scalar_t<S>> sensor_weight, int depth) {
  using T = spectrum_scalar_t<S>;
  S total(T(0));
  for (std::size_t i = 0; i < sensor_segments.size(); ++i)
    total += recursive_mmis_radiance(clustering, emitted, weighted_geometry, link, sensor_segments[i], depth) *
             sensor_weight[i];
  return total;
}

}  // namespace segpath
