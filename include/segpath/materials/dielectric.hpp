// A smooth dielectric interface (the Cornell-box glass sphere): Fresnel-weighted specular
// reflection and Snell refraction, two-sided, both delta lobes.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "segpath/concepts/bsdf.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/materials/scattering.hpp"

namespace segpath {

/// A smooth interface between the outside (the geometric normal's side, index 1) and the
/// inside (index `eta`, 1.6 for the Cornell-box glass). Two-sided: the side of the fixed
/// direction w (sign of n . w, n the geometric normal) says whether the path is outside or
/// inside. With e = eta_fixed / eta_other and F = fresnel_dielectric(|n_s . w|, e) (exact,
/// unpolarised; F = 1 under total internal reflection):
///  - reflection, chosen when u_lobe < F: direction reflect(w) about the shading normal,
///    pdf = F, value = F / |n . w_r|;
///  - refraction, chosen otherwise: direction by Snell's law, pdf = 1 - F,
///    value = (1 - F) s / |n . w_t|, with s = e^2 = (eta_i / eta_t)^2 for Transport::radiance
///    and s = 1 for Transport::importance.
/// So value |n . w| / pdf is 1 for reflection and s for refraction (the delta coefficient
/// convention of Mirror: eval() and pdf() return 0).
///
/// The scale s is the non-symmetric part of refraction (Veach's thesis, section 5.2; pbrt's
/// TransportMode): radiance is not invariant across an interface, L_t = (eta_t / eta_i)^2 L_i
/// along the light flow. A radiance path (fixed = to_sensor, eta_i the fixed side's index, the
/// side the light flows to; eta_t the sampled side's) estimates the radiance arriving on its
/// camera side, so each refraction scales it by (eta_i / eta_t)^2 (cornell-boxes.md, SmallVCM's
/// camera paths). An importance path (fixed = to_light) uses the adjoint BSDF, whose
/// refraction carries no such factor: light particles carry flux, which refraction does not
/// concentrate (SmallVCM's light paths).
template <Spectrum S>
class Dielectric {
 public:
  using Scalar = spectrum_scalar_t<S>;

  /// `eta` = inside / outside index of refraction. Throws std::invalid_argument unless it is
  /// finite and > 0.
  explicit Dielectric(Scalar eta) : eta_(eta) {
    if (!std::isfinite(eta) || !(eta > Scalar(0)))
      throw std::invalid_argument("segpath::Dielectric: eta must be finite and > 0, got " +
                                  format_number(double(eta)));
  }

  [[nodiscard]] Scalar eta() const noexcept { return eta_; }

  /// e = eta_fixed / eta_other for a fixed direction on the outside (n . w > 0) or inside.
  [[nodiscard]] Scalar eta_ratio(bool fixed_outside) const noexcept {
    return fixed_outside ? Scalar(1) / eta_ : eta_;
  }

  /// F for the fixed direction `w` at `p` (the reflection probability of sample()).
  [[nodiscard]] Scalar reflectance(const SurfacePoint<Scalar>& p,
                                   const Vec3<Scalar>& w) const noexcept {
    const Scalar cos_geometric = glm::dot(w, p.normal);
    return fresnel_dielectric(std::abs(glm::dot(w, p.shading_normal)),
                              eta_ratio(cos_geometric > Scalar(0)));
  }

  [[nodiscard]] S eval(const BsdfQuery<Scalar>&) const noexcept { return S(Scalar(0)); }

  [[nodiscard]] std::optional<BsdfSample<S>> sample(
      const BsdfSampleQuery<Scalar>& q) const noexcept {
    const Scalar cos_fixed = glm::dot(q.fixed, q.point.normal);
    if (!(std::abs(cos_fixed) > one_sided_epsilon<Scalar>)) return std::nullopt;
    const bool outside = cos_fixed > Scalar(0);
    const Scalar e = eta_ratio(outside);
    // The shading normal turned to the fixed side.
    const Vec3<Scalar> m = outside ? q.point.shading_normal : -q.point.shading_normal;
    const Scalar cos_i = glm::dot(q.fixed, m);
    if (!(cos_i > Scalar(0))) return std::nullopt;
    const Scalar cos_t = refracted_cosine(std::min(cos_i, Scalar(1)), e);
    const Scalar f = fresnel_dielectric(cos_i, e);
    if (q.u_lobe < f) {
      const Vec3<Scalar> direction = reflect(q.fixed, m);
      const Scalar cosine = glm::dot(direction, q.point.normal);
      // Reflection stays on the fixed side.
      if (!(std::abs(cosine) > one_sided_epsilon<Scalar>) || (cosine > Scalar(0)) != outside)
        return std::nullopt;
      return in_place_optional<BsdfSample<S>>(direction, S(f / std::abs(cosine)), f, true);
    }
    if (!(cos_t >= Scalar(0))) return std::nullopt;
    const Vec3<Scalar> direction = refract(q.fixed, m, cos_i, cos_t, e);
    const Scalar cosine = glm::dot(direction, q.point.normal);
    if (!(std::abs(cosine) > one_sided_epsilon<Scalar>) || (cosine > Scalar(0)) == outside)
      return std::nullopt;
    const Scalar transmittance = Scalar(1) - f;
    const Scalar scale = q.mode == Transport::radiance ? e * e : Scalar(1);
    return in_place_optional<BsdfSample<S>>(direction, S(transmittance * scale / std::abs(cosine)), transmittance, true);
  }

  [[nodiscard]] Scalar pdf(const BsdfQuery<Scalar>&) const noexcept { return Scalar(0); }

  /// Two-sided: only a direction in the tangent plane scatters nothing (HasScattersFrom).
  [[nodiscard]] bool scatters_from(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& w) const noexcept {
    return std::abs(glm::dot(w, p.normal)) > one_sided_epsilon<Scalar>;
  }

 private:
  Scalar eta_;
};

}  // namespace segpath
