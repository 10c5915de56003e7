// The sequential next-segment sampler on the sensor side (N31, N32): x_{i+1} from the
// kernel around y_i, the direction from the (translated, N20) BSDF at y_i, y_{i+1} the first
// hit from x_{i+1}:
//   p(s_{i+1} | s_i) = p_K(x_{i+1} | s_i) p_w(s^_{i+1} | y_i, s_i) |n_y . s^| / |x - y|^2.
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/sampler.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/contribution.hpp"
#include "segpath/core/geometry.hpp"

#include <optional>

namespace segpath {

template <Scene Scn, Kernel K>
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
  [[nodiscard]] std::optional<SegmentSample<S>> sample(const Scn& scene, const Technique& t, R& rng) const noexcept {
    const Segment<T>& prev = t.previous;
    const Vec2<T> u_kernel = rng.template uniform2<T>();
    const Vec2<T> u_bsdf = rng.template uniform2<T>();
    const T u_lobe = rng.template uniform<T>();
    // For a Dirac kernel the draw is y_i itself (K / p_K = 1): skip the kernel entirely.
    std::optional<KernelSample<T>> junction;
    if constexpr (K::is_dirac) {
      junction = KernelSample<T>{prev.y, T(1)};
    } else {
      junction = kernel_.sample(KernelSampleQuery<T>{prev, u_kernel});
      if (!junction || !(junction->pdf > T(0))) return std::nullopt;
    }
    const auto bsdf = scene.bsdf().sample(
        BsdfSampleQuery<T>{prev.y, -t.direction, u_bsdf, u_lobe, Transport::radiance});
    if (!bsdf || !(bsdf->pdf > T(0))) return std::nullopt;
    const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{junction->point.position, bsdf->direction}});
    if (!hit) return std::nullopt;

    SegmentSample<S> out;
    out.segment = Segment<T>{junction->point, hit->point};
    out.direction = bsdf->direction;
    out.delta = bsdf->delta;
    const T g = geometry_term(out.segment, bsdf->direction, hit->distance);
    if constexpr (K::is_dirac) {
      out.factor = link_factor(T(1), bsdf->value, g);
    } else {
      out.factor = link_factor(kernel_.eval(KernelQuery<T>{prev, out.segment}), bsdf->value, g);
    }
    out.pdf = junction->pdf * solid_angle_to_area(bsdf->pdf, junction->point, hit->point, bsdf->direction,
                                                  hit->distance);
    return out;
  }

  /// p(s | s_i) of (N31) for any segment s, including V(x, y) (y must be the first hit).
  [[nodiscard]] T pdf(const Scn& scene, const Technique& t, const Segment<T>& s) const noexcept {
    const Segment<T>& prev = t.previous;
    const T p_kernel = kernel_.pdf(KernelQuery<T>{prev, s});
    if (!(p_kernel > T(0))) return T(0);
    const T p_direction = scene.bsdf().pdf(
        BsdfQuery<T>{prev.y, -t.direction, s.direction(), Transport::radiance});
    if (!(p_direction > T(0))) return T(0);
    if (!scene.visible(VisibilityQuery<T>{s.x, s.y})) return T(0);
    return p_kernel * solid_angle_to_area(p_direction, s.x, s.y);
  }

 private:
  K kernel_;
};

}  // namespace segpath
