// Stochastic MIS (N9-N13): the weights over the drawn techniques sum to one and vanish where their
// technique cannot sample; the estimator (N12) is unbiased for the toy integrals, and a
// denominator that misses one drawn technique sample is rejected.
#include <array>
#include <cmath>
#include <limits>
#include <segpath/core/rng.hpp>
#include <segpath/core/spectrum.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/weights/smis.hpp>
#include <span>
#include <vector>

#include "support/catch.hpp"
#include "weights/toy_techniques.hpp"

using namespace segpath;
using namespace weights_test;

namespace {
/// [stat] test cases of this file that can fail falsely: 2 scalar types x 2 integrals.
constexpr std::size_t stat_tests = 4;
template <class T>
constexpr double sum_tolerance = sizeof(T) == sizeof(float) ? 1e-5 : 1e-6;
}  // namespace

TEMPLATE_TEST_CASE("SMIS weights sum to one over random technique sets", "[weights]", float,
                   double) {
  using T = TestType;
  Pcg32 rng(5, 17);
  for (int trial = 0; trial < 2000; ++trial) {
    // Technique samples are indices into a table of densities at the fixed sample x; some are 0,
    // and they span many decades.
    const std::size_t n = 1 + rng.next_u32() % 12;
    std::vector<T> density(n);
    std::vector<int> techniques(n);
    bool any = false;
    for (std::size_t j = 0; j < n; ++j) {
      techniques[j] = int(j);
      density[j] =
          rng.uniform<T>() < T(0.25) ? T(0) : T(std::exp(20.0 * (rng.uniform<double>() - 0.5)));
      any = any || density[j] > T(0);
    }
    const auto pdf = [&](const T& /*x*/, int t) { return density[std::size_t(t)]; };
    const T x = T(0.5);
    const std::span<const int> view(techniques);
    T sum = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const T w = smis_weight(i, x, view, pdf);
      if (density[i] == T(0)) CHECK(w == T(0));
      CHECK(w >= T(0));
      CHECK(w <= T(1) + T(sum_tolerance<T>));
      sum += w;
    }
    if (any)
      CHECK(double(sum) == Approx(1.0).margin(sum_tolerance<T>));
    else
      CHECK(sum == T(0));
  }
}

TEMPLATE_TEST_CASE("SMIS weights of the triangular family sum to one at any sample", "[weights]",
                   float, double) {
  using T = TestType;
  Pcg32 rng(6, 2);
  const auto pdf = [](T x, T t) { return triangle_pdf(x, t); };
  for (int trial = 0; trial < 500; ++trial) {
    std::array<T, 7> techniques{};
    const std::size_t n = 1 + rng.next_u32() % techniques.size();
    for (std::size_t j = 0; j < n; ++j) techniques[j] = rng.uniform<T>();
    const std::span<const T> drawn(techniques.data(), n);
    const T x = rng.uniform<T>();
    const T denominator = smis_denominator(x, drawn, pdf);
    T sum = 0;
    for (std::size_t i = 0; i < n; ++i) sum += smis_weight(i, x, drawn, pdf);
    if (denominator > T(0))
      CHECK(double(sum) == Approx(1.0).margin(sum_tolerance<T>));
    else
      CHECK(sum == T(0));  // x = 0: no triangle can produce it
  }
}

TEST_CASE("SMIS never divides by zero or propagates NaN", "[weights]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::array<double, 3> zeros{0.0, 0.0, 0.0};
  const auto table = [](const std::array<double, 3>& d) {
    return [d](double /*x*/, int t) { return d[std::size_t(t)]; };
  };
  const std::array<int, 3> techniques{0, 1, 2};
  CHECK(smis_denominator(0.0, techniques, table(zeros)) == 0.0);
  for (std::size_t i = 0; i < 3; ++i) CHECK(smis_weight(i, 0.0, techniques, table(zeros)) == 0.0);
  // A NaN or infinite density is a numerical failure and counts as 0.
  const std::array<double, 3> broken{nan, 2.0, inf};
  CHECK(smis_denominator(0.0, techniques, table(broken)) == 2.0);
  CHECK(smis_weight(0, 0.0, techniques, table(broken)) == 0.0);
  CHECK(smis_weight(1, 0.0, techniques, table(broken)) == 1.0);
  CHECK(smis_weight(2, 0.0, techniques, table(broken)) == 0.0);
  CHECK(smis_weight(1.0, 0.0) == 0.0);
  CHECK(smis_weight(1.0f, 4.0f) == 0.25f);
  CHECK(smis_contribution(1.0, 0.0) == 0.0);
  CHECK(smis_contribution(1.0, nan) == 0.0);
  CHECK(is_black(smis_contribution(Rgb<double>(1.0), 0.0)));
  // The estimate over no samples is zero; samples nobody can produce contribute zero.
  const std::array<double, 0> none{};
  CHECK(smis_estimate(
            none, techniques, [](double x) { return x; }, table(broken)) == 0.0);
  CHECK(smis_estimate(
            std::array<double, 2>{1.0, 2.0}, techniques, [](double x) { return x; },
            table(zeros)) == 0.0);
}

