// A perfect specular reflector without Fresnel term (the Cornell-box mirror spheres): a
// delta BSDF that only sample() can produce.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>

#include "segpath/concepts/bsdf.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/materials/scattering.hpp"

namespace segpath {

/// f_r = R delta(w_free - reflect(w_fixed)) / |n . w_free|, R the reflectance (1 in the
/// Cornell boxes), one-sided about the geometric normal.
///
/// Delta coefficient convention (BsdfSample): sample() returns delta = true, pdf = 1 (the
/// single lobe's selection probability) and value = R / |n . w|, w the sampled direction and
/// n the geometric normal (the cosine the geometry term G carries), so that
/// value |n . w| / pdf = R exactly. eval() and pdf() return 0: no finite density describes a
/// delta lobe. Both Transport modes alike (reflection is symmetric).
template <Spectrum S>
class Mirror {
 public:
  using Scalar = spectrum_scalar_t<S>;

  /// Throws std::invalid_argument for a reflectance that is not finite and >= 0 in every channel.
  explicit Mirror(S reflectance = S(Scalar(1))) : reflectance_(reflectance) {
    if (!is_finite(reflectance))
      throw std::invalid_argument("segpath::Mirror: the reflectance must be finite");
    if (min_component(reflectance) < Scalar(0))
      throw std::invalid_argument("segpath::Mirror: the reflectance must be >= 0 in every channel, got " +
                                  format_number(double(min_component(reflectance))));
  }

  [[nodiscard]] const S& reflectance() const noexcept { return reflectance_; }

  [[nodiscard]] S eval(const BsdfQuery<Scalar>&) const noexcept { return S(Scalar(0)); }

  [[nodiscard]] std::optional<BsdfSample<S>> sample(
      const BsdfSampleQuery<Scalar>& q) const noexcept {
    if (!is_above(q.point, q.fixed)) return std::nullopt;
    const Vec3<Scalar> direction = reflect(q.fixed, q.point.shading_normal);
    const Scalar cosine = glm::dot(direction, q.point.normal);
    if (!(cosine > one_sided_epsilon<Scalar>)) return std::nullopt;
    return in_place_optional<BsdfSample<S>>(direction, reflectance_ / cosine, Scalar(1), true);
  }

  [[nodiscard]] Scalar pdf(const BsdfQuery<Scalar>&) const noexcept { return Scalar(0); }

  /// One-sided: nothing is scattered from behind the geometric normal (HasScattersFrom).
  [[nodiscard]] bool scatters_from(const SurfacePoint<Scalar>& p, const Vec3<Scalar>& w) const noexcept {
    return is_above(p, w);
  }

 private:
  S reflectance_;
};

}  // namespace segpath
