// The Poisson count (core/poisson.hpp): its pmf by a chi-square test on both of its methods
// (inversion below a mean of 10, transformed rejection from 10 on), its mean and variance, and
// the bad means it refuses.
#include <segpath/core/poisson.hpp>
#include <segpath/testing/statistics.hpp>

#include "support/catch.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

using namespace segpath;

namespace {

/// P(X = k) for X ~ Poisson(mean).
double poisson_pmf(double mean, double k) { return std::exp(-mean + k * std::log(mean) - std::lgamma(k + 1)); }

}  // namespace

TEST_CASE("sample_poisson refuses a mean that is negative or not finite, and draws 0 at mean 0", "[core]") {
  Pcg32 rng(1, 2);
  CHECK_THROWS_AS(sample_poisson(-1.0, rng), std::invalid_argument);
  CHECK_THROWS_AS(sample_poisson(std::numeric_limits<double>::quiet_NaN(), rng), std::invalid_argument);
  CHECK_THROWS_AS(sample_poisson(std::numeric_limits<double>::infinity(), rng), std::invalid_argument);
  for (int i = 0; i < 10; ++i) CHECK(sample_poisson(0.0, rng) == 0);
}

// Every mean is tested at alpha = 1e-4 / 10 (Sidak over the ten means; fixed seeds, so a pass
// is reproducible). Cells: every count from mean - 8 sd to mean + 8 sd, and a cell for each
// tail; chi_square_test pools cells expected to hold fewer than 5 draws. The rejection method's
// small means get ten times the draws: a wrong offset in its transform shows there and fades as
// the mean grows (power, checked: with the offset 0.43 moved to 0.93 the chi-square and the mean
// fail at 10, 14.5 and 30; with 200,000 draws only the chi-square at 14.5 failed. At 200 the
// shift's mean is +0.3 standard errors of 2 M draws: no test sees it, and it does no harm).
TEST_CASE("sample_poisson draws counts with the Poisson pmf, mean and variance, by inversion and by rejection", "[core]") {
  const double alpha = testing::sidak_alpha(1e-4, 10);
  for (const double mean : {0.05, 0.7, 3.0, 9.9, 10.0, 14.5, 30.0, 61.0, 1000.0, 262144.0}) {
    INFO("mean " << mean);
    Pcg32 rng = Pcg32::for_sample(7, std::uint64_t(mean * 1000), 3);
    const std::size_t draws = mean >= 10 && mean <= 30 ? 2000000 : 200000;
    const double sd = std::sqrt(mean);
    const auto lo = std::uint64_t(std::max(0.0, std::floor(mean - 8 * sd)));
    const auto hi = std::uint64_t(std::ceil(mean + 8 * sd + 8));
    std::vector<double> observed(hi - lo + 3, 0.0), expected(hi - lo + 3, 0.0);  // [0]: below lo, [last]: above hi
    testing::RunningStats stats;
    for (std::size_t i = 0; i < draws; ++i) {
      const std::uint64_t k = sample_poisson(mean, rng);
      stats.add(double(k));
      observed[k < lo ? 0 : k > hi ? observed.size() - 1 : std::size_t(k - lo + 1)] += 1;
    }
    double inside = 0;
    for (std::uint64_t k = lo; k <= hi; ++k) inside += expected[std::size_t(k - lo + 1)] = draws * poisson_pmf(mean, double(k));
    for (std::uint64_t k = 0; k < lo; ++k) expected[0] += draws * poisson_pmf(mean, double(k));
    expected.back() = std::max(0.0, draws - inside - expected[0]);
    const auto result = testing::chi_square_test(observed, expected);
    INFO("chi-square " << result.statistic << " on " << result.dof << " degrees of freedom, p " << result.p_value);
    CHECK_FALSE(result.rejects(alpha));
    // Mean and variance both equal `mean`: within 5 standard errors (the variance's standard
    // error is about sqrt((2 mean^2 + mean) / draws) for a Poisson variable).
    CHECK(std::abs(stats.mean() - mean) < 5 * std::sqrt(mean / double(draws)));
    CHECK(std::abs(stats.variance() - mean) < 5 * std::sqrt((2 * mean * mean + mean) / double(draws)));
  }
}

TEST_CASE("sample_poisson is a function of its generator's stream", "[core]") {
  for (const double mean : {4.0, 400.0}) {
    Pcg32 a(11, 5), b(11, 5);
    std::vector<std::uint64_t> x, y;
    for (int i = 0; i < 100; ++i) x.push_back(sample_poisson(mean, a)), y.push_back(sample_poisson(mean, b));
    CHECK(x == y);
    Pcg32 c(11, 6);
    std::vector<std::uint64_t> z;
    for (int i = 0; i < 100; ++i) z.push_back(sample_poisson(mean, c));
    CHECK(z != x);
  }
}
