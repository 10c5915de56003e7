// Hypothesis tests for unit-testing Monte Carlo code (SPEC 4, use 3): Student and Welch
// t-tests, Pearson chi-square with pooling, Sidak correction, and the distributions they need.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <numeric>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath::testing {

/// Mean and variance of a sample, accumulated one value at a time (Welford 1962) in double
/// whatever the scalar type of the estimator under test, so that millions of float
/// estimates do not lose the mean to rounding. Non-finite values are accumulated as they
/// are: a NaN estimate makes the mean NaN and every test on it fail, which is the point.
class RunningStats {
 public:
  void add(double x) noexcept {
    ++n_;
    const double delta = x - mean_;
    mean_ += delta / static_cast<double>(n_);
    m2_ += delta * (x - mean_);
  }

  /// Combines two partial accumulations (Chan, Golub, LeVeque 1979), e.g. one per thread.
  void merge(const RunningStats& other) noexcept {
    if (other.n_ == 0) return;
    if (n_ == 0) {
      *this = other;
      return;
    }
    const double na = static_cast<double>(n_);
    const double nb = static_cast<double>(other.n_);
    const double n = na + nb;
    const double delta = other.mean_ - mean_;
    mean_ += delta * (nb / n);
    m2_ += other.m2_ + delta * delta * (na * nb / n);
    n_ += other.n_;
  }

  [[nodiscard]] std::uint64_t count() const noexcept { return n_; }
  [[nodiscard]] double mean() const noexcept { return mean_; }
  /// Unbiased sample variance (divides by n - 1); 0 for fewer than two values.
  [[nodiscard]] double variance() const noexcept {
    return n_ > 1 ? std::max(m2_, 0.0) / static_cast<double>(n_ - 1) : 0.0;
  }
  /// The estimated standard deviation of the mean, sqrt(variance / n).
  [[nodiscard]] double standard_error() const noexcept {
    return n_ > 0 ? std::sqrt(variance() / static_cast<double>(n_)) : 0.0;
  }

 private:
  std::uint64_t n_ = 0;
  double mean_ = 0;
  double m2_ = 0;
};

/// The outcome of a hypothesis test. `p_value` is the probability, under the null
/// hypothesis (e.g. "the estimator is unbiased"), of a statistic at least as extreme as the
/// one observed. A test rejects at significance `alpha` when p < alpha; alpha is the
/// false-failure rate you accept for a correct implementation (see sidak_alpha).
struct TestResult {
  double statistic = 0;
  double dof = 0;
  double p_value = 1;
  [[nodiscard]] bool rejects(double alpha) const noexcept { return p_value < alpha; }
};

