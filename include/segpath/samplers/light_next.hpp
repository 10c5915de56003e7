// The sequential next-segment sampler on the light side, the mirror image of (N31): given
// s_{i+1}, y_i from the kernel around x_{i+1}, the direction -s^_i from the adjoint BSDF at y_i,
// x_i the first hit:  p(s_i | s_{i+1}) = p_K(y_i | s_{i+1}) p_w(-s^_i | y_i, s^_{i+1}) |n_x . s^_i| / d^2.
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/core/geometry.hpp"

#include <optional>

namespace segpath {

namespace detail {

/// The mirror image (y, x) of a segment. Light-side samplers hand kernels reversed segments,
/// so that "draw around from.y" draws around x_{i+1}: p_K(y_i | s_{i+1}) is
/// kernel.pdf({reversed(s_{i+1}), reversed(s_i)}). This is exact for kernels symmetric in the
/// two joined ends, as the Dirac and the disk kernel are (N19: |x_{i+1} - y_i| < r with
/// agreeing normals, 1/(pi r^2) either way).
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE Segment<T> reversed(const Segment<T>& s) noexcept {
  return Segment<T>{s.y, s.x};
}

/// The light-side continuation from a junction y_i: the adjoint BSDF at y_i samples
/// -s^_i given s^_{i+1}, x_i is the first hit, and the sample gets factor K f_r G(s_i)
/// (N17) and density junction_pdf p_w |n_x . s^_i| / d^2. K(s_i, s_{i+1}) is evaluated on the
/// finished s_i (1 for a Dirac kernel). Shared by LightNextSegmentSampler and the light-side
/// approximate sampler (samplers/approximate.hpp).
template <class Scn, class K>
[[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<typename Scn::Spectrum>> light_continue_from(
    const Scn& scene, const K& kernel, const Segment<typename Scn::Scalar>& next,
    const Vec3<typename Scn::Scalar>& next_direction, const SurfacePoint<typename Scn::Scalar>& junction,
    typename Scn::Scalar junction_pdf, const Vec2<typename Scn::Scalar>& u_bsdf,
    typename Scn::Scalar u_lobe) noexcept {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  const auto bsdf =
      scene.bsdf().sample(BsdfSampleQuery<T>{junction, next_direction, u_bsdf, u_lobe, Transport::importance});
  if (!bsdf || !(bsdf->pdf > T(0))) return std::nullopt;
  const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{junction.position, bsdf->direction}});
  if (!hit) return std::nullopt;
  // A grazing ray whose hit rounds to the other side of the junction's tangent plane: outside
  // pdf()'s support.
  if (junction.kind == PointKind::surface &&
      !(glm::dot(hit->point.position - junction.position, junction.normal) * glm::dot(bsdf->direction, junction.normal) >
        T(0)))
    return std::nullopt;
  const Segment<T> s{hit->point, junction};
  // G(s_i) and the density share |n_x . s^| / d^2; what remains of G is |n_y . s^|.
  const T area_factor = solid_angle_to_area(T(1), junction, hit->point, bsdf->direction, hit->distance);
  const T cos_y = endpoint_cosine(junction, bsdf->direction);
  T k = T(1);
  if constexpr (!K::is_dirac) k = kernel.eval(KernelQuery<T>{s, next});
  return in_place_optional<SegmentSample<S>>(s, -bsdf->direction, link_factor(k, bsdf->value, cos_y * area_factor),
                                             junction_pdf * bsdf->pdf * area_factor, bsdf->value * ((k / junction_pdf) * cos_y / bsdf->pdf),
                                             bsdf->delta);
}

}  // namespace detail

/// Light subpaths are built from the light towards the sensor: this sampler draws s_i given
/// s_{i+1}. The translated BSDF of (N20) is the BSDF at y_i: with the Dirac kernel y_i is
/// x_{i+1} itself; with the disk kernel y_i is the kernel's sample in the tangent plane of
/// x_{i+1}, which carries x_{i+1}'s normal, shading frame and material, so f_r(s_i, s_{i+1})
/// is x_{i+1}'s BSDF moved to y_i.
template <Scene Scn, KernelOf<typename Scn::Scalar> K>
  requires std::same_as<typename K::Scalar, typename Scn::Scalar>
class LightNextSegmentSampler {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  /// The technique parameter: the segment s_{i+1} being continued towards the sensor, with
  /// its unit direction (pass it when known to save a normalisation).
  struct Technique {
    const Segment<T>& next;
    Vec3<T> direction;
    Technique(const Segment<T>& s) noexcept : next(s), direction(s.direction()) {}  // NOLINT: implicit by design
    Technique(const Segment<T>& s, const Vec3<T>& d) noexcept : next(s), direction(d) {}
  };
  static constexpr bool is_dirac = K::is_dirac;

