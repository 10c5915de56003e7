// The geometry term G(s) of (N17) and conversions between solid-angle and area densities.
#pragma once

#include "segpath/core/segment.hpp"

#include <cmath>

namespace segpath {

/// |n . d| at an endpoint, or 1 where the endpoint has no surface (PointKind::point and
/// ::direction: the sensor or emitter carries that factor).
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T endpoint_cosine(const SurfacePoint<T>& p,
                                                     const Vec3<T>& d) noexcept {
  return p.kind == PointKind::surface ? std::abs(glm::dot(p.normal, d)) : T(1);
}

/// G(s) = |n_x . s^| |n_y . s^| / |x - y|^2 without visibility (N17). Endpoint kinds other
/// than `surface` drop their cosine; a `direction` endpoint drops 1/d^2. Zero-length
/// segments between surface points have no finite G and return 0 (a dropped sample).
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T geometry_term(const Segment<T>& s) noexcept {
  const bool at_infinity = s.x.kind == PointKind::direction || s.y.kind == PointKind::direction;
  if (at_infinity) {
    const Vec3<T> d = s.direction();
    return endpoint_cosine(s.x, d) * endpoint_cosine(s.y, d);
  }
  const Vec3<T> delta = s.y.position - s.x.position;
  const T d2 = glm::dot(delta, delta);
  if (!(d2 > T(0)) || !std::isfinite(d2)) return T(0);
  const Vec3<T> d = delta / std::sqrt(d2);
  return endpoint_cosine(s.x, d) * endpoint_cosine(s.y, d) / d2;
}

/// G(s) for a segment whose unit direction and length are already known (a ray-traced
/// segment: the ray direction and hit distance), saving the normalisation.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T geometry_term(const Segment<T>& s, const Vec3<T>& direction,
                                                   T distance) noexcept {
  const T cosines = endpoint_cosine(s.x, direction) * endpoint_cosine(s.y, direction);
  if (s.x.kind == PointKind::direction || s.y.kind == PointKind::direction) return cosines;
  return distance > T(0) ? cosines / (distance * distance) : T(0);
}

/// Converts a solid-angle density at `from` towards `to` into an area density at `to`:
/// p_A(to) = p_w |n_to . w| / |from - to|^2 (the factor in (N27), (N28), (N31)).
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T solid_angle_to_area(T pdf_solid_angle, const SurfacePoint<T>& from,
                                                         const SurfacePoint<T>& to) noexcept {
  if (to.kind == PointKind::direction || from.kind == PointKind::direction) return pdf_solid_angle;
  const Vec3<T> delta = to.position - from.position;
  const T d2 = glm::dot(delta, delta);
  if (!(d2 > T(0))) return T(0);
  return pdf_solid_angle * endpoint_cosine(to, delta / std::sqrt(d2)) / d2;
}

/// solid_angle_to_area for a known unit direction from -> to and distance.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T solid_angle_to_area(T pdf_solid_angle, const SurfacePoint<T>& from,
                                                         const SurfacePoint<T>& to, const Vec3<T>& direction,
                                                         T distance) noexcept {
  if (to.kind == PointKind::direction || from.kind == PointKind::direction) return pdf_solid_angle;
  return distance > T(0) ? pdf_solid_angle * endpoint_cosine(to, direction) / (distance * distance) : T(0);
}

/// The inverse of solid_angle_to_area; returns 0 where the conversion is singular.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T area_to_solid_angle(T pdf_area, const SurfacePoint<T>& from,
                                                         const SurfacePoint<T>& to) noexcept {
  if (to.kind == PointKind::direction || from.kind == PointKind::direction) return pdf_area;
  const Vec3<T> delta = to.position - from.position;
  const T d2 = glm::dot(delta, delta);
  const T cosine = d2 > T(0) ? endpoint_cosine(to, delta / std::sqrt(d2)) : T(0);
  if (!(cosine > T(0))) return T(0);
  return pdf_area * d2 / cosine;
}

}  // namespace segpath
