// Bridge segment samplers (N34): both ends of s_i drawn around the ends of a camera and a light
// subpath, then a visibility test; and the next-event (light end) and light-tracing (sensor
// end) variants. With Dirac kernels they are ordinary BDPT connections.
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/samplers/light_next.hpp"

#include <cmath>
#include <optional>

namespace segpath {

/// Kernel-kernel bridge (N34): given the camera subpath's last segment s_{i-1} and the light
/// subpath's first segment s_{i+1}, x_i is drawn from the kernel around y_{i-1} and y_i from
/// the kernel around x_{i+1} (light-side kernel queries use mirrored segments, see
/// detail::reversed), and the sample is rejected unless V(x_i, y_i):
///   p(s_i | s_{i-1}, s_{i+1}) = p_K(x_i | s_{i-1}) p_K(y_i | s_{i+1}).
/// The (N17) factors the bridge carries: K(s_{i-1}, s_i) G(s_i) K(s_i, s_{i+1}), visibility
/// included. The two BSDFs beside it, f_r(s_{i-1}, s_i) at y_{i-1} and f_r(s_i, s_{i+1}) at
/// y_i (with the disk kernel y_i carries x_{i+1}'s normal and material, N20), belong to the
/// estimator's connection term: each needs a direction of a subpath the bridge does not own.
/// weight = (K / p_K)(K / p_K) G. Dirac kernels: x_i = y_{i-1}, y_i = x_{i+1}, p = 1 (the
/// coefficient of both deltas), factor G(s_i): the BDPT connection edge.
template <Scene Scn, KernelOf<typename Scn::Scalar> K>
  requires std::same_as<typename K::Scalar, typename Scn::Scalar>
class KernelBridgeSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The camera subpath's last segment s_{i-1} and the light subpath's first segment s_{i+1}.
  struct Technique {
    const Segment<T>& camera;
    const Segment<T>& light;
  };
  static constexpr bool is_dirac = K::is_dirac;

  explicit KernelBridgeSampler(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>)
      : kernel_(std::move(kernel)) {}
  [[nodiscard]] const K& kernel() const noexcept { return kernel_; }

  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    Segment<T> s{t.camera.y, t.light.x};
    T p_x = T(1), p_y = T(1);
    if constexpr (!K::is_dirac) {
      const auto x = kernel_.sample(KernelSampleQuery<T>{t.camera, Vec2<T>(u0, u1)});
      if (!x || !(x->pdf > T(0))) return std::nullopt;
      const Segment<T> mirror = detail::reversed(t.light);
      const auto y = kernel_.sample(KernelSampleQuery<T>{mirror, Vec2<T>(u2, u3)});
      if (!y || !(y->pdf > T(0))) return std::nullopt;
      s = Segment<T>{x->point, y->point};
      p_x = x->pdf;
      p_y = y->pdf;
    } else {
      (void)u0, (void)u1, (void)u2, (void)u3;
    }
    const Vec3<T> delta = s.y.position - s.x.position;
    const T d2 = glm::dot(delta, delta);
    if (!(d2 > T(0)) || !std::isfinite(d2)) return std::nullopt;
    if (!scene.visible(VisibilityQuery<T>{s.x, s.y})) return std::nullopt;
    const T distance = std::sqrt(d2);
    const Vec3<T> direction = delta / distance;
    const T g = geometry_term(s, direction, distance);
    T k_x = T(1), k_y = T(1);
    if constexpr (!K::is_dirac) {
      k_x = kernel_.eval(KernelQuery<T>{t.camera, s});
      k_y = kernel_.eval(KernelQuery<T>{s, t.light});
    }
    return in_place_optional<SegmentSample<S>>(s, direction, S(k_x * g * k_y), p_x * p_y, S((k_x / p_x) * (k_y / p_y) * g), false);
  }

  /// p_K(s.x | s_{i-1}) p_K(s.y | s_{i+1}) for any segment s: the density of the two kernel
  /// draws, before the visibility test.
  [[nodiscard]] T unoccluded_pdf(const Scn&, const Technique& t, const Segment<T>& s) const noexcept {
    if (!(s.length_squared() > T(0))) return T(0);
    const T p_x = kernel_.pdf(KernelQuery<T>{t.camera, s});
    if (!(p_x > T(0))) return T(0);
    const T p_y = kernel_.pdf(KernelQuery<T>{detail::reversed(t.light), detail::reversed(s)});
    if (!(p_y > T(0))) return T(0);
    return p_x * p_y;
  }

  /// p_K(s.x | s_{i-1}) p_K(s.y | s_{i+1}) V(s.x, s.y) for any segment s.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

 private:
  K kernel_;
};