  explicit LightNextSegmentSampler(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>)
      : kernel_(std::move(kernel)) {}
  [[nodiscard]] const K& kernel() const noexcept { return kernel_; }

  /// Draws s_i with factor K(s_i, s_{i+1}) f_r(s_i, s_{i+1}) G(s_i) (N17; f_r under
  /// Transport::importance, fixed = to_light = s^_{i+1}) and the mirrored (N31) density.
  /// weight = (K / p_K) f_r |n_y . s^_i| / p_w.
  template <UniformSource<T> R>
  [[nodiscard]] SEGPATH_FORCE_INLINE std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t,
                                                                            R& rng) const noexcept {
    const T u0 = rng.template uniform<T>();
    const T u1 = rng.template uniform<T>();
    const T u2 = rng.template uniform<T>();
    const T u3 = rng.template uniform<T>();
    const T u_lobe = rng.template uniform<T>();
    if constexpr (K::is_dirac) {
      // The junction is x_{i+1} itself and K / p_K = 1.
      (void)u0;
      (void)u1;
      return detail::light_continue_from(scene, kernel_, t.next, t.direction, t.next.x, T(1), Vec2<T>(u2, u3), u_lobe);
    } else {
      const Segment<T> mirror = detail::reversed(t.next);
      const auto junction = kernel_.sample(KernelSampleQuery<T>{mirror, Vec2<T>(u0, u1)});
      if (!junction || !(junction->pdf > T(0))) return std::nullopt;
      return detail::light_continue_from(scene, kernel_, t.next, t.direction, junction->point, junction->pdf,
                                         Vec2<T>(u2, u3), u_lobe);
    }
  }

  /// p(s | s_{i+1}) for any segment s as if x were the first hit from y:
  /// p_K(y | s_{i+1}) direction_pdf(y, -s^, s^_{i+1}) area_jacobian(s) (the last two grouped
  /// as solid_angle_to_area, so rounding differs from that product).
  [[nodiscard]] T unoccluded_pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    if (s.x.kind == PointKind::direction || !(s.length_squared() > T(0))) return T(0);
    const T p_kernel = kernel_.pdf(KernelQuery<T>{detail::reversed(t.next), detail::reversed(s)});
    if (!(p_kernel > T(0))) return T(0);
    const T p_direction = direction_pdf(scene, s.y, -s.direction(), t.direction);
    if (!(p_direction > T(0))) return T(0);
    return p_kernel * solid_angle_to_area(p_direction, s.y, s.x);
  }

  /// p(s | s_{i+1}): unoccluded_pdf where x is the first hit from y, 0 otherwise.
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    return visibility_masked(scene, s, unoccluded_pdf(scene, t, s));
  }

  /// p_w(to_sensor | y, to_light) of the mirrored (N31), in solid angle at y: the adjoint BSDF
  /// at the junction y samples `to_sensor` = -s^_i given `to_light` = s^_{i+1} (importance
  /// transport). Needs no sampler object and no Technique: for loops over (segment,
  /// technique) pairs.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T direction_pdf(const Scn& scene, const SurfacePoint<T>& y,
                                                            const Vec3<T>& to_sensor,
                                                            const Vec3<T>& to_light) noexcept {
    return scene.bsdf().pdf(BsdfQuery<T>{y, to_sensor, to_light, Transport::importance});
  }

  /// |n_x . s^| / |x - y|^2: direction_pdf's solid angle at y to x's area measure.
  [[nodiscard]] static SEGPATH_FORCE_INLINE T area_jacobian(const Segment<T>& s) noexcept {
    return solid_angle_to_area(T(1), s.y, s.x);
  }

 private:
  K kernel_;
};

}  // namespace segpath
