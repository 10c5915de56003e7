// The sequential next-segment sampler on the sensor side (N31, N32): x_{i+1} from the
// kernel around y_i, the direction from the (translated, N20) BSDF at y_i, y_{i+1} the first
// hit from x_{i+1}:
//   p(s_{i+1} | s_i) = p_K(x_{i+1} | s_i) p_w(s^_{i+1} | y_i, s_i) |n_y . s^| / |x - y|^2.
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/core/geometry.hpp"

#include <optional>

namespace segpath {

template <Scene Scn, KernelOf<typename Scn::Scalar> K>
  requires std::same_as<typename K::Scalar, typename Scn::Scalar>
class NextSegmentSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The technique parameter: the segment s_i being continued, with its unit direction
  /// (pass it when known, e.g. from the SegmentSample, to save a normalisation).
  struct Technique {
    const Segment<T>& previous;
    Vec3<T> direction;
    Technique(const Segment<T>& s) noexcept : previous(s), direction(s.direction()) {}  // NOLINT: implicit by design
    Technique(const Segment<T>& s, const Vec3<T>& d) noexcept : previous(s), direction(d) {}
  };
  static constexpr bool is_dirac = K::is_dirac;

  explicit NextSegmentSampler(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>) : kernel_(std::move(kernel)) {}
  [[nodiscard]] const K& kernel() const noexcept { return kernel_; }

