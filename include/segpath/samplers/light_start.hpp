// The sequential light-start sampler (N30): p_L(s_k) proportional to L_e(s_k) G(s_k). The light
// end y comes from the emitter's sample_emission, x is the first hit along the emitted ray.
#pragma once

#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/in_place_optional.hpp"

#include <cmath>
#include <optional>

namespace segpath {

template <LightSampledScene Scn>
class LightStartSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// Unconditional: the emitter itself selects a light (EmissionSampleQuery::u_select).
  struct Technique {};
  /// Point lights are deltas in position, distant lights in direction.
  static constexpr bool is_dirac = true;

  /// Draws the last segment s = (x, y) of a light subpath with
  ///   p = pdf_position(y) pdf_direction(-s^) |n_x . s^| / d^2   (N30)
  /// and factor L_e G(s) (visibility holds: x is the first hit). Endpoint kinds of y:
  ///  - surface: area density, cosine |n_y . s^| in G;
  ///  - point (point lights): discrete position probability, no cosine at y;
  ///  - direction (distant lights): y.position is the reversed travel direction (= s^);
  ///    following concepts/emitter.hpp the densities swap roles, and `direction` then holds
  ///    the sampled point on the plane perpendicular to the travel direction that the ray
  ///    starts from (outside the scene); p = pdf_position (solid angle) * pdf_direction (area
  ///    on that plane) * |n_x . s^|, G = |n_x . s^| (no 1/d^2).
  /// weight = L_e |n_y . s^| / (pdf_position pdf_direction) (the |n_x . s^| / d^2 cancels).
  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique&,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    const T u_select = rng.template uniform<T>();
    const auto e =
        scene.emitter().sample_emission(EmissionSampleQuery<T>{Vec2<T>(u0, u1), Vec2<T>(u2, u3), u_select});
    if (!e) return std::nullopt;
    const T pdf_emission = e->pdf_position * e->pdf_direction;
    if (!(pdf_emission > T(0)) || !std::isfinite(pdf_emission)) return std::nullopt;
    const bool distant = e->point.kind == PointKind::direction;
    const Ray<T> ray = distant ? Ray<T>{e->direction, -e->point.position} : Ray<T>{e->point.position, e->direction};
    const auto hit = scene.intersect(IntersectQuery<T>{ray});
    if (!hit) return std::nullopt;
    // A grazing ray whose hit rounds to the other side of y's tangent plane than the emitted
    // direction is outside pdf_emission's support (one-sided emitters): reject it.
    if (e->point.kind == PointKind::surface &&
        !(glm::dot(hit->point.position - e->point.position, e->point.normal) * glm::dot(e->direction, e->point.normal) >
          T(0)))
      return std::nullopt;
    const Vec3<T> direction = -ray.direction;  // s^: from x towards y
    const Segment<T> s{hit->point, e->point};
    // |n_x . s^| / d^2 (|n_x . s^| at a distant light's end): shared by G and p.
    const T area_factor = distant ? endpoint_cosine(s.x, direction)
                                  : solid_angle_to_area(T(1), s.y, s.x, ray.direction, hit->distance);
    const T pdf = pdf_emission * area_factor;
    if (!(pdf > T(0))) return std::nullopt;
    const T cos_y = endpoint_cosine(s.y, direction);
    return in_place_optional<SegmentSample<S>>(s, direction, e->radiance * (cos_y * area_factor), pdf, e->radiance * (cos_y / pdf_emission), e->delta);
  }

  /// p(s) of (N30) for any segment as if x were the first hit from y: the emitter's
  /// densities for the end y and the direction -s^ it leaves in, times |n_x . s^| / d^2
  /// (|n_x . s^| for a distant y); 0 unless x is a surface point.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique&, const Segment<T>& s) const noexcept {
    if (s.x.kind != PointKind::surface) return T(0);
    const bool distant = s.y.kind == PointKind::direction;
    if (!distant && !(s.length_squared() > T(0))) return T(0);
    const Vec3<T> direction = s.direction();
    // A distant end's emitter reads a point of the ray (concepts/emitter.hpp): x.
    const T pdf_emission = emission_pdf(scene, s.y, distant ? s.x.position : -direction);
    if (!(pdf_emission > T(0))) return T(0);
    return distant ? pdf_emission * endpoint_cosine(s.x, direction) : solid_angle_to_area(pdf_emission, s.y, s.x);
  }

  /// p(s) of (N30): unoccluded_pdf where x is the first hit from y, 0 otherwise.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

  /// The emitter's pdf_position(y) pdf_direction(leaving | y) (N30) in the product of y's
  /// measure and solid angle at y; for a distant y `leaving` is read as the emitter concept
  /// says (concepts/emitter.hpp: a point of the emitted ray) and the product is solid angle
  /// times area on the plane across the ray.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T emission_pdf(const Scn& scene, const SurfacePoint<T>& y,
                                                           const Vec3<T>& leaving) noexcept {
    const EmissionPdf<T> e = scene.emitter().pdf_emission(EmissionPdfQuery<T>{y, leaving});
    return e.position * e.direction;
  }

  /// What turns emission_pdf into x's area measure: |n_x . s^| / |x - y|^2, or |n_x . s^| for
  /// a distant y (`direction` = s^, the segment's unit direction as the caller has it).
  /// emission_pdf * area_jacobian is unoccluded_pdf up to rounding (grouped differently).
  [[nodiscard]] static SEGPATH_FORCE_INLINE T area_jacobian(const Segment<T>& s, const Vec3<T>& direction) noexcept {
    return s.y.kind == PointKind::direction ? endpoint_cosine(s.x, direction) : solid_angle_to_area(T(1), s.y, s.x);
  }
};

}  // namespace segpath
