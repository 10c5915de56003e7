// Russian roulette after a scattering, with SmallVCM's rule (its BSDF::ContinuationProb): the
// continuation probability follows the scattering's own weight, not the path's throughput.
#pragma once

#include "segpath/core/spectrum.hpp"

#include <algorithm>

namespace segpath {

/// The probability q of continuing a path after a scattering whose sample weight
/// (f_r |cos| / p) is `weight`: min(1, its largest component), and 1 through a delta lobe.
/// The caller divides the throughput by q when the path survives, so the estimate is unchanged
/// in expectation and the roulette never raises the throughput's largest component. The
/// throughput rule q = max(throughput) instead lifts every surviving dark path to weight ~1:
/// fireflies in dark pixels (docs/figures.md, issue 14).
template <Spectrum S>
[[nodiscard]] constexpr spectrum_scalar_t<S> continuation_probability(const S& weight, bool delta) noexcept {
  using T = spectrum_scalar_t<S>;
  if (delta) return T(1);
  const T m = max_component(weight);
  return m < T(1) ? std::max(m, T(0)) : T(1);
}

}  // namespace segpath
