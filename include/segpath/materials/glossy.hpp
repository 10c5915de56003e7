// The Cornell-box floor material: a Lambertian lobe plus a modified Phong lobe, sampled by
// picking one lobe in proportion to its albedo weight (SmallVCM's layered BSDF).
#pragma once

#include <stdexcept>

#include "segpath/core/format.hpp"
#include "segpath/materials/lambertian.hpp"
#include "segpath/materials/phong.hpp"

namespace segpath {

/// f_r = diffuse / pi + Phong(rho, n) (cornell-boxes.md: diffuse 0.1, rho 0.7, n 90), one-sided.
///
/// Sampling: u_lobe < P_d picks the Lambertian lobe, else the Phong lobe, with
/// P_d = w_d / (w_d + w_p) and the albedo weights w = average(diffuse), average(rho)
/// (SmallVCM uses luminance; the two agree on the grey floor); `u` then samples the chosen
/// lobe. The returned value is the whole f_r and the pdf the mixture
/// P_d p_d + (1 - P_d) p_p of both lobes' densities (one-sample MIS, balance heuristic), so
/// pdf() needs no lobe. A sample the chosen lobe rejects is nullopt; each lobe's density is
/// zero where it rejects, so pdf() integrates to the acceptance probability.
template <Spectrum S>
class Glossy {
 public:
  using Scalar = spectrum_scalar_t<S>;

  /// Throws std::invalid_argument for a diffuse albedo or Phong coefficient that is not
  /// finite and >= 0 in every channel, or a bad exponent (see Phong).
  Glossy(S diffuse, S phong_coefficient, Scalar exponent)
      : diffuse_{diffuse}, phong_(phong_coefficient, exponent) {
    if (!is_finite(diffuse))
      throw std::invalid_argument("segpath::Glossy: the diffuse albedo must be finite");
    if (min_component(diffuse) < Scalar(0))
      throw std::invalid_argument("segpath::Glossy: the diffuse albedo must be >= 0 in every channel, got " +
                                  format_number(double(min_component(diffuse))));
    const Scalar w_d = average(diffuse);
    const Scalar w_p = average(phong_coefficient);
    const Scalar total = w_d + w_p;
    diffuse_probability_ = total > Scalar(0) ? w_d / total : Scalar(0);
    phong_probability_ = total > Scalar(0) ? w_p / total : Scalar(0);
  }

  [[nodiscard]] const Lambertian<S>& diffuse() const noexcept { return diffuse_; }
  [[nodiscard]] const Phong<S>& phong() const noexcept { return phong_; }
  /// P_d, the probability of sampling the Lambertian lobe.
  [[nodiscard]] Scalar diffuse_probability() const noexcept { return diffuse_probability_; }

  [[nodiscard]] S eval(const BsdfQuery<Scalar>& q) const noexcept {
    return diffuse_.eval(q) + phong_.eval(q);
  }

  [[nodiscard]] std::optional<BsdfSample<S>> sample(
      const BsdfSampleQuery<Scalar>& q) const noexcept {
    if (!(diffuse_probability_ + phong_probability_ > Scalar(0))) return std::nullopt;
    const bool pick_diffuse = q.u_lobe < diffuse_probability_;
    std::optional<BsdfSample<S>> s = pick_diffuse ? diffuse_.sample(q) : phong_.sample(q);
    if (!s) return std::nullopt;
    const BsdfQuery<Scalar> pair = q.mode == Transport::radiance
                                       ? BsdfQuery<Scalar>{q.point, q.fixed, s->direction, q.mode}
                                       : BsdfQuery<Scalar>{q.point, s->direction, q.fixed, q.mode};
    // The chosen lobe's value and density are in s already; add the other one's.
    if (pick_diffuse) {
      s->value += phong_.eval(pair);
      s->pdf = diffuse_probability_ * s->pdf + phong_probability_ * phong_.pdf(pair);
    } else {
      s->value += diffuse_.eval(pair);
      s->pdf = phong_probability_ * s->pdf + diffuse_probability_ * diffuse_.pdf(pair);
    }
    if (!(s->pdf > Scalar(0)) || !std::isfinite(s->pdf)) return std::nullopt;
    return s;
  }

  [[nodiscard]] Scalar pdf(const BsdfQuery<Scalar>& q) const noexcept {
    return diffuse_probability_ * diffuse_.pdf(q) + phong_probability_ * phong_.pdf(q);
  }

  /// One-sided, both lobes: nothing is scattered from behind the geometric normal (HasScattersFrom).
  [[nodiscard]] bool scatters_from(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& w) const noexcept {
    return is_above(p, w);
  }

 private:
  Lambertian<S> diffuse_;
  Phong<S> phong_;
  Scalar diffuse_probability_ = 0;
  Scalar phong_probability_ = 0;
};

}  // namespace segpath