/// Light-kernel bridge, i.e. next-event estimation (N34): x_i from the kernel around y_{i-1}
/// (the Dirac kernel: y_{i-1} itself), y_i from the emitter's sample_towards(x_i), rejected
/// unless V(x_i, y_i):  p(s_i | s_{i-1}) = p_K(x_i | s_{i-1}) p_L(y_i | x_i). A draw whose
/// emission towards x_i is zero (a one-sided emitter seen from behind) is rejected before its
/// shadow ray, and pdf() is 0 for such a segment (requirement 7 of SegmentSampler).
/// The (N17) factors it carries: K(s_{i-1}, s_i) G(s_i) L_e(s_i); the BSDF f_r(s_{i-1}, s_i) at
/// y_{i-1} is the estimator's connection term. p_L is in the measure of y's kind (area,
/// discrete for point lights, solid angle for distant lights); G drops the matching factors.
/// weight = (K / p_K) G L_e / p_L. `delta` is set for Dirac light ends (EmitterTowardsSample::delta).
template <LightSampledScene Scn, KernelOf<typename Scn::Scalar> K>
  requires std::same_as<typename K::Scalar, typename Scn::Scalar>
class LightBridgeSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The camera subpath's last segment s_{i-1}.
  struct Technique {
    const Segment<T>& camera;
  };
  static constexpr bool is_dirac = K::is_dirac;

  explicit LightBridgeSampler(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>)
      : kernel_(std::move(kernel)) {}
  [[nodiscard]] const K& kernel() const noexcept { return kernel_; }

  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    const T u_select = rng.template uniform<T>();
    SurfacePoint<T> x = t.camera.y;
    T p_x = T(1);
    if constexpr (!K::is_dirac) {
      const auto junction = kernel_.sample(KernelSampleQuery<T>{t.camera, Vec2<T>(u0, u1)});
      if (!junction || !(junction->pdf > T(0))) return std::nullopt;
      x = junction->point;
      p_x = junction->pdf;
    } else {
      (void)u0, (void)u1;
    }
    const auto e = scene.emitter().sample_towards(EmitterTowardsQuery<T>{x, Vec2<T>(u2, u3), u_select});
    if (!e || !(e->pdf > T(0)) || !std::isfinite(e->pdf)) return std::nullopt;
    const Segment<T> s{x, e->point};
    if (s.y.kind != PointKind::direction && !(s.length_squared() > T(0))) return std::nullopt;
    // A draw that sees the emitter's back (one-sided) carries nothing: no shadow ray for it.
    if (is_black(e->radiance)) return std::nullopt;
    if (!scene.visible(VisibilityQuery<T>{s.x, s.y})) return std::nullopt;
    const Vec3<T> direction = s.direction();
    const T g = geometry_term(s);
    T k = T(1);
    if constexpr (!K::is_dirac) k = kernel_.eval(KernelQuery<T>{t.camera, s});
    return in_place_optional<SegmentSample<S>>(s, direction, e->radiance * (k * g), p_x * e->pdf, e->radiance * ((k / p_x) * g / e->pdf), e->delta);
  }

  /// p_K(s.x | s_{i-1}) pdf_towards(s.y | s.x) for any segment s whose emitter end emits
  /// towards s.x (0 otherwise): the density of the kernel and emitter draws, before the
  /// visibility test.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    if (s.y.kind != PointKind::direction && !(s.length_squared() > T(0))) return T(0);
    const T p_x = kernel_.pdf(KernelQuery<T>{t.camera, s});
    if (!(p_x > T(0))) return T(0);
    const T p_y = scene.emitter().pdf_towards(EmitterPdfTowardsQuery<T>{s.x, s.y});
    if (!(p_y > T(0))) return T(0);
    if (is_black(emission_factor(scene, s))) return T(0);  // as sample() rejects it
    return p_x * p_y;
  }

  /// p_K(s.x | s_{i-1}) pdf_towards(s.y | s.x) V(s.x, s.y) for any segment s.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

 private:
  K kernel_;
};

