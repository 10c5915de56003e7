// Approximate sequential samplers (N33), the UPS "virtual perturbation": the junction is an
// exact copy of the previous end (x_{i+1} = y_i on the sensor side, y_i = x_{i+1} on the light
// side), no kernel draw, but the reported density still carries the kernel's density there.
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/samplers/light_next.hpp"
#include "segpath/samplers/next_segment.hpp"

#include <optional>

namespace segpath {

/// Sensor-side approximate successor (N33). sample() continues from x_{i+1} = y_i itself and
/// reports
///   pdf    = p_K(y_i | s_i) p_w(s^_{i+1} | y_i, s_i) |n_y . s^| / d^2,
///   factor = K(s_i, s_{i+1}) f_r G(s_{i+1}),
/// both kernels at zero distance (the disk kernel's 1/(pi r^2) at its centre), so weight =
/// f_r |n_x . s^| / p_w equals the Dirac-kernel weight: the sample is a Dirac draw weighted
/// as if it had been a kernel draw. The reported density is not the density sample() draws
/// with (that one is a delta in x_{i+1}): estimators that divide by it, or by MMIS sums of
/// pdf() over techniques (N39-N42), are biased for a fixed kernel; the bias vanishes as the
/// kernel shrinks (PPM-style radius schedule), so they are consistent (N33).
/// pdf(scene, t, s) is (N31) with the kernel's density for ANY segment s, exactly as
/// NextSegmentSampler's: MMIS evaluates it for segments that start anywhere in the support.
/// is_dirac follows the kernel: pdf() is a proper density whenever the kernel's is.
template <Scene Scn, KernelOf<typename Scn::Scalar> K>
  requires std::same_as<typename K::Scalar, typename Scn::Scalar>
class ApproximateNextSegmentSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The segment s_i being continued, with its unit direction (NextSegmentSampler's).
  using Technique = typename NextSegmentSampler<Scn, K>::Technique;
  static constexpr bool is_dirac = K::is_dirac;

  explicit ApproximateNextSegmentSampler(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>)
      : exact_(std::move(kernel)) {}
  [[nodiscard]] const K& kernel() const noexcept { return exact_.kernel(); }

  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u_lobe = rng.template uniform<T>();
    const Segment<T>& prev = t.previous;
    const auto bsdf = scene.bsdf().sample(
        BsdfSampleQuery<T>{prev.y, -t.direction, Vec2<T>(u0, u1), u_lobe, Transport::radiance});
    if (!bsdf || !(bsdf->pdf > T(0))) return std::nullopt;
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{prev.y.position, bsdf->direction}});
    if (!hit) return std::nullopt;
    // A grazing ray whose hit rounds to the other side of y_i's tangent plane: outside pdf()'s support.
    if (prev.y.kind == PointKind::surface &&
        !(glm::dot(hit->point.position - prev.y.position, prev.y.normal) * glm::dot(bsdf->direction, prev.y.normal) >
          T(0)))
      return std::nullopt;
    const Segment<T> s{prev.y, hit->point};
    const T p_kernel = kernel().pdf(KernelQuery<T>{prev, s});
    if (!(p_kernel > T(0))) return std::nullopt;
    const T k = kernel().eval(KernelQuery<T>{prev, s});
    const T cos_x = endpoint_cosine(s.x, bsdf->direction);
    const T area_factor = solid_angle_to_area(T(1), s.x, s.y, bsdf->direction, hit->distance);
    return in_place_optional<SegmentSample<S>>(s, bsdf->direction, link_factor(k, bsdf->value, cos_x * area_factor),
                                               p_kernel * bsdf->pdf * area_factor, bsdf->value * ((k / p_kernel) * cos_x / bsdf->pdf), bsdf->delta);
  }

  /// p_K(s.x | s_i) p_w(s^ | y_i, s_i) |n_y . s^| / d^2 as if y were the first hit from x, for
  /// any segment s: NextSegmentSampler's unoccluded (N31).
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    if (s.y.kind != PointKind::direction && !(s.length_squared() > T(0))) return T(0);
    return exact_.unoccluded_pdf(scene, t, s);
  }

  /// unoccluded_pdf with V(x, y): NextSegmentSampler's (N31).
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

  /// The (N31) factors without the kernel's: NextSegmentSampler's direction_pdf (solid angle
  /// at y_i) and area_jacobian. With the junction copied (x = y_i), a caller that knows the
  /// kernel's density K at zero distance has unoccluded_pdf = K direction_pdf area_jacobian
  /// up to rounding.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T direction_pdf(const Scn& scene, const SurfacePoint<T>& y,
                                                            const Vec3<T>& to_sensor,
                                                            const Vec3<T>& direction) noexcept {
    return NextSegmentSampler<Scn, K>::direction_pdf(scene, y, to_sensor, direction);
  }
  [[nodiscard]] static SEGPATH_FORCE_INLINE T area_jacobian(const Segment<T>& s) noexcept {
    return NextSegmentSampler<Scn, K>::area_jacobian(s);
  }

 private:
  NextSegmentSampler<Scn, K> exact_;  ///< its kernel and density
};