namespace detail {

inline void require_positive_dof(double dof, const char* who) {
  if (!(dof > 0))
    throw std::invalid_argument(std::string("segpath::testing::") + who +
                                ": degrees of freedom must be > 0, got " + std::to_string(dof));
}

/// Continued fraction of the regularized incomplete beta function I_x(a, b), evaluated by
/// the modified Lentz method; converges fast for x < (a + 1) / (a + b + 2).
inline double incomplete_beta_fraction(double a, double b, double x) noexcept {
  constexpr double tiny = 1e-300;
  constexpr double eps = 1e-15;
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double f = d;
  for (int m = 1; m <= 10000; ++m) {
    const double dm = m;
    // Even step: d_{2m} = m (b - m) x / ((a + 2m - 1)(a + 2m)).
    double num = dm * (b - dm) * x / ((a + 2.0 * dm - 1.0) * (a + 2.0 * dm));
    d = 1.0 + num * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1.0 + num / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    f *= d * c;
    // Odd step: d_{2m+1} = -(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
    num = -(a + dm) * (a + b + dm) * x / ((a + 2.0 * dm) * (a + 2.0 * dm + 1.0));
    d = 1.0 + num * d;
    if (std::abs(d) < tiny) d = tiny;
    c = 1.0 + num / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double step = d * c;
    f *= step;
    if (std::abs(step - 1.0) < eps) break;
  }
  return f;
}

/// lgamma(a + b) - lgamma(a) for a >= b > 0 without the cancellation of the direct
/// difference at large a (Student t with ~10^9 dof): Stirling's series, whose truncation
/// error 1/(1680 a^7) is below rounding for a >= 100.
inline double log_gamma_ratio(double a, double b) noexcept {
  if (a < 100.0) return std::lgamma(a + b) - std::lgamma(a);
  const auto series = [](double z) {
    const double r = 1.0 / z, r2 = r * r;
    return r * (1.0 / 12.0 - r2 * (1.0 / 360.0 - r2 / 1260.0));
  };
  return (a - 0.5) * std::log1p(b / a) + b * std::log(a + b) - b + (series(a + b) - series(a));
}

/// Regularized incomplete beta function I_x(a, b) for a, b > 0, x in [0, 1], with y = 1 - x
/// passed separately so that callers keep its precision when x is near 1.
inline double regularized_beta(double a, double b, double x, double y) noexcept {
  if (!(x > 0)) return 0.0;
  if (!(y > 0)) return 1.0;
  const double log_x = x < 0.5 ? std::log(x) : std::log1p(-y);
  const double log_y = y < 0.5 ? std::log(y) : std::log1p(-x);
  const double log_beta =
      a >= b ? log_gamma_ratio(a, b) - std::lgamma(b) : log_gamma_ratio(b, a) - std::lgamma(a);
  const double front = std::exp(log_beta + a * log_x + b * log_y);
  if (x < (a + 1.0) / (a + b + 2.0)) return front * incomplete_beta_fraction(a, b, x) / a;
  return 1.0 - front * incomplete_beta_fraction(b, a, y) / b;
}

/// Regularized lower (P) and upper (Q) incomplete gamma functions, P + Q = 1: the power
/// series of P for x < a + 1, the Legendre continued fraction of Q otherwise, so the one
/// that is small is computed without cancellation.
struct IncompleteGamma {
  double p;
  double q;
};
inline IncompleteGamma incomplete_gamma(double a, double x) noexcept {
  if (!(x > 0)) return {0.0, 1.0};
  if (std::isinf(x)) return {1.0, 0.0};
  const double log_front = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a;
    double sum = term;
    for (int n = 1; n <= 100000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    const double p = std::min(1.0, sum * std::exp(log_front));
    return {p, 1.0 - p};
  }
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a;
  double c = 1.0 / tiny;
  double d = 1.0 / b;
  double h = d;
  for (int i = 1; i <= 100000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double step = d * c;
    h *= step;
    if (std::abs(step - 1.0) < 1e-16) break;
  }
  const double q = std::min(1.0, std::exp(log_front) * h);
  return {1.0 - q, q};
}

/// P(T > t) for t >= 0, Student t with `dof` degrees of freedom: I_{v/(v+t^2)}(v/2, 1/2) / 2.
inline double student_t_upper_tail(double t, double dof) noexcept {
  if (std::isinf(dof)) return 0.5 * std::erfc(t / std::numbers::sqrt2);
  const double t2 = t * t;
  if (std::isinf(t2)) return 0.0;
  return 0.5 * regularized_beta(0.5 * dof, 0.5, dof / (dof + t2), t2 / (dof + t2));
}

}  // namespace detail

/// Standard normal cumulative distribution function Phi(x).
[[nodiscard]] inline double normal_cdf(double x) noexcept {
  return 0.5 * std::erfc(-x / std::numbers::sqrt2);
}

/// Cumulative distribution function of Student's t with `dof` > 0 degrees of freedom (not
/// necessarily an integer, as Welch's test needs; infinity gives the normal), through the
/// regularized incomplete beta function. Throws std::invalid_argument for dof <= 0 or NaN.
[[nodiscard]] inline double student_t_cdf(double t, double dof) {
  detail::require_positive_dof(dof, "student_t_cdf");
  if (std::isnan(t)) return std::numeric_limits<double>::quiet_NaN();
  const double tail = detail::student_t_upper_tail(std::abs(t), dof);
  return t >= 0 ? 1.0 - tail : tail;
}

/// Cumulative distribution function of the chi-square distribution with `dof` > 0 degrees of
/// freedom: the regularized lower incomplete gamma function P(dof / 2, x / 2); 0 for x <= 0.
/// Throws std::invalid_argument for dof <= 0 or NaN.
[[nodiscard]] inline double chi_square_cdf(double x, double dof) {
  detail::require_positive_dof(dof, "chi_square_cdf");
  if (std::isnan(x)) return std::numeric_limits<double>::quiet_NaN();
  return detail::incomplete_gamma(0.5 * dof, 0.5 * x).p;
}

