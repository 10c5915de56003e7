// The ray-traced segment sampler (N27): x uniform by area on M, a cosine-weighted direction
// about n_x, y the first hit: p(s) = G(s) / (pi |M|).
#pragma once

#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"

#include <optional>

namespace segpath {

template <Scene Scn>
class RaytracedSegmentSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// Unconditional: no technique parameter.
  struct Technique {};
  static constexpr bool is_dirac = false;

  /// Draws s with p = p_A(x) (cos_x / pi) |n_y . s^| / d^2 = G(s) / (pi |M|) and factor G(s)
  /// (visibility holds: y is the first hit). The cosine is about the geometric normal, on
  /// its front side; rays that escape the scene are rejected, so p integrates to the
  /// probability of a hit. weight = G / p = pi / p_A(x) = pi |M|.
  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique&,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    const auto x = scene.sample_area(AreaSampleQuery<T>{Vec2<T>(u0, u1)});
    if (!x || !(x->pdf > T(0))) return std::nullopt;
    const Vec3<T> local = square_to_cosine_hemisphere(Vec2<T>(u2, u3));
    const T pdf_direction = square_to_cosine_hemisphere_pdf(local);
    if (!(pdf_direction > T(0))) return std::nullopt;
    const Vec3<T> direction = Frame<T>::from_normal(x->point.normal).to_world(local);
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{x->point.position, direction}});
    if (!hit) return std::nullopt;
    // A grazing ray whose hit rounds to behind x's tangent plane is outside pdf()'s support.
    if (!(glm::dot(hit->point.position - x->point.position, x->point.normal) > T(0))) return std::nullopt;
    const Segment<T> s{x->point, hit->point};
    const T area_factor = solid_angle_to_area(T(1), s.x, s.y, direction, hit->distance);
    const T pdf = x->pdf * pdf_direction * area_factor;
    if (!(pdf > T(0))) return std::nullopt;
    // G = cos_x |n_y . s^| / d^2 and p share |n_y . s^| / d^2; cos_x / (cos_x / pi) = pi.
    return in_place_optional<SegmentSample<S>>(s, direction, S(local.z * area_factor), pdf, S(pi<T> / x->pdf), false);
  }

  /// (1/|M|) (cos_x / pi) |n_y . s^| / d^2 for any segment between surface points whose
  /// direction leaves the front of x, as if y were the first hit from x; else 0.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique&, const Segment<T>& s) const noexcept {
    if (s.x.kind != PointKind::surface || s.y.kind != PointKind::surface) return T(0);
    const Vec3<T> delta = s.y.position - s.x.position;
    const T d2 = glm::dot(delta, delta);
    if (!(d2 > T(0)) || !std::isfinite(d2)) return T(0);
    const Vec3<T> direction = delta / std::sqrt(d2);
    const T cos_x = glm::dot(s.x.normal, direction);
    if (!(cos_x > T(0))) return T(0);
    return cos_x * inv_pi<T> * endpoint_cosine(s.y, direction) / (d2 * scene.area());
  }

  /// unoccluded_pdf where y is visible from x (the first hit), 0 otherwise (N27).
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }
};

}  // namespace segpath
