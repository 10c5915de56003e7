// The uniform segment sampler (N26): both endpoints uniform by area on M, independently,
// p(s) = 1/|M|^2; the segment carries G(s) with visibility evaluated.
#pragma once

#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/in_place_optional.hpp"

#include <cmath>
#include <optional>

namespace segpath {

template <Scene Scn>
class UniformSegmentSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// Unconditional: no technique parameter.
  struct Technique {};
  static constexpr bool is_dirac = false;

  /// Draws x and y by Manifold::sample_area, pdf = p_A(x) p_A(y) = 1/|M|^2, factor G(s) with
  /// V(x, y) evaluated (an occluded segment is returned with factor 0: it was drawn, it just
  /// carries nothing). Zero-length segments (x == y, a set of measure zero) are rejected.
  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique&,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    const auto x = scene.sample_area(AreaSampleQuery<T>{Vec2<T>(u0, u1)});
    if (!x) return std::nullopt;
    const auto y = scene.sample_area(AreaSampleQuery<T>{Vec2<T>(u2, u3)});
    if (!y) return std::nullopt;
    const T pdf = x->pdf * y->pdf;
    const Vec3<T> delta = y->point.position - x->point.position;
    const T d2 = glm::dot(delta, delta);
    if (!(pdf > T(0)) || !(d2 > T(0)) || !std::isfinite(d2)) return std::nullopt;
    const T distance = std::sqrt(d2);
    const Vec3<T> direction = delta / distance;
    const Segment<T> s{x->point, y->point};
    const T g = scene.visible(VisibilityQuery<T>{s.x, s.y}) ? geometry_term(s, direction, distance) : T(0);
    return in_place_optional<SegmentSample<S>>(s, direction, S(g), pdf, S(g / pdf), false);
  }

  /// 1/|M|^2 for any segment between two surface points, 0 for point and direction
  /// endpoints. V does not enter (occluded segments are drawn too): the same as pdf.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique&, const Segment<T>& s) const noexcept {
    if (s.x.kind != PointKind::surface || s.y.kind != PointKind::surface) return T(0);
    const T inv_area = T(1) / scene.area();
    return inv_area * inv_area;
  }

  /// unoccluded_pdf: the uniform sampler's density has no visibility factor.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return unoccluded_pdf(scene, t, s);
  }
};

}  // namespace segpath
