// Geometry shared by the reference materials: the one-sided test, mirror reflection, Snell
// refraction and the exact unpolarised Fresnel reflectance of a smooth dielectric.
#pragma once

#include <algorithm>
#include <cmath>

#include "segpath/core/surface_point.hpp"

namespace segpath {

/// Below this cosine with the geometric normal a direction counts as behind a one-sided
/// surface (the Cornell-box convention, cornell-boxes.md; SmallVCM's EPS_COSINE).
template <Real T>
inline constexpr T one_sided_epsilon = T(1e-6);

/// Whether unit `d` leaves the front (normal) side of a one-sided surface at `p`.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE bool is_above(const SurfacePoint<T>& p,
                                                 const Vec3<T>& d) noexcept {
  return glm::dot(d, p.normal) > one_sided_epsilon<T>;
}

/// The mirror image of `d` about the unit normal `n` (both pointing away from the surface):
/// 2 (d . n) n - d.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE Vec3<T> reflect(const Vec3<T>& d, const Vec3<T>& n) noexcept {
  return (T(2) * glm::dot(d, n)) * n - d;
}

/// cos of the angle between reflect(a, n) and b, computed symmetrically in a and b
/// (2 (a.n)(b.n) - a.b), so that lobes built on it are reciprocal to the last bit.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T reflected_cosine(const Vec3<T>& a, const Vec3<T>& b,
                                                      const Vec3<T>& n) noexcept {
  return T(2) * (glm::dot(a, n) * glm::dot(b, n)) - glm::dot(a, b);
}

/// cos theta_t of the refracted direction for cos theta_i = `cos_i` >= 0 and the relative
/// index `eta_ratio` = eta_i / eta_t (Snell: sin_t = eta_ratio sin_i); a negative value
/// signals total internal reflection.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T refracted_cosine(T cos_i, T eta_ratio) noexcept {
  const T sin2_t = eta_ratio * eta_ratio * std::max(T(0), T(1) - cos_i * cos_i);
  return sin2_t < T(1) ? std::sqrt(T(1) - sin2_t) : T(-1);
}

/// The unpolarised Fresnel reflectance of a smooth interface (exact, not Schlick):
/// (r_par^2 + r_perp^2) / 2 with r_par = (cos_i - e cos_t) / (cos_i + e cos_t) and
/// r_perp = (e cos_i - cos_t) / (e cos_i + cos_t), e = eta_i / eta_t; 1 under total internal
/// reflection and at grazing incidence (cos_i <= 0). Symmetric: a refracted pair gives the
/// same value from either side.
template <Real T>
[[nodiscard]] inline T fresnel_dielectric(T cos_i, T eta_ratio) noexcept {
  if (!(cos_i > T(0))) return T(1);
  cos_i = std::min(cos_i, T(1));
  const T cos_t = refracted_cosine(cos_i, eta_ratio);
  if (cos_t < T(0)) return T(1);
  const T r_par = (cos_i - eta_ratio * cos_t) / (cos_i + eta_ratio * cos_t);
  const T r_perp = (eta_ratio * cos_i - cos_t) / (eta_ratio * cos_i + cos_t);
  return std::clamp(T(0.5) * (r_par * r_par + r_perp * r_perp), T(0), T(1));
}

/// The direction refracted from unit `d` (pointing away from the surface, on the side of the
/// unit normal `n`, cos_i = d . n >= 0) into the other side, for cos_t =
/// refracted_cosine(cos_i, eta_ratio) >= 0: -e d + (e cos_i - cos_t) n.
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE Vec3<T> refract(const Vec3<T>& d, const Vec3<T>& n, T cos_i,
                                                   T cos_t, T eta_ratio) noexcept {
  return -eta_ratio * d + (eta_ratio * cos_i - cos_t) * n;
}

}  // namespace segpath