/// The per-test significance that keeps the probability of at least one false failure
/// among `tests` independent tests at `family_alpha` (Sidak): 1 - (1 - a)^(1/m).
/// How to pick alpha: decide how often a correct implementation may fail the whole suite
/// (e.g. family_alpha = 0.01 is one spurious red CI run in a hundred; with fixed seeds the
/// outcome is then deterministic, so this is the chance of having picked an unlucky seed),
/// bound the number of tests in the suite, and test each one at sidak_alpha(family, m).
/// Smaller alpha costs power: compensate with more samples, never with wider bounds.
/// Throws std::invalid_argument unless 0 < family_alpha < 1 and tests >= 1.
[[nodiscard]] inline double sidak_alpha(double family_alpha, std::size_t tests) {
  if (!(family_alpha > 0 && family_alpha < 1))
    throw std::invalid_argument(
        "segpath::testing::sidak_alpha: family_alpha must lie in (0, 1), got " +
        std::to_string(family_alpha));
  if (tests == 0)
    throw std::invalid_argument("segpath::testing::sidak_alpha: tests must be >= 1, got 0");
  return -std::expm1(std::log1p(-family_alpha) / static_cast<double>(tests));
}

/// Two-sided one-sample t-test of H0: "the population mean is `expected_mean`", e.g. "this
/// estimator is unbiased for the analytic value". statistic = (mean - expected) / standard
/// error, dof = n - 1.
/// Assumptions: independent, identically distributed values with finite variance; by the
/// central limit theorem the test is accurate for large n (use >= 10^3 values, more for
/// heavy-tailed estimators such as kernel or MIS estimators with rare large weights, whose
/// sample variance underestimates the true one at small n).
/// Degenerate samples fail rather than pass silently: fewer than two values give p = 0;
/// zero variance gives p = 1 if the mean equals `expected_mean` exactly and p = 0 otherwise
/// (statistic = +-inf). Non-finite means give p = 0.
[[nodiscard]] inline TestResult student_t_test(const RunningStats& sample, double expected_mean) {
  TestResult r;
  if (sample.count() < 2 || !std::isfinite(sample.mean()) || !std::isfinite(sample.variance())) {
    r.p_value = 0;
    return r;
  }
  r.dof = static_cast<double>(sample.count() - 1);
  const double diff = sample.mean() - expected_mean;
  const double se = sample.standard_error();
  if (se == 0) {
    r.statistic = diff == 0 ? 0.0 : std::copysign(std::numeric_limits<double>::infinity(), diff);
    r.p_value = diff == 0 ? 1.0 : 0.0;
    return r;
  }
  r.statistic = diff / se;
  r.p_value = std::min(1.0, 2.0 * detail::student_t_upper_tail(std::abs(r.statistic), r.dof));
  return r;
}

/// Two-sided Welch t-test of H0: "samples a and b have the same mean", without assuming equal
/// variances, e.g. "two estimators (MIS vs. single technique, propagation vs. naive
/// recursion) converge to the same value" when no closed form is known.
/// statistic = (mean_a - mean_b) / sqrt(s_a^2/n_a + s_b^2/n_b); dof by Welch-Satterthwaite,
/// (s_a^2/n_a + s_b^2/n_b)^2 / ((s_a^2/n_a)^2/(n_a-1) + (s_b^2/n_b)^2/(n_b-1)).
/// Assumptions as for student_t_test, plus independence of the two samples (draw them from
/// different seeds or streams). Degenerate inputs as for student_t_test: either sample with
/// fewer than two values gives p = 0; both variances zero give p = 1 only for equal means.
[[nodiscard]] inline TestResult welch_t_test(const RunningStats& a, const RunningStats& b) {
  TestResult r;
  if (a.count() < 2 || b.count() < 2 || !std::isfinite(a.mean()) || !std::isfinite(b.mean()) ||
      !std::isfinite(a.variance()) || !std::isfinite(b.variance())) {
    r.p_value = 0;
    return r;
  }
  const double va = a.variance() / static_cast<double>(a.count());
  const double vb = b.variance() / static_cast<double>(b.count());
  const double diff = a.mean() - b.mean();
  const double v = va + vb;
  if (v == 0) {
    r.statistic = diff == 0 ? 0.0 : std::copysign(std::numeric_limits<double>::infinity(), diff);
    r.p_value = diff == 0 ? 1.0 : 0.0;
    return r;
  }
  r.dof =
      v * v /
      (va * va / static_cast<double>(a.count() - 1) + vb * vb / static_cast<double>(b.count() - 1));
  r.statistic = diff / std::sqrt(v);
  r.p_value = std::min(1.0, 2.0 * detail::student_t_upper_tail(std::abs(r.statistic), r.dof));
  return r;
}