/// Light-side approximate successor (N33), the mirror image: y_i = x_{i+1} itself, the
/// adjoint BSDF there samples -s^_i, x_i is the first hit, and
///   pdf    = p_K(x_{i+1} | s_{i+1}) p_w(-s^_i | x_{i+1}, s^_{i+1}) |n_x . s^_i| / d^2,
///   factor = K(s_i, s_{i+1}) f_r G(s_i),
/// kernels at zero distance, so the weight equals the Dirac-kernel weight; biased but
/// consistent exactly as ApproximateNextSegmentSampler. pdf(scene, t, s) is
/// LightNextSegmentSampler's for any segment s.
template <Scene Scn, KernelOf<typename Scn::Scalar> K>
  requires std::same_as<typename K::Scalar, typename Scn::Scalar>
class ApproximateLightNextSegmentSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The segment s_{i+1} being continued towards the sensor, with its unit direction
  /// (LightNextSegmentSampler's).
  using Technique = typename LightNextSegmentSampler<Scn, K>::Technique;
  static constexpr bool is_dirac = K::is_dirac;

  explicit ApproximateLightNextSegmentSampler(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>)
      : exact_(std::move(kernel)) {}
  [[nodiscard]] const K& kernel() const noexcept { return exact_.kernel(); }

  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u_lobe = rng.template uniform<T>();
    // Junction density 1 first; the kernel's density at its centre needs the finished s_i.
    auto out = detail::light_continue_from(scene, kernel(), t.next, t.direction, t.next.x, T(1), Vec2<T>(u0, u1),
                                           u_lobe);
    if (!out) return out;
    const T p_kernel = kernel().pdf(KernelQuery<T>{detail::reversed(t.next), detail::reversed(out->segment)});
    if (!(p_kernel > T(0))) {
      out.reset();
      return out;
    }
    out->pdf *= p_kernel;
    out->weight = out->weight / p_kernel;
    return out;
  }

  /// p_K(s.y | s_{i+1}) p_w(-s^ | y, s^_{i+1}) |n_x . s^| / d^2 as if x were the first hit
  /// from y, for any segment s: LightNextSegmentSampler's.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return exact_.unoccluded_pdf(scene, t, s);
  }

  /// unoccluded_pdf with V(x, y): LightNextSegmentSampler's.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return exact_.pdf(scene, t, s);
  }

  /// LightNextSegmentSampler's direction_pdf (adjoint BSDF, solid angle at y) and
  /// area_jacobian: the density without the kernel's factor.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T direction_pdf(const Scn& scene, const SurfacePoint<T>& y,
                                                            const Vec3<T>& to_sensor,
                                                            const Vec3<T>& to_light) noexcept {
    return LightNextSegmentSampler<Scn, K>::direction_pdf(scene, y, to_sensor, to_light);
  }
  [[nodiscard]] static SEGPATH_FORCE_INLINE T area_jacobian(const Segment<T>& s) noexcept {
    return LightNextSegmentSampler<Scn, K>::area_jacobian(s);
  }

 private:
  LightNextSegmentSampler<Scn, K> exact_;  ///< its kernel and density
};

}  // namespace segpath
