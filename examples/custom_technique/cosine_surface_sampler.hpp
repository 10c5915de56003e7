// A segment sampler written outside the library, as a researcher would add one: x uniform by
// area on the scene, a cosine-weighted direction about its normal, y the first hit. It models
// segpath::SegmentSampler with an empty technique parameter, so it joins segment filtering's
// technique set (segpath::FilteringTechnique) without any change to the library.
#pragma once

#include <segpath/concepts/sampler.hpp>
#include <segpath/concepts/scene.hpp>
#include <segpath/core/geometry.hpp>
#include <segpath/core/in_place_optional.hpp>
#include <segpath/core/warp.hpp>

#include <cmath>
#include <optional>

namespace example {

template <segpath::Scene Scn>
class CosineSurfaceSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  struct Technique {};  ///< unconditional
  static constexpr bool is_dirac = false;

  template <segpath::UniformSource<T> R>
  [[nodiscard]] std::optional<segpath::SegmentSample<S>> sample(const Scn& scene, const Technique& t, R& rng) const noexcept {
    const T u0 = rng.template uniform<T>(), u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>(), u3 = rng.template uniform<T>();
    const auto x = scene.sample_area(segpath::AreaSampleQuery<T>{segpath::Vec2<T>(u0, u1)});
    if (!x) return std::nullopt;
    const segpath::Vec3<T> direction =
        segpath::Frame<T>::from_normal(x->point.normal).to_world(segpath::square_to_cosine_hemisphere(segpath::Vec2<T>(u2, u3)));
    const auto hit = scene.intersect(segpath::IntersectQuery<T>{segpath::Ray<T>{x->point.position, direction}});
    if (!hit) return std::nullopt;
    const segpath::Segment<T> s{x->point, hit->point};
    const T p = unoccluded_pdf(scene, t, s);
    if (!(p > T(0))) return std::nullopt;
    const T g = segpath::geometry_term(s);
    return segpath::in_place_optional<segpath::SegmentSample<S>>(s, direction, S(g), p, S(g / p), false);
  }

  /// p(s) = p_A(x) cos_x / pi |cos_y| / d^2 in area x area, assuming y is the first hit from x.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique&, const segpath::Segment<T>& s) const noexcept {
    if (s.x.kind != segpath::PointKind::surface || s.y.kind != segpath::PointKind::surface) return T(0);
    const segpath::Vec3<T> d = s.y.position - s.x.position;
    const T d2 = glm::dot(d, d);
    if (!(d2 > T(0))) return T(0);
    const T inv_d = T(1) / std::sqrt(d2);
    const T cos_x = glm::dot(s.x.normal, d) * inv_d;
    if (!(cos_x > T(0))) return T(0);
    const T cos_y = std::abs(glm::dot(s.y.normal, d)) * inv_d;
    return cos_x * segpath::inv_pi<T> * cos_y / d2 / scene.area();
  }
  /// With the first-hit condition (V: y is what x sees towards y).
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const segpath::Segment<T>& s) const noexcept {
    const T p = unoccluded_pdf(scene, t, s);
    return p > T(0) && scene.visible(segpath::VisibilityQuery<T>{s.x, s.y}) ? p : T(0);
  }
};

}  // namespace example
