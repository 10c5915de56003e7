// The uniform disk kernel (N19) with the disk support of SPEC 1.2: the points of M within
// radius r of y whose normal agrees with n_y; |K(y)| = pi r^2 (VCM / photon mapping style).
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/frame.hpp"
#include "segpath/core/in_place_optional.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace segpath {

template <Real T>
class DiskKernel {
 public:
  using Scalar = T;
  static constexpr bool is_dirac = false;

  /// `radius` > 0 and finite; `min_normal_cosine` in [-1, 1]: x' is in the support only if
  /// n_x' . n_y >= min_normal_cosine.
  explicit DiskKernel(T radius, T min_normal_cosine = T(0.5))
      : radius_(radius), min_normal_cosine_(min_normal_cosine) {
    // 1 / (pi r^2) must be finite and > 0 as well: beyond, eval is 0 everywhere.
    const T inv_area = T(1) / (pi<T> * radius * radius);
    if (!(radius > T(0)) || !std::isfinite(radius) || !(inv_area > T(0)) || !std::isfinite(inv_area))
      throw std::invalid_argument("segpath::DiskKernel: radius must be finite and > 0, and 1 / (pi r^2) finite and > 0, got " +
                                  format_number(double(radius)));
    if (!(min_normal_cosine >= T(-1) && min_normal_cosine <= T(1)))
      throw std::invalid_argument(
          "segpath::DiskKernel: min_normal_cosine must lie in [-1, 1], got " +
          format_number(double(min_normal_cosine)));
    inv_area_ = inv_area;
  }

  [[nodiscard]] T radius() const noexcept { return radius_; }
  [[nodiscard]] T min_normal_cosine() const noexcept { return min_normal_cosine_; }

  /// 1[x' in K(y)] / (pi r^2) (N19).
  [[nodiscard]] T eval(const KernelQuery<T>& q) const noexcept {
    return in_support(q.from.y, q.to.x) ? inv_area_ : T(0);
  }

  /// x' uniform in the disk of radius r in the tangent plane of y (exact on planar
  /// neighbourhoods; elsewhere the locally-planar approximation of VCM). The drawn point
  /// keeps y's normal, frame and ids. A draw that rounding puts on or beyond the rim (u.x
  /// near 1, or r small against |y|) is pulled inward until in_support holds, so the returned
  /// pdf is always pdf() of the point; nullopt only for non-surface or non-finite y.
  [[nodiscard]] std::optional<KernelSample<T>> sample(
      const KernelSampleQuery<T>& q) const noexcept {
    const SurfacePoint<T>& y = q.from.y;
    if (y.kind != PointKind::surface) return std::nullopt;
    const T rho = radius_ * std::sqrt(q.u.x);
    const T phi = T(2) * pi<T> * q.u.y;
    const Frame<T> frame = Frame<T>::from_normal(y.normal);
    const Vec3<T> offset =
        frame.tangent * (rho * std::cos(phi)) + frame.bitangent * (rho * std::sin(phi));
    SurfacePoint<T> x = y;
    x.position = y.position + offset;
    for (T shrink = T(4) * std::numeric_limits<T>::epsilon(); SEGPATH_UNLIKELY(!in_support(y, x));
         shrink *= T(4)) {
      if (!(shrink < T(1))) return std::nullopt;
      x.position = y.position + offset * (T(1) - shrink);
    }
    return in_place_optional<KernelSample<T>>(x, inv_area_);
  }

  [[nodiscard]] T pdf(const KernelQuery<T>& q) const noexcept { return eval(q); }
  [[nodiscard]] T support_radius(const KernelSupportQuery<T>&) const noexcept { return radius_; }

  [[nodiscard]] bool in_support(const SurfacePoint<T>& y, const SurfacePoint<T>& x) const noexcept {
    if (y.kind != PointKind::surface || x.kind != PointKind::surface) return false;
    const Vec3<T> d = x.position - y.position;
    // The slack of a few ulps keeps min_normal_cosine = 1 meaning "same normal": the dot
    // product of a unit normal with itself rounds to slightly below 1.
    return glm::dot(d, d) < radius_ * radius_ &&
           glm::dot(x.normal, y.normal) >=
               min_normal_cosine_ - T(8) * std::numeric_limits<T>::epsilon();
  }

 private:
  T radius_;
  T min_normal_cosine_;
  T inv_area_ = 0;
};

}  // namespace segpath
