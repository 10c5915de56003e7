// The densities of the library's techniques for a pooled segment, from the samplers' own
// density functions (samplers/), in the segment's measure
// (area at x x area at y for a straight segment, area at x x solid angle at x for a chain):
// the pooled segments are visible, so every density here is the unoccluded one (N29-N34).
#pragma once

#include "segpath/algorithms/filtering/pool.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/kernels/disk.hpp"
#include "segpath/samplers/approximate.hpp"
#include "segpath/samplers/light_start.hpp"
#include "segpath/samplers/sensor_start.hpp"

#include <cmath>
#include <cstdint>

namespace segpath::filtering {

// The samplers filtering draws with (N33: approximate, the junction copied). Their kernel is
// the support's (voxel or disk), which the densities below leave out: the support multiplies
// by it, so the kernel type here is only a placeholder.
template <class Scn>
using CameraSuccessor = ApproximateNextSegmentSampler<Scn, DiskKernel<typename Scn::Scalar>>;
template <class Scn>
using LightPredecessor = ApproximateLightNextSegmentSampler<Scn, DiskKernel<typename Scn::Scalar>>;

/// p_w(s' | t) of the camera successor from t's end y_t (solid angle at y_t).
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar camera_technique_pdf(const Scn& scene, const Pool<typename Scn::Scalar, typename Scn::Spectrum>& pool,
                                                        std::uint32_t t, std::uint32_t sp) noexcept {
  return CameraSuccessor<Scn>::direction_pdf(scene, pool.segments[t].y, -pool.last_direction[t], pool.first_direction[sp]);
}
/// p_w(-s' | u) of the light predecessor from u's start x_u (solid angle at x_u).
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar light_technique_pdf(const Scn& scene, const Pool<typename Scn::Scalar, typename Scn::Spectrum>& pool,
                                                       std::uint32_t u, std::uint32_t sp) noexcept {
  return LightPredecessor<Scn>::direction_pdf(scene, pool.segments[u].x, -pool.last_direction[sp], pool.first_direction[u]);
}
/// Solid angle at the technique point to the segment's measure: area at y (plain segments);
/// chains are measured in solid angle at x already.
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar camera_measure(const Pool<typename Scn::Scalar, typename Scn::Spectrum>& pool, std::size_t s) noexcept {
  using T = typename Scn::Scalar;
  return (pool.flags[s] & chain_segment) ? T(1) : CameraSuccessor<Scn>::area_jacobian(pool.segments[s]);
}
/// Area x solid angle at y (light techniques) to the segment's measure: area at x for a plain
/// segment; for a chain, area x solid angle at x, by the conservation of etendue, n_y^2 cos_y
/// dA_y dw_y = n_x^2 cos_x dA_x dw_x, without the (n_x / n_y)^2 that a light-born chain's
/// importance throughput leaves out too (trace_light_path): cos_x / cos_y. (With Fresnel-selected delta
/// reflections both sides pick the same lobe with the same probability, so the selection
/// factors, left out of every density of a chain, agree.)
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar light_measure(const Pool<typename Scn::Scalar, typename Scn::Spectrum>& pool, std::size_t s) noexcept {
  using T = typename Scn::Scalar;
  if (!(pool.flags[s] & chain_segment)) return LightPredecessor<Scn>::area_jacobian(pool.segments[s]);
  const T cos_y = endpoint_cosine(pool.segments[s].y, pool.last_direction[s]);
  return cos_y > T(0) ? endpoint_cosine(pool.segments[s].x, pool.first_direction[s]) / cos_y : T(0);
}

/// N_L p_L(s) (N30) of any segment whose light end could be emitted: plain segments, and
/// light-born chains, which leave area lights only (trace_light_path); 0 otherwise. For a
/// distant light end pdf_emission reads a point on the ray (concepts/emitter.hpp).
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar light_start_density(const Scn& scene, const Pool<typename Scn::Scalar, typename Scn::Spectrum>& pool,
                                                    std::size_t i, std::uint64_t light_paths) {
  using T = typename Scn::Scalar;
  const auto f = pool.flags[i];
  if (kept_chain(pool, i)) return pool.density[i];  // kept from the draw (pool.hpp)
  const Segment<T>& s = pool.segments[i];
  const bool light_chain = (f & chain_segment) && s.y.kind == PointKind::surface && light_reachable(pool, i);
  if (light_paths == 0 || s.x.kind != PointKind::surface || ((f & chain_segment) && !light_chain)) return T(0);
  const Vec3<T> leaving = s.y.kind == PointKind::direction ? s.x.position : -pool.last_direction[i];
  const T p_light = LightStartSampler<Scn>::emission_pdf(scene, s.y, leaving);
  if (!(p_light > T(0))) return T(0);
  return T(light_paths) * p_light *
         ((f & chain_segment) ? light_measure<Scn>(pool, i) : LightStartSampler<Scn>::area_jacobian(s, pool.last_direction[i]));
}

/// n_p p_W(s) (N29) of a sensor segment: the sensor-start technique, one draw per pixel.
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar sensor_density(const Scn& scene, const Pool<typename Scn::Scalar, typename Scn::Spectrum>& pool,
                                                  std::size_t i) {
  using T = typename Scn::Scalar;
  const Segment<T>& s = pool.segments[i];
  return SensorStartSampler<Scn>::ray_pdf(scene, s.x, pool.first_direction[i]) *
         ((pool.flags[i] & chain_segment) ? T(1) : SensorStartSampler<Scn>::area_jacobian(s));
}

/// p_L(y | x) of a next-event segment from x (N34, the light-end bridge), in y's measure (a
/// Dirac's coefficient); 0 for a segment no next-event draw gives (a chain, x off the surfaces).
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar next_event_density(const Scn& scene, const Pool<typename Scn::Scalar, typename Scn::Spectrum>& pool,
                                                      std::size_t i) {
  using T = typename Scn::Scalar;
  const Segment<T>& s = pool.segments[i];
  if (s.x.kind != PointKind::surface || (pool.flags[i] & chain_segment)) return T(0);
  return scene.emitter().pdf_towards(EmitterPdfTowardsQuery<T>{s.x, s.y});
}

}  // namespace segpath::filtering
