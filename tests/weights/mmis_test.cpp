// Marginal MIS (N38-N42): the balance weights of all technique samples of all families sum to
// one; the estimator (N42) is unbiased for the toy integrals, and denominators missing a family
// or a single technique sample are rejected ("every denominator includes every technique sample").
#include <array>
#include <cmath>
#include <limits>
#include <segpath/core/rng.hpp>
#include <segpath/core/spectrum.hpp>
#include <segpath/testing/statistics.hpp>
#include <segpath/weights/mmis.hpp>
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

struct NoTechniques {
  double pdf(double, int) const { return 1; }
};
struct NoPdf {
  std::array<int, 2> techniques() const { return {}; }
};
struct PdfNotReal {
  std::array<int, 2> techniques() const { return {}; }
  int* pdf(double, int) const { return nullptr; }
};
struct MinimalFamily {
  std::array<int, 2> techniques() const noexcept { return {1, 2}; }
  double pdf(double, int t) const noexcept { return t; }
};
}  // namespace

using TableFamily = decltype(ConditionalFamily(std::declval<const std::vector<int>&>(),
                                               [](double, int) { return 0.0; }));
static_assert(TechniqueFamily<MinimalFamily, double>);
static_assert(TechniqueFamily<TableFamily, double>);
static_assert(TechniqueFamily<UnconditionalFamily<double (*)(double)>, double>);
static_assert(!TechniqueFamily<NoTechniques, double>);
static_assert(!TechniqueFamily<NoPdf, double>);
static_assert(!TechniqueFamily<PdfNotReal, double>);

TEMPLATE_TEST_CASE("MMIS weights sum to one over random families", "[weights]", float, double) {
  using T = TestType;
  Pcg32 rng(9, 4);
  const auto random_density = [&rng]() {
    return rng.uniform<T>() < T(0.25) ? T(0) : T(std::exp(20.0 * (rng.uniform<double>() - 0.5)));
  };
  for (int trial = 0; trial < 1000; ++trial) {
    // A run-time number of families of one type, each with 0..6 technique samples whose densities
    // at the fixed sample x come from a table (zeros included).
    const std::size_t family_count = 1 + rng.next_u32() % 5;
    std::vector<std::vector<int>> techniques(family_count);
    std::vector<std::vector<T>> densities(family_count);
    for (std::size_t f = 0; f < family_count; ++f) {
      const std::size_t n = rng.next_u32() % 7;
      for (std::size_t j = 0; j < n; ++j) {
        techniques[f].push_back(int(j));
        densities[f].push_back(random_density());
      }
    }
    const auto table_pdf = [](const std::vector<T>* table) {
      return [table](T /*x*/, int t) { return (*table)[std::size_t(t)]; };
    };
    using Family = decltype(ConditionalFamily(techniques[0], table_pdf(&densities[0])));
    std::vector<Family> families;
    for (std::size_t f = 0; f < family_count; ++f)
      families.emplace_back(techniques[f], table_pdf(&densities[f]));
    const T x = T(0.5);
    const T denominator = mmis_denominator_range(x, families);
    T sum = 0;
    for (std::size_t f = 0; f < family_count; ++f) {
      for (const int t : families[f].techniques()) {
        const T w = mmis_weight(families[f].pdf(x, t), denominator);
        if (densities[f][std::size_t(t)] == T(0)) CHECK(w == T(0));
        CHECK(w >= T(0));
        sum += w;
      }
    }
    if (denominator > T(0))
      CHECK(double(sum) == Approx(1.0).margin(sum_tolerance<T>));
    else
      CHECK(sum == T(0));
  }
}

