// The BSDF importance segment sampler (N28): x uniform by area on M, the direction from the
// scene's BSDF at x given an auxiliary incoming direction s^', y the first hit:
//   p(s | s^') = (1/|M|) p_w(s^ | x, s^') |n_y . s^| / |x - y|^2.
#pragma once

#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/in_place_optional.hpp"

#include <cmath>
#include <optional>

namespace segpath {

template <Scene Scn>
class BsdfDirectedSegmentSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The technique parameter: the auxiliary direction s^' (unit, world space, pointing away
  /// from x towards where the sensor would be). It is the BSDF's fixed direction under
  /// Transport::radiance, so the sampled s^ plays the incoming-light direction.
  struct Technique {
    Vec3<T> to_sensor{0, 0, 1};
  };
  static constexpr bool is_dirac = false;

  /// Draws s with the (N28) density and factor G(s) (visibility holds: y is the first hit).
  /// weight = G / p = |n_x . s^| / (p_A(x) p_w). Points where the BSDF cannot be sampled for
  /// s^' (e.g. s^' behind a one-sided surface) reject the sample, so p integrates to the
  /// acceptance probability. A delta lobe sets `delta`; then factor and p are coefficients of
  /// the same delta in s^.
  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    const T u_lobe = rng.template uniform<T>();
    const auto x = scene.sample_area(AreaSampleQuery<T>{Vec2<T>(u0, u1)});
    if (!x || !(x->pdf > T(0))) return std::nullopt;
    const auto bsdf = scene.bsdf().sample(
        BsdfSampleQuery<T>{x->point, t.to_sensor, Vec2<T>(u2, u3), u_lobe, Transport::radiance});
    if (!bsdf || !(bsdf->pdf > T(0))) return std::nullopt;
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{x->point.position, bsdf->direction}});
    if (!hit) return std::nullopt;
    // A grazing ray whose hit rounds to the other side of x's tangent plane: outside pdf()'s support.
    if (!(glm::dot(hit->point.position - x->point.position, x->point.normal) *
              glm::dot(bsdf->direction, x->point.normal) > T(0)))
      return std::nullopt;
    const Segment<T> s{x->point, hit->point};
    const T area_factor = solid_angle_to_area(T(1), s.x, s.y, bsdf->direction, hit->distance);
    const T pdf = x->pdf * bsdf->pdf * area_factor;
    if (!(pdf > T(0))) return std::nullopt;
    const T cos_x = endpoint_cosine(s.x, bsdf->direction);
    return in_place_optional<SegmentSample<S>>(s, bsdf->direction, S(cos_x * area_factor), pdf, S(cos_x / (x->pdf * bsdf->pdf)), bsdf->delta);
  }

  /// (1/|M|) p_w(s^ | x, s^') |n_y . s^| / d^2 for any segment from a surface point x, as if
  /// y were the first hit from x; 0 otherwise (and for delta lobes, by the BSDF's pdf).
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    if (s.x.kind != PointKind::surface) return T(0);
    if (s.y.kind == PointKind::surface && !(s.length_squared() > T(0))) return T(0);
    const T p_direction =
        scene.bsdf().pdf(BsdfQuery<T>{s.x, t.to_sensor, s.direction(), Transport::radiance});
    if (!(p_direction > T(0))) return T(0);
    return solid_angle_to_area(p_direction, s.x, s.y) / scene.area();
  }

  /// unoccluded_pdf where y is visible from x (the first hit), 0 otherwise (N28).
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }
};

}  // namespace segpath
