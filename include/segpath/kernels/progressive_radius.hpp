// Progressive kernel shrinking (progressive photon mapping, Knaus & Zwicker 2011):
// r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1), so r_i^2 = r_1^2 prod_{j=1}^{i-1} (j + alpha) / (j + 1).
// (SPEC 1.2 writes the factor as (j + alpha) / j, which grows; the PPM recurrence it cites
// is the shrinking one implemented here.)
#pragma once

#include "segpath/core/format.hpp"
#include "segpath/core/vec.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace segpath {

template <Real T>
class ProgressiveRadius {
 public:
  /// `initial_radius` > 0 and finite, `alpha` in (0, 1).
  ProgressiveRadius(T initial_radius, T alpha) : initial_(initial_radius), alpha_(alpha) {
    if (!(initial_radius > T(0)) || !std::isfinite(initial_radius))
      throw std::invalid_argument("segpath::ProgressiveRadius: radius must be finite and > 0, got " +
                                  format_number(double(initial_radius)));
    if (!(alpha > T(0) && alpha < T(1)))
      throw std::invalid_argument("segpath::ProgressiveRadius: alpha must lie in (0, 1), got " +
                                  format_number(double(alpha)));
  }

  /// The radius of iteration i >= 1 (iteration 1 uses the initial radius).
  [[nodiscard]] T radius(std::uint64_t iteration) const noexcept {
    double r2 = double(initial_) * double(initial_);
    for (std::uint64_t j = 1; j < iteration; ++j) r2 *= (double(j) + double(alpha_)) / double(j + 1);
    return T(std::sqrt(r2));
  }
  [[nodiscard]] T initial_radius() const noexcept { return initial_; }
  [[nodiscard]] T alpha() const noexcept { return alpha_; }

 private:
  T initial_;
  T alpha_;
};

/// The kernel size of each iteration of a progressive method (0-based iterations): none for
/// the methods without a kernel (PT, LT, BDPT), ProgressiveRadius's shrinking schedule (a disk
/// radius for the VCM family, a voxel size for the filtering methods), or a fixed size (to
/// measure a kernel's bias at that size).
template <Real T>
class KernelSchedule {
 public:
  KernelSchedule() = default;  ///< no kernel
  /// ProgressiveRadius(initial, alpha): `initial` > 0 and finite, `alpha` in (0, 1).
  KernelSchedule(T initial, T alpha) : initial_(ProgressiveRadius<T>(initial, alpha).initial_radius()), alpha_(alpha) {}
  /// The same `size` (> 0, finite) in every iteration.
  [[nodiscard]] static KernelSchedule fixed(T size) {
    if (!(size > T(0)) || !std::isfinite(size))
      throw std::invalid_argument("segpath::KernelSchedule: a fixed kernel size must be finite and > 0, got " +
                                  format_number(double(size)));
    KernelSchedule k;
    k.initial_ = size;
    k.alpha_ = T(1);
    return k;
  }
  [[nodiscard]] bool has_kernel() const noexcept { return initial_ > T(0); }
  /// The kernel of `iteration` (ProgressiveRadius's r_{iteration + 1}); 0 without a kernel.
  [[nodiscard]] T at(std::uint64_t iteration) const noexcept {
    if (!has_kernel() || alpha_ == T(1)) return initial_;
    return ProgressiveRadius<T>(initial_, alpha_).radius(iteration + 1);
  }
  [[nodiscard]] T initial() const noexcept { return initial_; }
  /// The shrinking factor: in (0, 1), 1 for a fixed size, 0 without a kernel.
  [[nodiscard]] T alpha() const noexcept { return alpha_; }

 private:
  T initial_ = 0, alpha_ = 0;
};

}  // namespace segpath
