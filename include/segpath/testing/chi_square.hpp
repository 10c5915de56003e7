// Goodness-of-fit harness for samplers (SPEC 4): a 2D histogram of `sample` against the
// integral of `pdf` over each cell, tested by Pearson chi-square with pooling.
#pragma once

#include "segpath/core/rng.hpp"
#include "segpath/testing/integrate.hpp"
#include "segpath/testing/statistics.hpp"

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath::testing {

/// The histogram of chi_square_2d: the domain [lo, hi] split into cells_x * cells_y equal
/// cells. Pick cells so that most cells expect >= min_expected samples (samples / cells >> 5)
/// and `integration_panels` so that the per-cell integral of the pdf is accurate to well
/// below one expected sample's worth of noise: raise it for pdfs with jumps inside cells.
struct ChiSquare2DConfig {
  glm::dvec2 lo{0, 0}, hi{1, 1};
  int cells_x = 32, cells_y = 32;
  std::uint64_t samples = 1'000'000;
  int integration_panels = 4;  ///< Gauss-Legendre panels per cell per axis
  double min_expected = 5.0;
};

/// chi_square_2d's result. `outside_domain`: samples that were non-finite or outside
/// [lo, hi] (a hard failure, p = 0); `failed_samples`: nullopt samples (legal; they are
/// expected to match a pdf that integrates to the acceptance rate); `integral_of_pdf`: the
/// integral of the pdf over the domain, which should be ~1 or the acceptance rate.
struct ChiSquare2DReport : ChiSquareResult {
  std::uint64_t outside_domain = 0, failed_samples = 0;
  double integral_of_pdf = 0;
};

/// Tests H0: "sample(rng) draws points of the domain with density pdf" (N26-N34: every
/// sampler's `sample` against its own `pdf`). Draws config.samples points with
/// sample(segpath::Pcg32&) -> std::optional<glm::dvec2> from a generator
/// Pcg32(seed, 0), histograms them, and compares with the expected counts
/// samples * integral of pdf(glm::dvec2) over each cell (integrate_2d) by chi_square_test.
/// The pdf is w.r.t. the domain measure (e.g. d cos theta d phi = solid angle for
/// directions, see direction_to_cos_theta_phi). Points on the upper boundary hi belong to the
/// last cell. Also check `integral_of_pdf` against the acceptance rate: the chi-square
/// statistic sees a wrong normalisation only through the totals.
/// Test at alpha = sidak_alpha(family_alpha, sampler_suite_size) and print `table` on failure.
/// Throws std::invalid_argument for an empty domain, cells < 1, samples == 0 or panels < 1.
template <class SampleFn, class PdfFn>
ChiSquare2DReport chi_square_2d(SampleFn&& sample, PdfFn&& pdf, const ChiSquare2DConfig& config,
                                std::uint64_t seed) {
  if (!(config.hi.x > config.lo.x) || !(config.hi.y > config.lo.y) ||
      !std::isfinite(config.hi.x - config.lo.x) || !std::isfinite(config.hi.y - config.lo.y))
    throw std::invalid_argument(
        "segpath::testing::chi_square_2d: the domain [lo, hi] must be finite and non-empty");
  if (config.cells_x < 1 || config.cells_y < 1)
    throw std::invalid_argument(
        "segpath::testing::chi_square_2d: cells_x and cells_y must be >= 1, got " +
        std::to_string(config.cells_x) + " x " + std::to_string(config.cells_y));
  if (config.samples == 0)
    throw std::invalid_argument("segpath::testing::chi_square_2d: samples must be >= 1");
  detail::require_panels(config.integration_panels, "chi_square_2d");

  const auto nx = static_cast<std::size_t>(config.cells_x);
  const auto ny = static_cast<std::size_t>(config.cells_y);
  const glm::dvec2 extent = config.hi - config.lo;
  const glm::dvec2 cell_size =
      extent / glm::dvec2(static_cast<double>(nx), static_cast<double>(ny));

  std::vector<double> observed(nx * ny, 0.0);
  std::uint64_t outside = 0;
  std::uint64_t failed = 0;
  Pcg32 rng(seed, 0);
  for (std::uint64_t s = 0; s < config.samples; ++s) {
    const std::optional<glm::dvec2> p = std::invoke(sample, rng);
    if (!p) {
      ++failed;
      continue;
    }
    const glm::dvec2 q = *p;
    if (!(q.x >= config.lo.x && q.x <= config.hi.x && q.y >= config.lo.y && q.y <= config.hi.y)) {
      ++outside;
      continue;
    }
    const auto ix = std::min(
        nx - 1, static_cast<std::size_t>((q.x - config.lo.x) / extent.x * static_cast<double>(nx)));
    const auto iy = std::min(
        ny - 1, static_cast<std::size_t>((q.y - config.lo.y) / extent.y * static_cast<double>(ny)));
    observed[iy * nx + ix] += 1.0;
  }

  std::vector<double> expected(nx * ny, 0.0);
  const double n = static_cast<double>(config.samples);
  double total = 0;
  for (std::size_t iy = 0; iy < ny; ++iy) {
    for (std::size_t ix = 0; ix < nx; ++ix) {
      const glm::dvec2 lo =
          config.lo + cell_size * glm::dvec2(static_cast<double>(ix), static_cast<double>(iy));
      const glm::dvec2 hi = glm::dvec2(ix + 1 == nx ? config.hi.x : lo.x + cell_size.x,
                                       iy + 1 == ny ? config.hi.y : lo.y + cell_size.y);
      const double integral = integrate_2d(
          [&](const glm::dvec2& p) { return static_cast<double>(std::invoke(pdf, p)); }, lo, hi,
          config.integration_panels, config.integration_panels);
      total += integral;
      // A pdf that is negative or NaN somewhere is a failure of the pdf, not of the harness.
      expected[iy * nx + ix] = std::isfinite(integral) ? n * std::max(integral, 0.0) : 0.0;
    }
  }

  ChiSquare2DReport report;
  static_cast<ChiSquareResult&>(report) =
      detail::chi_square_test_labelled(observed, expected, config.min_expected, [&](std::size_t i) {
        const std::size_t ix = i % nx;
        const std::size_t iy = i / nx;
        const glm::dvec2 lo =
            config.lo + cell_size * glm::dvec2(static_cast<double>(ix), static_cast<double>(iy));
        return detail::format("cell (%.0f, %.0f) = [%.4g, %.4g]", static_cast<double>(ix),
                              static_cast<double>(iy), lo.x, lo.x + cell_size.x) +
               detail::format(" x [%.4g, %.4g]", lo.y, lo.y + cell_size.y);
      });
  report.outside_domain = outside;
  report.failed_samples = failed;
  report.integral_of_pdf = total;
  std::string header = detail::format(
      "chi_square_2d: %.0f samples, %.0f failed (nullopt), %.0f outside the domain, integral of "
      "pdf %.8g\n",
      n, static_cast<double>(failed), static_cast<double>(outside), total);
  if (!std::isfinite(total)) header += "  FAIL: the pdf integral is not finite\n";
  if (outside > 0) {
    report.p_value = 0;
    header += "  FAIL: samples outside the domain (or non-finite)\n";
  }
  if (!std::isfinite(total)) report.p_value = 0;
  report.table = header + report.table;
  return report;
}

/// A unit direction as (cos theta, phi) in [-1, 1] x [0, 2 pi), theta measured from +z. The
/// map preserves measure: a solid-angle pdf is also the pdf in d cos theta d phi.
[[nodiscard]] inline glm::dvec2 direction_to_cos_theta_phi(const glm::dvec3& d) noexcept {
  const double cos_theta = std::clamp(d.z, -1.0, 1.0);
  double phi = std::atan2(d.y, d.x);
  if (phi < 0) phi += 2.0 * std::numbers::pi;
  if (!(phi < 2.0 * std::numbers::pi)) phi = 0.0;  // -tiny + 2 pi rounds up to 2 pi
  return {cos_theta, phi};
}

/// The inverse of direction_to_cos_theta_phi.
[[nodiscard]] inline glm::dvec3 cos_theta_phi_to_direction(const glm::dvec2& p) noexcept {
  return detail::direction_from_cos_theta_phi(p.x, p.y);
}

/// The family significance of segpath's sampler chi-square suite: the probability that a
/// correct implementation fails any of its tests. Each test runs at
/// sidak_alpha(family_alpha, sampler_suite_size).
inline constexpr double family_alpha = 0.01;
/// An upper bound on the number of chi-square tests in segpath's sampler suite.
inline constexpr std::size_t sampler_suite_size = 64;

}  // namespace segpath::testing