namespace {
/// The SMIS estimate (N12) with the last technique sample left out of every denominator: the
/// deliberately wrong variant the statistical tests must reject.
template <class Samples, class Techniques, class F, class Pdf>
auto smis_missing_last(const Samples& samples, const Techniques& techniques, F&& f, Pdf&& pdf) {
  const std::span<const typename Techniques::value_type> partial(techniques.data(),
                                                                 techniques.size() - 1);
  return smis_estimate(samples, partial, f, pdf);
}
}  // namespace

TEMPLATE_TEST_CASE("SMIS of int_0^1 x^2 dx over the techniques {p1 = 1, p2 = 2x} is unbiased",
                   "[weights][stat]", float, double) {
  using T = TestType;
  // t ~ uniform on {1, 2}; X ~ p_t: uniform for t = 1, sqrt(u) for t = 2 (N9).
  const auto pdf = [](T x, int t) { return t == 1 ? T(1) : T(2) * x; };
  const auto f = [](T x) { return square(x); };
  constexpr std::size_t n = 3;
  Pcg32 rng(77, 1);
  testing::RunningStats right, wrong;
  std::array<int, n> techniques{};
  std::array<T, n> samples{};
  for (int k = 0; k < 100000; ++k) {
    for (std::size_t j = 0; j < n; ++j) {
      techniques[j] = rng.uniform<T>() < T(0.5) ? 1 : 2;
      const T u = rng.uniform<T>();
      samples[j] = techniques[j] == 1 ? u : std::sqrt(u);
    }
    right.add(double(smis_estimate(samples, techniques, f, pdf)));
    wrong.add(double(smis_missing_last(samples, techniques, f, pdf)));
  }
  const double alpha = testing::sidak_alpha(0.01, stat_tests);
  const auto result = testing::student_t_test(right, 1.0 / 3.0);
  INFO("SMIS: mean " << right.mean() << " +- " << right.standard_error()
                     << ", p = " << result.p_value);
  CHECK_FALSE(result.rejects(alpha));
  const auto rejected = testing::student_t_test(wrong, 1.0 / 3.0);
  INFO("missing technique sample: mean " << wrong.mean() << " +- " << wrong.standard_error());
  CHECK(rejected.rejects(alpha));
}

TEMPLATE_TEST_CASE(
    "SMIS over a continuous triangular technique family is unbiased for a bumpy integral",
    "[weights][stat]", float, double) {
  using T = TestType;
  // t ~ p(t) = 2t, X ~ triangle with mode t (N9); the same t_j in every denominator (N10-N12).
  const auto pdf = [](T x, T t) { return triangle_pdf(x, t); };
  const auto f = [](T x) { return bumpy(x); };
  constexpr std::size_t n = 4;
  Pcg32 rng(78, 2);
  testing::RunningStats right, wrong;
  std::array<T, n> techniques{};
  std::array<T, n> samples{};
  for (int k = 0; k < 100000; ++k) {
    for (std::size_t j = 0; j < n; ++j) {
      techniques[j] = sample_technique(TechniquePrior::linear, rng.uniform<T>());
      samples[j] = sample_triangle(techniques[j], rng.uniform<T>());
    }
    right.add(double(smis_estimate(samples, techniques, f, pdf)));
    wrong.add(double(smis_missing_last(samples, techniques, f, pdf)));
  }
  const double alpha = testing::sidak_alpha(0.01, stat_tests);
  const auto result = testing::student_t_test(right, bumpy_integral);
  INFO("SMIS: mean " << right.mean() << " +- " << right.standard_error()
                     << ", p = " << result.p_value);
  CHECK_FALSE(result.rejects(alpha));
  const auto rejected = testing::student_t_test(wrong, bumpy_integral);
  INFO("missing technique sample: mean " << wrong.mean() << " +- " << wrong.standard_error());
  CHECK(rejected.rejects(alpha));
}