/// Sensor-kernel bridge, light tracing's camera connection (N34): x_1 from the sensor's
/// position sampling, y_1 from the kernel around x_2 of the light subpath, rejected unless
/// V(x_1, y_1) and the sensor sees along s_1:  p(s_1 | s_2) = p_W,pos(x_1) p_K(y_1 | s_2).
/// x_1 is the origin of sensor().sample_ray for pixel 0 with its pdf_position (the position
/// sampling of a pinhole, discrete probability 1, or of a lens, must not depend on the
/// pixel); the pixel s_1 lands in is sensor().importance(x_1, s^_1) (sensor_factor in
/// integrand/contribution.hpp). The (N17) factors it carries: W(s_1) G(s_1) K(s_1, s_2); the BSDF
/// f_r(s_1, s_2) at y_1 is the estimator's connection term. weight = W G (K / p_K) / p_pos.
template <Scene Scn, KernelOf<typename Scn::Scalar> K>
  requires std::same_as<typename K::Scalar, typename Scn::Scalar>
class SensorBridgeSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The light subpath's segment s_2 whose sensor end x_2 the bridge reaches.
  struct Technique {
    const Segment<T>& light;
  };
  static constexpr bool is_dirac = true;  ///< pinholes are deltas in position

  explicit SensorBridgeSampler(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>)
      : kernel_(std::move(kernel)) {}
  [[nodiscard]] const K& kernel() const noexcept { return kernel_; }

  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    const T u4 = rng.template uniform<T>();
    const T u5 = rng.template uniform<T>();
    const auto origin =
        scene.sensor().sample_ray(SensorSampleQuery<T>{0, Vec2<T>(u0, u1), Vec2<T>(u4, u5)});
    if (!origin || !(origin->pdf_position > T(0))) return std::nullopt;
    SurfacePoint<T> y = t.light.x;
    T p_y = T(1);
    if constexpr (!K::is_dirac) {
      const Segment<T> mirror = detail::reversed(t.light);
      const auto junction = kernel_.sample(KernelSampleQuery<T>{mirror, Vec2<T>(u2, u3)});
      if (!junction || !(junction->pdf > T(0))) return std::nullopt;
      y = junction->point;
      p_y = junction->pdf;
    } else {
      (void)u2, (void)u3;
    }
    const Segment<T> s{origin->origin, y};
    const Vec3<T> delta = s.y.position - s.x.position;
    const T d2 = glm::dot(delta, delta);
    if (!(d2 > T(0)) || !std::isfinite(d2)) return std::nullopt;
    const T distance = std::sqrt(d2);
    const Vec3<T> direction = delta / distance;
    const auto response = scene.sensor().importance(SensorQuery<T>{s.x, direction});
    if (!response || !(response->importance > T(0))) return std::nullopt;
    if (!scene.visible(VisibilityQuery<T>{s.x, s.y})) return std::nullopt;
    const T wg = response->importance * geometry_term(s, direction, distance);
    T k = T(1);
    if constexpr (!K::is_dirac) k = kernel_.eval(KernelQuery<T>{s, t.light});
    return in_place_optional<SegmentSample<S>>(s, direction, S(wg * k), origin->pdf_position * p_y, S(wg * (k / p_y) / origin->pdf_position), false);
  }

  /// p_W,pos(s.x) p_K(s.y | s_2) for any segment s the sensor sees (importance() has a
  /// pixel for it), 0 otherwise: the density of the two draws, before the visibility test.
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    if (!(s.length_squared() > T(0))) return T(0);
    const T p_y = kernel_.pdf(KernelQuery<T>{detail::reversed(t.light), detail::reversed(s)});
    if (!(p_y > T(0))) return T(0);
    const SensorQuery<T> query{s.x, s.direction()};
    const auto response = scene.sensor().importance(query);
    if (!response || !(response->importance > T(0))) return T(0);
    const T p_x = scene.sensor().pdf(query).position;
    if (!(p_x > T(0))) return T(0);
    return p_x * p_y;
  }

  /// p_W,pos(s.x) p_K(s.y | s_2) V(s.x, s.y) for any segment s the sensor sees; 0 otherwise.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

 private:
  K kernel_;
};

}  // namespace segpath
