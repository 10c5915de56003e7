// The Dirac kernel K = delta(x_{i+1} - y_i) (SPEC 1.2): segments touch, and segment paths
// collapse to ordinary vertex paths.
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/core/in_place_optional.hpp"

namespace segpath {

/// Under the delta convention eval and pdf both return the coefficient 1 when the next
/// segment starts exactly at y (as it does when drawn by sample) and 0 otherwise, so
/// K / p_K = 1 for every segment path built through it.
template <Real T>
struct DiracKernel {
  using Scalar = T;
  static constexpr bool is_dirac = true;

  [[nodiscard]] T eval(const KernelQuery<T>& q) const noexcept {
    return q.to.x.position == q.from.y.position ? T(1) : T(0);
  }
  [[nodiscard]] std::optional<KernelSample<T>> sample(const KernelSampleQuery<T>& q) const noexcept {
    return in_place_optional<KernelSample<T>>(q.from.y, T(1));
  }
  [[nodiscard]] T pdf(const KernelQuery<T>& q) const noexcept { return eval(q); }
  [[nodiscard]] T support_radius(const KernelSupportQuery<T>&) const noexcept { return T(0); }
};

}  // namespace segpath