TEMPLATE_TEST_CASE("MMIS over three families of different types: weights sum to one", "[weights]",
                   float, double) {
  using T = TestType;
  Pcg32 rng(10, 5);
  for (int trial = 0; trial < 1000; ++trial) {
    // Family 1: triangles with random modes; family 2: the uniform technique drawn 0..3 times;
    // family 3: a table of densities with zeros.
    std::array<T, 5> modes{};
    const std::size_t n1 = rng.next_u32() % (modes.size() + 1);
    for (std::size_t j = 0; j < n1; ++j) modes[j] = rng.uniform<T>();
    const ConditionalFamily triangles(std::span<const T>(modes.data(), n1),
                                      [](T x, T t) { return triangle_pdf(x, t); });
    const UnconditionalFamily uniform(rng.next_u32() % 4,
                                      [](T x) { return x >= T(0) && x < T(1) ? T(1) : T(0); });
    std::array<T, 4> table{};
    std::array<int, 4> table_techniques{};
    const std::size_t n3 = rng.next_u32() % (table.size() + 1);
    for (std::size_t j = 0; j < n3; ++j) {
      table_techniques[j] = int(j);
      table[j] = rng.uniform<T>() < T(0.3) ? T(0) : T(4) * rng.uniform<T>();
    }
    const ConditionalFamily tabulated(std::span<const int>(table_techniques.data(), n3),
                                      [&table](T, int t) { return table[std::size_t(t)]; });

    const T x = rng.uniform<T>();
    const T denominator = mmis_denominator(x, triangles, uniform, tabulated);
    CHECK(double(denominator) ==
          Approx(double(family_density_sum(x, triangles) + family_density_sum(x, uniform) +
                        family_density_sum(x, tabulated)))
              .epsilon(1e-6));
    // A conditional family alone gives the SMIS denominator (N12).
    CHECK(mmis_denominator(x, triangles) ==
          smis_denominator(x, triangles.techniques(), [](T y, T t) { return triangle_pdf(y, t); }));
    // The closed-form density_sum of the unconditional family equals its loop over techniques.
    T loop = 0;
    for (const std::size_t j : uniform.techniques()) loop += uniform.pdf(x, j);
    CHECK(family_density_sum(x, uniform) == loop);

    T sum = 0;
    for (const T t : triangles.techniques()) sum += mmis_weight(triangles.pdf(x, t), denominator);
    for (const std::size_t j : uniform.techniques())
      sum += mmis_weight(uniform.pdf(x, j), denominator);
    for (const int t : tabulated.techniques()) {
      const T w = mmis_weight(tabulated.pdf(x, t), denominator);
      if (table[std::size_t(t)] == T(0)) CHECK(w == T(0));
      sum += w;
    }
    if (denominator > T(0))
      CHECK(double(sum) == Approx(1.0).margin(sum_tolerance<T>));
    else
      CHECK(sum == T(0));
  }
}

TEST_CASE("MMIS never divides by zero or propagates NaN", "[weights]") {
  constexpr double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> no_modes;
  const ConditionalFamily empty(no_modes, [](double x, double t) { return triangle_pdf(x, t); });
  const UnconditionalFamily none(0, [](double) { return 1.0; });
  CHECK(mmis_denominator(0.5, empty, none) == 0.0);
  CHECK(mmis_weight(1.0, mmis_denominator(0.5, empty, none)) == 0.0);
  CHECK(mmis_contribution(1.0, 0.0) == 0.0);
  CHECK(is_black(mmis_contribution(Rgb<float>(1.0f), 0.0f)));
  CHECK(mmis_contribution(Rgb<float>(2.0f), 4.0f) == Rgb<float>(0.5f));
  const UnconditionalFamily broken(3, [](double) { return nan; });
  const UnconditionalFamily fine(2, [](double) { return 0.5; });
  CHECK(mmis_denominator(0.5, broken, fine) == 1.0);
  CHECK(mmis_weight(nan, 1.0) == 0.0);
  CHECK(mmis_denominator(0.5, MinimalFamily{}) == 3.0);
  static_assert(noexcept(mmis_denominator(0.5, MinimalFamily{})));
}

