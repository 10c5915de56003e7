// The Lambertian BRDF f_r = albedo / pi, one-sided about the geometric normal.
#pragma once

#include "segpath/concepts/bsdf.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"
#include "segpath/materials/scattering.hpp"

namespace segpath {

/// Diffuse reflection. Both directions must lie above the geometric normal; directions are
/// sampled by cosine about the shading normal.
template <Spectrum S>
struct Lambertian {
  using Scalar = spectrum_scalar_t<S>;
  S albedo{};

  [[nodiscard]] S eval(const BsdfQuery<Scalar>& q) const noexcept {
    if (!both_above(q.point, q.to_sensor, q.to_light)) return S(Scalar(0));
    return albedo * inv_pi<Scalar>;
  }

  [[nodiscard]] std::optional<BsdfSample<S>> sample(
      const BsdfSampleQuery<Scalar>& q) const noexcept {
    if (!is_above(q.point, q.fixed)) return std::nullopt;
    const Vec3<Scalar> local = square_to_cosine_hemisphere(q.u);
    const Vec3<Scalar> direction = q.point.shading_frame().to_world(local);
    const Scalar pdf = square_to_cosine_hemisphere_pdf(local);
    if (!(pdf > Scalar(0)) || !is_above(q.point, direction)) return std::nullopt;
    return in_place_optional<BsdfSample<S>>(direction, albedo * inv_pi<Scalar>, pdf, false);
  }

  /// One-sided: nothing is scattered from behind the geometric normal (HasScattersFrom).
  [[nodiscard]] bool scatters_from(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& w) const noexcept {
    return is_above(p, w);
  }

  [[nodiscard]] Scalar pdf(const BsdfQuery<Scalar>& q) const noexcept {
    if (!both_above(q.point, q.to_sensor, q.to_light)) return Scalar(0);
    const Vec3<Scalar>& free = q.mode == Transport::radiance ? q.to_light : q.to_sensor;
    const Scalar cosine = glm::dot(free, q.point.shading_normal);
    return cosine > Scalar(0) ? cosine * inv_pi<Scalar> : Scalar(0);
  }

 private:
  static bool both_above(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& a,
                         const Vec3<Scalar>& b) noexcept {
    return is_above(p, a) && is_above(p, b);
  }
};

}  // namespace segpath
