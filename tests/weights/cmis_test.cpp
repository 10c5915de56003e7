// Continuous MIS (N6-N8): the balance weight density integrates to one over the technique space,
// and the one-sample estimator f / p(X) is unbiased; a marginal over half the space is rejected.
#include <cmath>
#include <limits>
#include <segpath/core/rng.hpp>
#include <segpath/core/spectrum.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/weights/cmis.hpp>

#include "support/catch.hpp"
#include "weights/toy_techniques.hpp"

using namespace segpath;
using namespace weights_test;

namespace {
/// [stat] test cases of this file that can fail falsely: 2 scalar types x 2 technique priors.
constexpr std::size_t stat_tests = 4;
template <class T>
constexpr double sum_tolerance = sizeof(T) == sizeof(float) ? 1e-5 : 1e-6;
}  // namespace

TEMPLATE_TEST_CASE("CMIS weight density integrates to one over the technique space", "[weights]",
                   float, double) {
  using T = TestType;
  for (const auto prior : {TechniquePrior::uniform, TechniquePrior::linear}) {
    const auto p_t = [prior](T t) { return technique_pdf(prior, t); };
    const auto p_x_given_t = [](T x, T t) { return triangle_pdf(x, t); };
    const auto marginal = [prior](T x) { return triangle_marginal(prior, x); };
    for (const double x_d : {0.03, 0.2, 0.5, 0.77, 0.97}) {
      const T x = T(x_d);
      const auto w = [&](double t) {
        return double(cmis_weight(T(t), x, p_t, p_x_given_t, marginal));
      };
      // The weight has a kink at t = x: integrate the two smooth pieces separately.
      const double integral =
          testing::integrate_1d(w, 0.0, double(x)) + testing::integrate_1d(w, double(x), 1.0);
      INFO("prior " << int(prior) << ", x = " << x_d);
      CHECK(integral == Approx(1.0).margin(sum_tolerance<T>));
      // Outside the technique space p(t) = 0, so the weight density is 0 there.
      CHECK(cmis_weight(T(-0.5), x, p_t, p_x_given_t, marginal) == T(0));
      CHECK(cmis_weight(T(1.5), x, p_t, p_x_given_t, marginal) == T(0));
    }
    // Where p(x | t) = 0 (the ends of the triangle) the weight is 0, and the marginal is 0 too.
    CHECK(cmis_weight(T(0.4), T(0), p_t, p_x_given_t, marginal) == T(0));
    CHECK(cmis_weight(T(0.4), T(1), p_t, p_x_given_t, marginal) == T(0));
  }
  // A marginal that misses half of the technique space gives weights that do not integrate to 1.
  const T x = T(0.77);
  const auto w_half = [&](double t) {
    return double(
        cmis_weight(T(technique_pdf(TechniquePrior::uniform, T(t)) * triangle_pdf(x, T(t))),
                    triangle_half_marginal(x)));
  };
  const double half =
      testing::integrate_1d(w_half, 0.0, double(x)) + testing::integrate_1d(w_half, double(x), 1.0);
  CHECK(std::abs(half - 1.0) > 0.5);
}

TEMPLATE_TEST_CASE("CMIS general estimator with the balance weight equals f / p(X)", "[weights]",
                   float, double) {
  using T = TestType;
  Pcg32 rng(7, 1);
  for (const auto prior : {TechniquePrior::uniform, TechniquePrior::linear}) {
    const auto p_t = [prior](T t) { return technique_pdf(prior, t); };
    const auto p_x_given_t = [](T x, T t) { return triangle_pdf(x, t); };
    const auto marginal = [prior](T x) { return triangle_marginal(prior, x); };
    for (int i = 0; i < 200; ++i) {
      const T t = sample_technique(prior, rng.uniform<T>());
      const T x = sample_triangle(t, rng.uniform<T>());
      const T joint = p_t(t) * p_x_given_t(x, t);
      const T general =
          cmis_estimate(bumpy(x), cmis_weight(t, x, p_t, p_x_given_t, marginal), joint);
      const T balance = cmis_balance_estimate(
          x, [](T y) { return bumpy(y); }, marginal);
      CHECK(general == Approx(balance).epsilon(sizeof(T) == sizeof(float) ? 1e-5 : 1e-12));
    }
  }
}

TEST_CASE("CMIS weights and estimates never divide by zero or propagate NaN", "[weights]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  CHECK(cmis_weight(0.0, 0.0) == 0.0);
  CHECK(cmis_weight(1.0, 0.0) == 0.0);
  CHECK(cmis_weight(nan, 1.0) == 0.0);
  CHECK(cmis_weight(1.0, nan) == 0.0);
  CHECK(cmis_weight(inf, 1.0) == 0.0);
  CHECK(cmis_weight(1.0, inf) == 0.0);
  CHECK(cmis_weight(0.5f, 2.0f) == 0.25f);
  CHECK(cmis_balance_estimate(3.0, 0.0) == 0.0);
  CHECK(cmis_balance_estimate(3.0, nan) == 0.0);
  CHECK(cmis_balance_estimate(3.0, 2.0) == 1.5);
  CHECK(cmis_estimate(2.0, 0.5, 0.25) == 4.0);
  CHECK(cmis_estimate(2.0, 0.5, 0.0) == 0.0);
  CHECK(is_black(cmis_balance_estimate(Rgb<float>(1.0f), 0.0f)));
  CHECK(cmis_balance_estimate(Rgb<float>(1.0f, 2.0f, 4.0f), 2.0f) == Rgb<float>(0.5f, 1.0f, 2.0f));
}

TEMPLATE_TEST_CASE(
    "one-sample CMIS f / p(X) of a bumpy integral is unbiased; a half marginal is not",
    "[weights][stat]", float, double) {
  using T = TestType;
  const double alpha = testing::sidak_alpha(0.01, stat_tests);
  for (const auto prior : {TechniquePrior::uniform, TechniquePrior::linear}) {
    const auto f = [](T x) { return bumpy(x); };
    const auto marginal = [prior](T x) { return triangle_marginal(prior, x); };
    Pcg32 rng(4242, 10 + static_cast<std::uint64_t>(prior));
    testing::RunningStats right, wrong;
    for (int i = 0; i < 200000; ++i) {
      // (N6) with t ~ p(t), X ~ p(X | t): the balance weight leaves f(X) / p(X) whichever t drew X.
      const T t = sample_technique(prior, rng.uniform<T>());
      const T x = sample_triangle(t, rng.uniform<T>());
      right.add(double(cmis_balance_estimate(x, f, marginal)));
      if (prior == TechniquePrior::uniform)
        wrong.add(
            double(cmis_balance_estimate(x, f, [](T y) { return triangle_half_marginal(y); })));
    }
    const auto result = testing::student_t_test(right, bumpy_integral);
    INFO("prior " << int(prior) << ": mean " << right.mean() << " +- " << right.standard_error()
                  << ", expected " << bumpy_integral << ", p = " << result.p_value);
    CHECK_FALSE(result.rejects(alpha));
    if (prior == TechniquePrior::uniform) {
      const auto rejected = testing::student_t_test(wrong, bumpy_integral);
      INFO("half marginal: mean " << wrong.mean() << " +- " << wrong.standard_error());
      CHECK(rejected.rejects(alpha));
    }
  }
}