/// The result of chi_square_test. `cells`: the number of cells entering the statistic after
/// pooling (dof = cells - 1); `pooled_cells`: how many input cells were merged into pools;
/// `zero_expected_hits`: observations that fell into cells of expected count 0 (any is a
/// hard failure); `table`: a human-readable summary for failure messages
/// (INFO(result.table) in Catch2).
struct ChiSquareResult : TestResult {
  std::size_t cells = 0, pooled_cells = 0, zero_expected_hits = 0;
  std::string table;
};

namespace detail {

inline std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, fmt, a, b, c, d);
  return buffer;
}

/// chi_square_test with a caller-supplied description of cell i (chi_square_2d names cells
/// by their 2D index and bounds).
template <class LabelFn>
ChiSquareResult chi_square_test_labelled(std::span<const double> observed,
                                         std::span<const double> expected, double min_expected,
                                         LabelFn&& label) {
  if (observed.size() != expected.size())
    throw std::invalid_argument(
        "segpath::testing::chi_square_test: " + std::to_string(observed.size()) +
        " observed cells but " + std::to_string(expected.size()) + " expected");
  if (!(min_expected >= 0) || !std::isfinite(min_expected))
    throw std::invalid_argument(
        "segpath::testing::chi_square_test: min_expected must be finite and >= 0, got " +
        std::to_string(min_expected));
  for (std::size_t i = 0; i < observed.size(); ++i) {
    if (!(observed[i] >= 0) || !std::isfinite(observed[i]) || !(expected[i] >= 0) ||
        !std::isfinite(expected[i]))
      throw std::invalid_argument("segpath::testing::chi_square_test: cell " + std::to_string(i) +
                                  " has observed " + std::to_string(observed[i]) + ", expected " +
                                  std::to_string(expected[i]) + " (both must be finite and >= 0)");
  }

  ChiSquareResult r;
  std::vector<std::size_t> zero_cells;
  std::vector<std::size_t> order;
  double zero_hits = 0;
  for (std::size_t i = 0; i < observed.size(); ++i) {
    if (expected[i] == 0) {
      if (observed[i] > 0) {
        zero_hits += observed[i];
        zero_cells.push_back(i);
      }
    } else {
      order.push_back(i);
    }
  }
  r.zero_expected_hits = static_cast<std::size_t>(zero_hits);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return expected[a] < expected[b]; });

  // Groups of input cells (contiguous ranges of `order`): small cells are pooled in order of
  // increasing expectation until a pool reaches min_expected; a final pool that stays below
  // it joins the next larger group (or the previous pool when there is none).
  struct Group {
    std::size_t begin, end;
    double observed, expected;
  };
  std::vector<Group> groups;
  std::size_t i = 0;
  while (i < order.size() && expected[order[i]] < min_expected) {
    Group g{i, i, 0, 0};
    while (i < order.size() && expected[order[i]] < min_expected && g.expected < min_expected) {
      g.observed += observed[order[i]];
      g.expected += expected[order[i]];
      g.end = ++i;
    }
    groups.push_back(g);
  }
  const std::size_t pools = groups.size();
  for (; i < order.size(); ++i)
    groups.push_back(Group{i, i + 1, observed[order[i]], expected[order[i]]});
  if (pools > 0 && groups.size() > 1 && groups[pools - 1].expected < min_expected) {
    const std::size_t last = pools - 1;
    Group& target = groups[last + 1 < groups.size() ? last + 1 : last - 1];
    target.begin = std::min(target.begin, groups[last].begin);
    target.end = std::max(target.end, groups[last].end);
    target.observed += groups[last].observed;
    target.expected += groups[last].expected;
    groups.erase(groups.begin() + static_cast<std::ptrdiff_t>(last));
  }
  for (const Group& g : groups)
    if (g.end - g.begin > 1) r.pooled_cells += g.end - g.begin;
  r.cells = groups.size();
  r.dof = r.cells > 0 ? static_cast<double>(r.cells - 1) : 0.0;

  struct Contribution {
    double value;
    std::size_t group;
  };
  std::vector<Contribution> contributions;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const double diff = groups[g].observed - groups[g].expected;
    const double c = diff * diff / groups[g].expected;
    r.statistic += c;
    contributions.push_back({c, g});
  }

  std::string verdict;
  if (r.zero_expected_hits > 0) {
    r.p_value = 0;
    verdict = "FAIL: observations in cells of expected count 0";
  } else if (r.cells < 2) {
    r.p_value = 0;
    verdict = "FAIL: fewer than 2 cells after pooling, no test possible (add samples or cells)";
  } else {
    r.p_value = detail::incomplete_gamma(0.5 * r.dof, 0.5 * r.statistic).q;
    verdict = "ok";
  }

  const double total_observed = std::accumulate(observed.begin(), observed.end(), 0.0);
  const double total_expected = std::accumulate(expected.begin(), expected.end(), 0.0);
  std::string& t = r.table;
  t += "chi-square goodness of fit: " + verdict + "\n";
  t += format("  statistic %.6g, dof %.0f, p-value %.6g\n", r.statistic, r.dof, r.p_value);
  t += format(
      "  input cells %.0f, cells after pooling %.0f, input cells pooled %.0f (min expected %g)\n",
      static_cast<double>(observed.size()), static_cast<double>(r.cells),
      static_cast<double>(r.pooled_cells), min_expected);
  t += format("  total observed %.10g, total expected %.10g\n", total_observed, total_expected);
  if (!zero_cells.empty()) {
    t += format("  %.0f observations in %.0f zero-expected cells:\n", zero_hits,
                static_cast<double>(zero_cells.size()));
    for (std::size_t k = 0; k < std::min<std::size_t>(zero_cells.size(), 10); ++k)
      t += "    " + label(zero_cells[k]) + format(": observed %.10g\n", observed[zero_cells[k]]);
  }
  std::sort(contributions.begin(), contributions.end(),
            [](const Contribution& a, const Contribution& b) { return a.value > b.value; });
  const std::size_t shown = std::min<std::size_t>(contributions.size(), 10);
  if (shown > 0) t += "  largest contributions (observed / expected -> (O-E)^2/E):\n";
  for (std::size_t k = 0; k < shown; ++k) {
    const Group& g = groups[contributions[k].group];
    const std::size_t members = g.end - g.begin;
    std::string name = label(order[g.begin]);
    if (members > 1) name += format(" + %.0f more pooled", static_cast<double>(members - 1));
    t += "    " + name +
         format(": %.10g / %.6g -> %.4g\n", g.observed, g.expected, contributions[k].value);
  }
  return r;
}

}  // namespace detail

