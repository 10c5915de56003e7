// A Poisson-distributed count: how many light paths an iteration of segment filtering draws
// (algorithms/filtering/context.hpp), so that they form a Poisson process on path space.
//
// Small means by inversion (sequential search over the pmf); from 10 on, Hoermann's
// transformed rejection with squeeze (PTRS; W. Hoermann, "The transformed rejection method for
// generating Poisson random variables", Insurance: Mathematics and Economics 12, 1993), whose
// expected cost is bounded whatever the mean.
#pragma once

#include "segpath/core/rng.hpp"

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace segpath {

/// A draw of a Poisson(mean) count from `rng` (mean finite and >= 0; 0 gives 0).
template <UniformSource<double> R>
[[nodiscard]] std::uint64_t sample_poisson(double mean, R& rng) {
  if (!(mean >= 0) || !std::isfinite(mean))
    throw std::invalid_argument("segpath::sample_poisson: the mean must be finite and >= 0, got " + std::to_string(mean));
  if (mean == 0) return 0;
  if (mean < 10) {
    // Inversion: the smallest k with P(X <= k) > u. Past k = 200 the remaining mass is below
    // 1e-150 for these means, so the cap only guards against the sum's rounding.
    const double u = rng.template uniform<double>();
    double p = std::exp(-mean), cdf = p;
    std::uint64_t k = 0;
    while (u >= cdf && k < 200) {
      ++k;
      p *= mean / double(k);
      cdf += p;
    }
    return k;
  }
  // PTRS: a transformed uniform proposes k; most proposals are taken by the squeeze (us >= 0.07,
  // v <= v_r), the rest by comparing with the pmf's logarithm.
  const double root = std::sqrt(mean), log_mean = std::log(mean);
  const double b = 0.931 + 2.53 * root;
  const double a = -0.059 + 0.02483 * b;
  const double inverse_alpha = 1.1239 + 1.1328 / (b - 3.4);
  const double v_r = 0.9277 - 3.6224 / (b - 2);
  while (true) {
    const double u = rng.template uniform<double>() - 0.5;
    const double v = rng.template uniform<double>();
    const double us = 0.5 - std::abs(u);
    if (!(us > 0)) continue;  // u = -0.5: the transform is unbounded there
    const double k = std::floor((2 * a / us + b) * u + mean + 0.43);
    if (us >= 0.07 && v <= v_r) return std::uint64_t(k);  // k >= 0 in the squeeze region
    if (k < 0 || (us < 0.013 && v > us)) continue;
    if (std::log(v) + std::log(inverse_alpha) - std::log(a / (us * us) + b) <= -mean + k * log_mean - std::lgamma(k + 1))
      return std::uint64_t(k);
  }
}

}  // namespace segpath