  /// Draws s_{i+1} with factor K f_r G(s_{i+1}) (N17) and its density (N31).
  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                     R& rng) const noexcept {
    const Vec2<T> u_kernel = uniform2<T>(rng);
    const Vec2<T> u_bsdf = uniform2<T>(rng);
    const T u_lobe = rng.template uniform<T>();
    // Paths do not continue from a light end that is not on a surface (infinity, a point).
    if (t.previous.y.kind != PointKind::surface) return std::nullopt;
    if constexpr (K::is_dirac) {
      // The junction is y_i itself and K / p_K = 1: no kernel work at all.
      (void)u_kernel;
      return continue_from(scene, t, t.previous.y, T(1), u_bsdf, u_lobe);
    } else {
      const auto junction = kernel_.sample(KernelSampleQuery<T>{t.previous, u_kernel});
      if (!junction || !(junction->pdf > T(0))) return std::nullopt;
      return continue_from(scene, t, junction->point, junction->pdf, u_bsdf, u_lobe);
    }
  }

  /// sample() in place, for sequential estimators: `s`, the sample being continued, becomes
  /// its successor, drawn from the same uniforms by the same expressions, without a second
  /// sample object; false (and `s` unchanged) where sample() returns nullopt. The numbers are
  /// sample()'s bit for bit unless the compiler contracts multiply-adds (-ffp-contract=fast with
  /// FMA, e.g. -march=native), which it may do differently in the two.
  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE bool advance(const Scn& scene, SegmentSample<S>& s, R& rng) const noexcept {
    const Vec2<T> u_kernel = uniform2<T>(rng);
    const Vec2<T> u_bsdf = uniform2<T>(rng);
    const T u_lobe = rng.template uniform<T>();
    if (s.segment.y.kind != PointKind::surface) return false;
    if constexpr (K::is_dirac) {
      (void)u_kernel;
      return advance_from(scene, s, s.segment.y, T(1), u_bsdf, u_lobe);
    } else {
      const auto junction = kernel_.sample(KernelSampleQuery<T>{s.segment, u_kernel});
      if (!junction || !(junction->pdf > T(0))) return false;
      return advance_from(scene, s, junction->point, junction->pdf, u_bsdf, u_lobe);
    }
  }

  /// p(s | s_i) of (N31) for any segment s as if y were the first hit from x:
  /// p_K(x | s_i) direction_pdf(y_i, -s^_i, s^) area_jacobian(s) (the last two grouped as
  /// solid_angle_to_area, so rounding differs from that product).
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    const Segment<T>& prev = t.previous;
    const T p_kernel = kernel_.pdf(KernelQuery<T>{prev, s});
    if (!(p_kernel > T(0))) return T(0);
    const T p_direction = direction_pdf(scene, prev.y, -t.direction, s.direction());
    if (!(p_direction > T(0))) return T(0);
    return p_kernel * solid_angle_to_area(p_direction, s.x, s.y);
  }

  /// p(s | s_i) of (N31): unoccluded_pdf where y is the first hit from x, 0 otherwise.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

  /// p_w(direction | y_i, s_i) of (N31), in solid angle: the BSDF at the previous end y_i
  /// (translated, N20) samples `direction` given `to_sensor` = -s^_i (radiance transport).
  /// Needs no sampler object and no Technique: for loops over (segment, technique) pairs.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T direction_pdf(const Scn& scene, const SurfacePoint<T>& y,
                                                            const Vec3<T>& to_sensor,
                                                            const Vec3<T>& direction) noexcept {
    return scene.bsdf().pdf(BsdfQuery<T>{y, to_sensor, direction, Transport::radiance});
  }

  /// |n_y . s^| / |x - y|^2 (1 for a `direction` end y): direction_pdf's solid angle at x to
  /// y's area measure.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T area_jacobian(const Segment<T>& s) noexcept {
    return solid_angle_to_area(T(1), s.x, s.y);
  }

 private:
  /// The rest of (N31) from the junction x_{i+1}: BSDF direction at y_i and first hit.
  SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> continue_from(const Scn& scene, const Technique& t,
                                                                     const SurfacePoint<T>& junction, T junction_pdf,
                                                                     const Vec2<T>& u_bsdf, T u_lobe) const noexcept {
    const Segment<T>& prev = t.previous;
    const auto bsdf = scene.bsdf().sample(BsdfSampleQuery<T>{prev.y, -t.direction, u_bsdf, u_lobe, Transport::radiance});
    if (!bsdf || !(bsdf->pdf > T(0))) return std::nullopt;
    const auto found = scene.intersect(IntersectQuery<T>{Ray<T>{junction.position, bsdf->direction}});
    if (found) return segment_to(prev, junction, junction_pdf, *bsdf, found->point, found->distance);
    // A ray that leaves the scene ends at infinity (a `direction` endpoint).
    return segment_to(prev, junction, junction_pdf, *bsdf, SurfacePoint<T>::at_infinity(bsdf->direction), T(1));
  }

  /// advance()'s continue_from: the same numbers, written over `s` once everything of the
  /// previous segment has been read.
  SEGPATH_FORCE_INLINE bool advance_from(const Scn& scene, SegmentSample<S>& s, const SurfacePoint<T>& junction,
                                         T junction_pdf, const Vec2<T>& u_bsdf, T u_lobe) const noexcept {
    const auto bsdf = scene.bsdf().sample(BsdfSampleQuery<T>{s.segment.y, -s.direction, u_bsdf, u_lobe, Transport::radiance});
    if (!bsdf || !(bsdf->pdf > T(0))) return false;
    const auto found = scene.intersect(IntersectQuery<T>{Ray<T>{junction.position, bsdf->direction}});
    if (found) advance_to(s, junction, junction_pdf, *bsdf, found->point, found->distance);
    else advance_to(s, junction, junction_pdf, *bsdf, SurfacePoint<T>::at_infinity(bsdf->direction), T(1));
    return true;
  }

  SEGPATH_FORCE_INLINE void advance_to(SegmentSample<S>& s, const SurfacePoint<T>& junction, T junction_pdf,
                                       const BsdfSample<S>& bsdf, const SurfacePoint<T>& y, T distance) const noexcept {
    const Terms terms = terms_of(s.segment, junction, junction_pdf, bsdf, y, distance);
    s.segment.x = junction;  // may be s.segment.y itself (Dirac kernel): copied before y changes
    s.segment.y = y;
    s.direction = bsdf.direction;
    s.factor = terms.factor;
    s.pdf = terms.pdf;
    s.weight = terms.weight;
    s.delta = bsdf.delta;
  }

  /// The sample for the segment junction -> y (returned whole, as SegmentSample says).
  SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> segment_to(const Segment<T>& prev,
                                                                  const SurfacePoint<T>& junction, T junction_pdf,
                                                                  const BsdfSample<S>& bsdf, const SurfacePoint<T>& y,
                                                                  T distance) const noexcept {
    const Terms terms = terms_of(prev, junction, junction_pdf, bsdf, y, distance);
    return in_place_optional<SegmentSample<S>>(Segment<T>{junction, y}, bsdf.direction, terms.factor, terms.pdf, terms.weight, bsdf.delta);
  }

  /// Factor, density and weight of the segment junction -> y drawn from `prev`.
  struct Terms {
    S factor;
    T pdf;
    S weight;
  };
  SEGPATH_FORCE_INLINE Terms terms_of(const Segment<T>& prev, const SurfacePoint<T>& junction, T junction_pdf,
                                      const BsdfSample<S>& bsdf, const SurfacePoint<T>& y, T distance) const noexcept {
    // (N17) factor K f_r G(s') and (N31) density p_K p_w |n_y . s^| / d^2 share |n_y . s^| / d^2.
    const T cos_x = endpoint_cosine(junction, bsdf.direction);
    const T area_factor = solid_angle_to_area(T(1), junction, y, bsdf.direction, distance);
    T k = T(1);
    if constexpr (!K::is_dirac) k = kernel_.eval(KernelQuery<T>{prev, Segment<T>{junction, y}});
    return Terms{link_factor(k, bsdf.value, cos_x * area_factor), junction_pdf * bsdf.pdf * area_factor,
                 bsdf.value * ((k / junction_pdf) * cos_x / bsdf.pdf)};
  }

  K kernel_;
};

}  // namespace segpath