/// Pearson chi-square goodness-of-fit test of H0: "the counts `observed` were drawn from the
/// multinomial distribution with cell means `expected`", e.g. a histogram of a sampler's
/// output against n times the integral of its pdf over each cell (see chi_square_2d).
/// statistic = sum (O - E)^2 / E over the cells, dof = cells - 1 (the totals of observed and
/// expected should agree; a mismatch, e.g. a pdf that does not integrate to what the sampler
/// produces, inflates the statistic and is detected).
/// Assumptions: independent samples; the chi-square approximation needs E >= ~5 per cell, so
/// cells with expected count below `min_expected` are pooled: sorted by expected count and
/// merged, smallest first, until each pool reaches min_expected (a last pool still below it
/// joins the next larger cell). Cells with expected 0 and no observations are ignored; any
/// observation in a cell with expected 0 is a hard failure (p = 0) whatever the statistic,
/// since it cannot happen under H0. Fewer than two cells after pooling also give p = 0.
/// How to pick alpha: a sampler suite runs many such tests, so use sidak_alpha (chi_square.hpp
/// has the value segpath uses). Throws std::invalid_argument on mismatched sizes and on
/// negative or non-finite counts.
[[nodiscard]] inline ChiSquareResult chi_square_test(std::span<const double> observed,
                                                     std::span<const double> expected,
                                                     double min_expected = 5.0) {
  return detail::chi_square_test_labelled(
      observed, expected, min_expected, [](std::size_t i) { return "cell " + std::to_string(i); });
}

}  // namespace segpath::testing