TEMPLATE_TEST_CASE(
    "MMIS of int_0^1 x^2 dx with the families {p1 = 1 (twice), p2 = 2x (once)} is unbiased",
    "[weights][stat]", float, double) {
  using T = TestType;
  const UnconditionalFamily uniform(2, [](T x) { return x >= T(0) && x < T(1) ? T(1) : T(0); });
  const UnconditionalFamily linear(1, [](T x) { return x >= T(0) && x < T(1) ? T(2) * x : T(0); });
  Pcg32 rng(303, 1);
  testing::RunningStats right, wrong;
  for (int k = 0; k < 100000; ++k) {
    const std::array<T, 3> samples{rng.uniform<T>(), rng.uniform<T>(), std::sqrt(rng.uniform<T>())};
    T estimate = 0, missing = 0;
    for (const T x : samples) {
      estimate += mmis_contribution(square(x), mmis_denominator(x, uniform, linear));  // (N42)
      missing += mmis_contribution(square(x), mmis_denominator(x, uniform));  // family 2 left out
    }
    right.add(double(estimate));
    wrong.add(double(missing));
  }
  const double alpha = testing::sidak_alpha(0.01, stat_tests);
  const auto result = testing::student_t_test(right, 1.0 / 3.0);
  INFO("MMIS: mean " << right.mean() << " +- " << right.standard_error()
                     << ", p = " << result.p_value);
  CHECK_FALSE(result.rejects(alpha));
  const auto rejected = testing::student_t_test(wrong, 1.0 / 3.0);
  INFO("missing family: mean " << wrong.mean() << " +- " << wrong.standard_error());
  CHECK(rejected.rejects(alpha));
}

TEMPLATE_TEST_CASE("MMIS with a continuous triangular family and the uniform technique is unbiased",
                   "[weights][stat]", float, double) {
  using T = TestType;
  // Family 1: n1 technique samples t ~ U(0, 1), X ~ triangle with mode t; family 2: the uniform
  // technique, n2 = 1. Every sample is divided by the densities of all four technique samples.
  constexpr std::size_t n1 = 3;
  const auto triangle = [](T x, T t) { return triangle_pdf(x, t); };
  const UnconditionalFamily uniform(1, [](T x) { return x >= T(0) && x < T(1) ? T(1) : T(0); });
  Pcg32 rng(304, 2);
  testing::RunningStats right, no_family, no_sample;
  std::array<T, n1> modes{};
  std::array<T, n1 + 1> samples{};
  for (int k = 0; k < 100000; ++k) {
    for (std::size_t j = 0; j < n1; ++j) {
      modes[j] = rng.uniform<T>();
      samples[j] = sample_triangle(modes[j], rng.uniform<T>());
    }
    samples[n1] = rng.uniform<T>();
    const ConditionalFamily triangles(std::span<const T>(modes), triangle);
    const ConditionalFamily all_but_one(std::span<const T>(modes.data(), n1 - 1), triangle);
    T estimate = 0, missing_family = 0, missing_sample = 0;
    for (const T x : samples) {
      const T g = square(x);
      estimate += mmis_contribution(g, mmis_denominator(x, triangles, uniform));
      missing_family += mmis_contribution(g, mmis_denominator(x, uniform));
      missing_sample += mmis_contribution(g, mmis_denominator(x, all_but_one, uniform));
    }
    right.add(double(estimate));
    no_family.add(double(missing_family));
    no_sample.add(double(missing_sample));
  }
  const double alpha = testing::sidak_alpha(0.01, stat_tests);
  const auto result = testing::student_t_test(right, 1.0 / 3.0);
  INFO("MMIS: mean " << right.mean() << " +- " << right.standard_error()
                     << ", p = " << result.p_value);
  CHECK_FALSE(result.rejects(alpha));
  const auto rejected_family = testing::student_t_test(no_family, 1.0 / 3.0);
  INFO("missing the triangular family: mean " << no_family.mean() << " +- "
                                              << no_family.standard_error());
  CHECK(rejected_family.rejects(alpha));
  const auto rejected_sample = testing::student_t_test(no_sample, 1.0 / 3.0);
  INFO("missing one technique sample: mean " << no_sample.mean() << " +- "
                                             << no_sample.standard_error());
  CHECK(rejected_sample.rejects(alpha));
}
