// Discrete MIS weights (N5): they sum to one, vanish where their technique cannot sample, and
// make the two-technique estimator of the toy integral unbiased.
#include <segpath/core/rng.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/weights/mis.hpp>

#include <vector>

#include "support/catch.hpp"

using namespace segpath;

TEST_CASE("MIS weights sum to one over random technique sets", "[weights]") {
  Pcg32 rng(11, 3);
  for (int trial = 0; trial < 2000; ++trial) {
    const std::size_t n = 1 + rng.next_u32() % 8;
    std::vector<double> terms(n);
    bool any = false;
    for (auto& t : terms) {
      // Some techniques have zero density at the sample; densities span many decades.
      t = rng.uniform<double>() < 0.25 ? 0.0 : std::exp(40.0 * (rng.uniform<double>() - 0.5));
      any = any || t > 0;
    }
    for (auto h : {MisHeuristic::balance, MisHeuristic::power}) {
      double sum = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const double w = mis_weight(terms[i], std::span<const double>(terms), h);
        if (terms[i] == 0) CHECK(w == 0);
        CHECK(w >= 0);
        sum += w;
      }
      if (any) CHECK(sum == Approx(1.0).margin(1e-6));
      else CHECK(sum == 0);
    }
  }
}

TEST_CASE("MIS weights never divide by zero or propagate NaN", "[weights]") {
  const double nan = std::nan("");
  const double inf = std::numeric_limits<double>::infinity();
  CHECK(mis_weight(0.0, 0.0) == 0.0);
  CHECK(mis_weight(nan, 1.0) == 0.0);
  CHECK(mis_weight(1.0, nan) == 1.0);
  CHECK(mis_weight(inf, 1.0) == 0.0);
  CHECK(mis_weight(2.0f, 2.0f, MisHeuristic::power) == 0.5f);
}

TEMPLATE_TEST_CASE("two-technique MIS of the toy integral int_0^1 x^2 dx = 1/3 is unbiased", "[weights][stat]", float,
                   double) {
  using T = TestType;
  // p1(x) = 1 (uniform), p2(x) = 2x (sampled as sqrt(u)), one sample of each per estimate.
  for (auto h : {MisHeuristic::balance, MisHeuristic::power}) {
    Pcg32 rng(2024, static_cast<std::uint64_t>(h));
    testing::RunningStats stats;
    for (int i = 0; i < 200000; ++i) {
      const T x1 = rng.uniform<T>();
      const T x2 = std::sqrt(rng.uniform<T>());
      T estimate = 0;
      estimate += mis_weight(T(1), T(2) * x1, h) * x1 * x1 / T(1);
      if (x2 > T(0)) estimate += mis_weight(T(2) * x2, T(1), h) * x2 * x2 / (T(2) * x2);
      stats.add(double(estimate));
    }
    const auto t = testing::student_t_test(stats, 1.0 / 3.0);
    INFO("heuristic " << int(h) << ": mean " << stats.mean() << " +- " << stats.standard_error());
    CHECK_FALSE(t.rejects(testing::sidak_alpha(0.01, 4)));
  }
}
