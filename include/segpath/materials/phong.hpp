// The energy-conserving modified Phong lobe of the Cornell-box floor (SmallVCM's glossy
// lobe): f_r = rho (n + 2) / (2 pi) cos^n(alpha), alpha between the mirrored fixed direction
// and the free one, importance-sampled by the cos^n lobe about the mirror direction.
#pragma once

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "segpath/concepts/bsdf.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/frame.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/materials/scattering.hpp"

namespace segpath {

/// Where the lobe is cut off: f_r = 0 for cos(alpha) <= this (SmallVCM's EPS_PHONG,
/// cornell-boxes.md).
template <Real T>
inline constexpr T phong_cutoff = T(1e-3);

/// The modified Phong BRDF (Lafortune and Willems 1994; the Cornell-box floor lobe of
/// cornell-boxes.md): f_r(a, b) = rho (n + 2) / (2 pi) cos^n(alpha), cos(alpha) = the cosine
/// between reflect(a) about the shading normal and b (symmetric in a and b, so f_r is
/// reciprocal), 0 where cos(alpha) <= phong_cutoff or where either direction is below the
/// geometric normal (one-sided). Energy conserving for rho <= 1: the directional albedo is
/// rho at normal incidence and less elsewhere.
///
/// Sampling (both Transport modes alike, the lobe is symmetric): the cos^n lobe about the
/// mirrored fixed direction, density (n + 1) / (2 pi) cos^n(alpha). Samples with f_r = 0
/// (below the surface, past the cut-off) are rejected (nullopt), and pdf() is 0 there, so the
/// density integrates to the acceptance probability (Bsdf requirement 5).
template <Spectrum S>
class Phong {
 public:
  using Scalar = spectrum_scalar_t<S>;

  /// `coefficient` rho (0.7 on the Cornell floor) and exponent n >= 0 (90 there).
  /// Throws std::invalid_argument for a coefficient that is not finite and >= 0 in every
  /// channel, or an exponent that is not finite and >= 0.
  explicit Phong(S coefficient, Scalar exponent) : coefficient_(coefficient), exponent_(exponent) {
    if (!is_finite(coefficient))
      throw std::invalid_argument("segpath::Phong: the coefficient must be finite");
    if (min_component(coefficient) < Scalar(0))
      throw std::invalid_argument("segpath::Phong: the coefficient must be >= 0 in every channel, got " +
                                  format_number(double(min_component(coefficient))));
    if (!std::isfinite(exponent) || exponent < Scalar(0))
      throw std::invalid_argument("segpath::Phong: the exponent must be finite and >= 0, got " +
                                  format_number(double(exponent)));
    eval_scale_ = (exponent + Scalar(2)) * (Scalar(0.5) * inv_pi<Scalar>);
    pdf_scale_ = (exponent + Scalar(1)) * (Scalar(0.5) * inv_pi<Scalar>);
    inv_exponent_plus_one_ = Scalar(1) / (exponent + Scalar(1));
    if (exponent == std::floor(exponent) && exponent <= Scalar(1 << 20)) integer_exponent_ = static_cast<std::uint32_t>(exponent);
  }

  [[nodiscard]] const S& coefficient() const noexcept { return coefficient_; }
  [[nodiscard]] Scalar exponent() const noexcept { return exponent_; }

  [[nodiscard]] S eval(const BsdfQuery<Scalar>& q) const noexcept {
    const Scalar lobe = lobe_of(q.point, q.to_sensor, q.to_light);
    return lobe > Scalar(0) ? coefficient_ * (eval_scale_ * lobe) : S(Scalar(0));
  }

  [[nodiscard]] std::optional<BsdfSample<S>> sample(
      const BsdfSampleQuery<Scalar>& q) const noexcept {
    if (!is_above(q.point, q.fixed)) return std::nullopt;
    const Vec3<Scalar> axis = reflect(q.fixed, q.point.shading_normal);
    // cos(alpha) = (1 - u)^(1 / (n + 1)) inverts the cos^n lobe's CDF 1 - cos^(n+1).
    const Scalar cos_alpha = std::pow(Scalar(1) - q.u.x, inv_exponent_plus_one_);
    const Scalar sin_alpha = std::sqrt(std::max(Scalar(0), Scalar(1) - cos_alpha * cos_alpha));
    const Scalar phi = Scalar(2) * pi<Scalar> * q.u.y;
    const Vec3<Scalar> local(sin_alpha * std::cos(phi), sin_alpha * std::sin(phi), cos_alpha);
    const Vec3<Scalar> direction = Frame<Scalar>::from_normal(axis).to_world(local);
    // value and pdf from the final direction, exactly as eval and pdf compute them.
    const Scalar lobe = lobe_of(q.point, q.fixed, direction);
    const Scalar pdf = pdf_scale_ * lobe;
    if (!(pdf > Scalar(0)) || !std::isfinite(pdf)) return std::nullopt;
    return in_place_optional<BsdfSample<S>>(direction, coefficient_ * (eval_scale_ * lobe), pdf, false);
  }

  [[nodiscard]] Scalar pdf(const BsdfQuery<Scalar>& q) const noexcept {
    return pdf_scale_ * lobe_of(q.point, q.to_sensor, q.to_light);
  }

  /// One-sided: nothing is scattered from behind the geometric normal (HasScattersFrom).
  [[nodiscard]] bool scatters_from(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& w) const noexcept {
    return is_above(p, w);
  }

 private:
  /// cos^n(alpha) where the lobe is non-zero, else 0.
  [[nodiscard]] Scalar lobe_of(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& a,
                               const Vec3<Scalar>& b) const noexcept {
    if (!is_above(p, a) || !is_above(p, b)) return Scalar(0);
    const Scalar cos_alpha = reflected_cosine(a, b, p.shading_normal);
    if (!(cos_alpha > phong_cutoff<Scalar>)) return Scalar(0);
    const Scalar c = std::min(cos_alpha, Scalar(1));
    if (!integer_exponent_) return std::pow(c, exponent_);
    // Integer exponents (90 on the Cornell floor) by repeated squaring: a few multiplies
    // instead of a pow in the hot loops that evaluate the lobe for many pairs.
    Scalar result = 1, base = c;
    for (std::uint32_t e = *integer_exponent_; e != 0; e >>= 1) {
      if (e & 1u) result *= base;
      base *= base;
    }
    return result;
  }

  S coefficient_;
  Scalar exponent_;
  Scalar eval_scale_ = 0;
  Scalar pdf_scale_ = 0;
  Scalar inv_exponent_plus_one_ = 1;
  std::optional<std::uint32_t> integer_exponent_;
};

}  // namespace segpath
