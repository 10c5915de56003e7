#include <segpath/core/rng.hpp>
#include <segpath/testing/statistics.hpp>

#include "support/catch.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

using namespace segpath;
using namespace segpath::testing;

TEST_CASE("RunningStats matches the two-pass mean and variance, and merges", "[testing]") {
  const std::vector<double> xs{1.5, -2.0, 3.25, 1e3, 7.0, 0.125, -4.5};
  RunningStats all;
  for (double x : xs) all.add(x);
  double mean = 0;
  for (double x : xs) mean += x;
  mean /= double(xs.size());
  double ss = 0;
  for (double x : xs) ss += (x - mean) * (x - mean);
  CHECK(all.count() == xs.size());
  CHECK(all.mean() == Approx(mean).epsilon(1e-14));
  CHECK(all.variance() == Approx(ss / double(xs.size() - 1)).epsilon(1e-14));
  CHECK(all.standard_error() == Approx(std::sqrt(ss / double(xs.size() - 1) / double(xs.size()))));

  RunningStats a, b, empty;
  for (std::size_t i = 0; i < 3; ++i) a.add(xs[i]);
  for (std::size_t i = 3; i < xs.size(); ++i) b.add(xs[i]);
  a.merge(empty);
  a.merge(b);
  CHECK(a.count() == all.count());
  CHECK(a.mean() == Approx(all.mean()).epsilon(1e-14));
  CHECK(a.variance() == Approx(all.variance()).epsilon(1e-14));
  empty.merge(all);
  CHECK(empty.mean() == all.mean());
  CHECK(RunningStats{}.variance() == 0);
}

TEST_CASE("distribution functions match tabulated values", "[testing]") {
  CHECK(normal_cdf(0.0) == 0.5);
  CHECK(normal_cdf(1.959963984540054) == Approx(0.975).epsilon(1e-12));
  CHECK(normal_cdf(-1.0) == Approx(0.15865525393145705).epsilon(1e-12));

  // Student t: tabulated quantiles and the closed forms for 1 (Cauchy) and 2 dof.
  CHECK(student_t_cdf(2.0, 10) == Approx(0.963306).margin(1e-6));
  CHECK(student_t_cdf(-2.0, 10) == Approx(1 - 0.963306).margin(1e-6));
  CHECK(student_t_cdf(0.0, 3) == 0.5);
  CHECK(student_t_cdf(2.228139, 10) == Approx(0.975).margin(1e-6));
  CHECK(student_t_cdf(12.7062, 1) == Approx(0.975).margin(1e-6));
  CHECK(student_t_cdf(2.0, 1) ==
        Approx(0.5 + std::atan(2.0) / 3.14159265358979323846).epsilon(1e-12));
  CHECK(student_t_cdf(1.5, 2) == Approx(0.5 + 1.5 / (2 * std::sqrt(2 + 1.5 * 1.5))).epsilon(1e-12));
  CHECK(student_t_cdf(1.3, 1e9) == Approx(normal_cdf(1.3)).epsilon(1e-8));
  CHECK(student_t_cdf(1.3, std::numeric_limits<double>::infinity()) ==
        Approx(normal_cdf(1.3)).epsilon(1e-14));
  CHECK(student_t_cdf(2.5, 7.5) > student_t_cdf(2.5, 7.0));  // non-integer dof (Welch)
  CHECK(student_t_cdf(std::numeric_limits<double>::infinity(), 4) == 1.0);

  // Chi-square: tabulated 95% quantiles, closed forms for 2 dof (exponential) and 1 dof.
  CHECK(chi_square_cdf(3.84146, 1) == Approx(0.95).margin(1e-5));
  CHECK(chi_square_cdf(18.307, 10) == Approx(0.95).margin(1e-5));
  CHECK(chi_square_cdf(124.342, 100) == Approx(0.95).margin(1e-5));
  CHECK(chi_square_cdf(3.0, 2) == Approx(1 - std::exp(-1.5)).epsilon(1e-13));
  CHECK(chi_square_cdf(0.5, 1) == Approx(std::erf(std::sqrt(0.25))).epsilon(1e-13));
  CHECK(chi_square_cdf(0.0, 5) == 0.0);
  CHECK(chi_square_cdf(-1.0, 5) == 0.0);
  CHECK(chi_square_cdf(1e4, 5) == 1.0);

  CHECK_THROWS_AS(student_t_cdf(1.0, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(chi_square_cdf(1.0, -1.0), std::invalid_argument);
  CHECK_THROWS_AS(chi_square_cdf(1.0, std::nan("")), std::invalid_argument);
}

TEST_CASE("sidak_alpha keeps the family-wise error rate", "[testing]") {
  CHECK(sidak_alpha(0.05, 1) == Approx(0.05).epsilon(1e-14));
  const double a = sidak_alpha(0.01, 64);
  CHECK(1 - std::pow(1 - a, 64) == Approx(0.01).epsilon(1e-12));
  CHECK(a < 0.01 / 64 * 1.01);
  CHECK_THROWS_AS(sidak_alpha(0.0, 3), std::invalid_argument);
  CHECK_THROWS_AS(sidak_alpha(1.0, 3), std::invalid_argument);
  CHECK_THROWS_AS(sidak_alpha(0.01, 0), std::invalid_argument);
}

TEST_CASE("Student t-test accepts an unbiased sample and rejects a biased hypothesis",
          "[testing][stat]") {
  Pcg32 rng(1234, 5);
  RunningStats s;
  for (int i = 0; i < 100000; ++i) s.add(rng.uniform<double>());
  const TestResult ok = student_t_test(s, 0.5);
  INFO("t = " << ok.statistic << ", p = " << ok.p_value);
  CHECK(ok.dof == 99999);
  CHECK_FALSE(ok.rejects(1e-3));
  // The standard error is 1/sqrt(12 * 10^5) = 9.1e-4: an offset of 0.005 is 5.5 sigma.
  const TestResult bad = student_t_test(s, 0.505);
  CHECK(bad.rejects(1e-3));
  CHECK(bad.statistic < 0);
  // The two-sided p-value is symmetric and matches the CDF.
  CHECK(bad.p_value == Approx(2 * student_t_cdf(bad.statistic, bad.dof)).epsilon(1e-9));
}

TEST_CASE("t-tests fail on degenerate samples instead of passing silently", "[testing]") {
  RunningStats one;
  one.add(1.0);
  CHECK(student_t_test(one, 1.0).rejects(1e-9));
  RunningStats constant;
  for (int i = 0; i < 10; ++i) constant.add(2.0);
  CHECK_FALSE(student_t_test(constant, 2.0).rejects(0.5));
  CHECK(student_t_test(constant, 2.0 + 1e-12).rejects(1e-9));
  RunningStats nan = constant;
  nan.add(std::nan(""));
  CHECK(student_t_test(nan, 2.0).rejects(1e-9));
  CHECK(welch_t_test(one, constant).rejects(1e-9));
  CHECK_FALSE(welch_t_test(constant, constant).rejects(0.5));
}

TEST_CASE("Welch t-test: equal means with unequal variances accepted, different means rejected",
          "[testing][stat]") {
  Pcg32 ra(7, 1), rb(7, 2), rc(7, 3);
  RunningStats a, b, c;
  // a: uniform on [0, 1] (variance 1/12), b: uniform on [0.25, 0.75] (variance 1/48), both
  // mean 0.5, different sizes; c: mean 0.51.
  for (int i = 0; i < 60000; ++i) a.add(ra.uniform<double>());
  for (int i = 0; i < 20000; ++i) b.add(0.25 + 0.5 * rb.uniform<double>());
  for (int i = 0; i < 20000; ++i) c.add(0.26 + 0.5 * rc.uniform<double>());

  const TestResult same = welch_t_test(a, b);
  INFO("t = " << same.statistic << ", dof = " << same.dof << ", p = " << same.p_value);
  CHECK_FALSE(same.rejects(1e-3));
  // Welch-Satterthwaite dof lies between min(n) - 1 and n_a + n_b - 2.
  const double va = (1.0 / 12) / 60000, vb = (1.0 / 48) / 20000;
  const double dof = (va + vb) * (va + vb) / (va * va / 59999 + vb * vb / 19999);
  CHECK(same.dof == Approx(dof).epsilon(0.02));
  CHECK(same.dof > 19999);
  CHECK(same.dof < 79998);

  const TestResult different = welch_t_test(a, c);
  CHECK(different.rejects(1e-3));
  CHECK(different.statistic < 0);
}

TEST_CASE("chi-square test: statistic, pooling and zero-expected hits", "[testing]") {
  SECTION("statistic and dof of an exact computation") {
    const std::vector<double> obs{10, 20, 30, 40};
    const std::vector<double> exp{25, 25, 25, 25};
    const ChiSquareResult r = chi_square_test(obs, exp);
    CHECK(r.statistic == Approx(225.0 / 25 + 25.0 / 25 + 25.0 / 25 + 225.0 / 25));
    CHECK(r.dof == 3);
    CHECK(r.cells == 4);
    CHECK(r.pooled_cells == 0);
    CHECK(r.p_value == Approx(1 - chi_square_cdf(20.0, 3)).epsilon(1e-10));
    CHECK(r.rejects(1e-3));
    CHECK(r.table.find("statistic 20") != std::string::npos);
  }
  SECTION("small cells are pooled in order of increasing expectation") {
    // Sorted expectations 1, 1, 2, 3 | 4 | 50, 50: the first pool closes at 7 >= 5; the
    // second holds only the 4, stays below 5 and joins the next larger cell (the first 50).
    const std::vector<double> exp{4, 1, 50, 2, 3, 1, 50};
    const std::vector<double> obs{3, 1, 52, 2, 4, 2, 45};
    const ChiSquareResult r = chi_square_test(obs, exp, 5.0);
    CHECK(r.cells == 3);
    CHECK(r.pooled_cells == 6);
    CHECK(r.dof == 2);
    const double pool = (9 - 7.0) * (9 - 7.0) / 7.0;
    const double joined = (55 - 54.0) * (55 - 54.0) / 54.0;
    const double large = (45 - 50.0) * (45 - 50.0) / 50.0;
    CHECK(r.statistic == Approx(pool + joined + large));
    // Without pooling every cell counts on its own.
    const ChiSquareResult unpooled = chi_square_test(obs, exp, 0.0);
    CHECK(unpooled.cells == 7);
    CHECK(unpooled.pooled_cells == 0);
  }
  SECTION("a trailing small pool joins the previous pool when there is no large cell") {
    const std::vector<double> exp{3, 3, 3};
    const std::vector<double> obs{3, 3, 3};
    const ChiSquareResult r = chi_square_test(obs, exp, 5.0);
    CHECK(r.cells == 1);
    CHECK(r.pooled_cells == 3);
    CHECK(r.rejects(1e-9));  // one cell: no test possible, reported as a failure
  }
  SECTION("an observation where nothing is expected is a hard failure") {
    const std::vector<double> exp{100, 100, 0, 100, 0};
    std::vector<double> obs{100, 100, 0, 100, 0};
    CHECK_FALSE(chi_square_test(obs, exp).rejects(0.5));
    obs[2] = 1;
    const ChiSquareResult r = chi_square_test(obs, exp);
    CHECK(r.zero_expected_hits == 1);
    CHECK(r.p_value == 0);
    CHECK(r.table.find("zero-expected") != std::string::npos);
    INFO(r.table);
  }
  SECTION("bad input") {
    const std::vector<double> three{1, 2, 3}, two{1, 2}, negative{1, -2, 3};
    CHECK_THROWS_AS(chi_square_test(three, two), std::invalid_argument);
    CHECK_THROWS_AS(chi_square_test(negative, three), std::invalid_argument);
    CHECK_THROWS_AS(chi_square_test(three, negative), std::invalid_argument);
  }
}

namespace {
// Histogram of n samples of p(x) = 2x on [0, 1] (x = sqrt(u)), and expected counts of a
// candidate density with CDF `cdf`.
template <class Cdf>
ChiSquareResult linear_density_test(Cdf&& cdf) {
  constexpr int cells = 50;
  constexpr int n = 100000;
  Pcg32 rng(99, 0);
  std::vector<double> obs(cells, 0.0), exp(cells, 0.0);
  for (int i = 0; i < n; ++i) {
    const double x = std::sqrt(rng.uniform<double>());
    obs[std::min(cells - 1, int(x * cells))] += 1;
  }
  for (int c = 0; c < cells; ++c) exp[c] = n * (cdf((c + 1.0) / cells) - cdf(double(c) / cells));
  return chi_square_test(obs, exp);
}
}  // namespace

TEST_CASE("chi-square test accepts a correct histogram and rejects a wrong one",
          "[testing][stat]") {
  const ChiSquareResult right = linear_density_test([](double x) { return x * x; });
  INFO(right.table);
  CHECK_FALSE(right.rejects(1e-3));
  CHECK(right.pooled_cells == 0);
  const ChiSquareResult wrong = linear_density_test([](double x) { return x; });
  CHECK(wrong.rejects(1e-3));
}
