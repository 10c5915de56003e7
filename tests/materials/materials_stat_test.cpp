// Statistical tests of the reference BSDFs: chi-square goodness of fit of sample() against
// pdf(), a demonstration that the test rejects a wrong pdf, binomial tests of the
// dielectric's Fresnel lobe choice, energy conservation and acceptance rates.
#include <array>
#include <cmath>
#include <segpath/core/warp.hpp>
#include <segpath/materials/material_set.hpp>
#include <segpath/testing/integrate.hpp>

#include "materials/bsdf_test_support.hpp"
#include "support/catch.hpp"

using namespace segpath;
using namespace segpath::test_materials;

namespace {

/// One chi-square case: a fixed direction (degrees from the normal, azimuth), a mode and the
/// chart that resolves the lobe (axis: normal or mirror direction; power k; cells).
struct Case {
  double theta, phi;
  Transport mode;
  bool mirror_axis;
  double power;
  int cells_x, cells_y;
};

template <class T, class B>
void run_chi_square(const B& bsdf, const Case& c, std::uint64_t seed) {
  const auto p = test_point<T>();
  const Vec3<T> fixed = direction_at<T>(c.theta, c.phi);
  const glm::dvec3 axis = c.mirror_axis ? to_d(reflect(fixed, p.normal)) : test_normal();
  const auto report = chi_square_bsdf<T>(bsdf, p, fixed, c.mode, LobeChart(axis, c.power), seed,
                                         c.cells_x, c.cells_y);
  const double accepted =
      1.0 - double(report.failed_samples) / 1e6;  // the acceptance rate the pdf must integrate to
  INFO("theta " << c.theta << " mode " << int(c.mode) << " p " << report.p_value << " cells "
                << report.cells << "\n"
                << report.table);
  CHECK(report.outside_domain == 0);
  CHECK(report.zero_expected_hits == 0);
  CHECK_FALSE(report.rejects(suite_alpha()));
  // Normalisation: binomial 5 sigma of the acceptance rate, plus the quadrature's error at
  // the horizon jump (O(cell / 48) of the mass near the horizon; below 1e-3 here).
  const double sigma = std::sqrt(std::max(accepted * (1 - accepted), 1e-12) / 1e6);
  CHECK(std::abs(report.integral_of_pdf - accepted) < 5 * sigma + 1e-3);
}

// 16 chi-square tests in all (8 per scalar type) of testing::sampler_suite_size. The Phong
// lobe (n = 90, ~0.1 rad wide) is charted about the mirror direction with k = 3 and more
// cells in x than in phi: the test then resolves the lobe's profile finely enough to reject
// the exponent off by one (below), while 12 azimuth cells still see errors in phi.
const std::array<Case, 2> lambert_cases{{{30, 1, Transport::radiance, false, 1, 40, 40},
                                         {88, 4, Transport::importance, false, 1, 40, 40}}};
const std::array<Case, 3> lobe_cases{{{5, 1, Transport::radiance, true, 3, 48, 12},
                                      {87, 2, Transport::radiance, true, 3, 48, 12},
                                      {60, 5, Transport::importance, true, 3, 48, 12}}};

}  // namespace

TEMPLATE_TEST_CASE("BSDF samples follow pdf (chi-square)", "[materials][stat][chi2]", float,
                   double) {
  using T = TestType;
  std::uint64_t seed = std::is_same_v<T, float> ? 100 : 200;
  SECTION("Lambertian") {
    const Lambertian<T> bsdf{T(0.8)};
    for (const Case& c : lambert_cases) run_chi_square<T>(bsdf, c, seed++);
  }
  SECTION("Phong n = 90") {
    const Phong<T> bsdf(T(0.7), T(90));
    for (const Case& c : lobe_cases) run_chi_square<T>(bsdf, c, 10 + seed++);
  }
  SECTION("Glossy floor") {
    const Glossy<T> bsdf(T(0.1), T(0.7), T(90));
    for (const Case& c : lobe_cases) run_chi_square<T>(bsdf, c, 20 + seed++);
  }
}

namespace {
/// Phong's sampler with the pdf of exponent n + 1: the kind of bug the test must catch.
template <class T>
struct PhongWrongPdf {
  Phong<T> sampler, density;
  [[nodiscard]] T eval(const BsdfQuery<T>& q) const noexcept { return sampler.eval(q); }
  [[nodiscard]] std::optional<BsdfSample<T>> sample(const BsdfSampleQuery<T>& q) const noexcept {
    return sampler.sample(q);
  }
  [[nodiscard]] T pdf(const BsdfQuery<T>& q) const noexcept { return density.pdf(q); }
};
}  // namespace

TEMPLATE_TEST_CASE("The chi-square test rejects a pdf whose exponent is off by one",
                   "[materials][stat][chi2]", float, double) {
  using T = TestType;
  // The Cornell floor's exponent, in the configuration of the Phong cases above.
  const PhongWrongPdf<T> wrong{Phong<T>(T(0.7), T(90)), Phong<T>(T(0.7), T(91))};
  const Case c = lobe_cases[0];
  const auto p = test_point<T>();
  const Vec3<T> fixed = direction_at<T>(30, c.phi);
  const auto report = chi_square_bsdf<T>(wrong, p, fixed, c.mode,
                                         LobeChart(to_d(reflect(fixed, p.normal)), c.power), 7,
                                         c.cells_x, c.cells_y);
  INFO("p " << report.p_value << "\n" << report.table);
  CHECK(report.rejects(suite_alpha()));
}

TEMPLATE_TEST_CASE("Dielectric reflects with probability F (binomial test)", "[materials][stat]",
                   float, double) {
  using T = TestType;
  const auto p = test_point<T>();
  const glm::dvec3 n = test_normal();
  constexpr int n_samples = 200'000;
  auto count_reflections = [&](const Dielectric<T>& glass, const Vec3<T>& w, Transport mode,
                               std::uint64_t seed) {
    Pcg32 rng(seed, 1);
    int reflected = 0;
    for (int i = 0; i < n_samples; ++i) {
      const auto s =
          glass.sample(BsdfSampleQuery<T>{p, w, rng.uniform2<T>(), rng.uniform<T>(), mode});
      REQUIRE(s);
      if (glm::dot(to_d(s->direction), n) * glm::dot(to_d(w), n) > 0) ++reflected;
    }
    return reflected;
  };
  auto binomial_p = [&](int k, double f) {
    const double z = (k - n_samples * f) / std::sqrt(n_samples * f * (1 - f));
    return 2 * (1 - testing::normal_cdf(std::abs(z)));
  };
  const Dielectric<T> glass(T(1.6));
  std::uint64_t seed = std::is_same_v<T, float> ? 300 : 400;
  for (const double theta : {0.0, 75.0, 150.0}) {
    for (const Transport mode : {Transport::radiance, Transport::importance}) {
      const Vec3<T> w = direction_at<T>(theta, 1.2);
      const double cos_i = std::abs(glm::dot(to_d(w), n));
      const double f = fresnel_dielectric(cos_i, theta < 90 ? 1 / 1.6 : 1.6);
      const int k = count_reflections(glass, w, mode, ++seed);
      INFO("theta " << theta << " F " << f << " reflected " << k << " of " << n_samples);
      CHECK(binomial_p(k, f) >= suite_alpha());
    }
  }
  // The test sees a wrong index: frequencies of eta 1.5 against F of eta 1.6 at 75 degrees.
  const Vec3<T> w = direction_at<T>(75.0, 1.2);
  const int k = count_reflections(Dielectric<T>(T(1.5)), w, Transport::radiance, 999);
  CHECK(binomial_p(k, fresnel_dielectric(std::abs(glm::dot(to_d(w), n)), 1 / 1.6)) < suite_alpha());
}

TEMPLATE_TEST_CASE("BSDFs conserve energy: mean f cos / pdf <= 1", "[materials][stat]", float,
                   double) {
  using T = TestType;
  const auto p = test_point<T>();
  constexpr int n_samples = 100'000;
  auto albedo = [&](const auto& bsdf, const Vec3<T>& w, Transport mode, std::uint64_t seed) {
    Pcg32 rng(seed, 2);
    testing::RunningStats stats;
    for (int i = 0; i < n_samples; ++i) {
      const auto s =
          bsdf.sample(BsdfSampleQuery<T>{p, w, rng.uniform2<T>(), rng.uniform<T>(), mode});
      const double x =
          s ? double(s->value) * std::abs(double(glm::dot(s->direction, p.normal))) / double(s->pdf)
            : 0.0;
      stats.add(x);
    }
    return stats;
  };
  std::uint64_t seed = std::is_same_v<T, float> ? 500 : 600;
  const Lambertian<T> white{T(1)};
  const Phong<T> phong(T(1), T(90));
  const Phong<T> broad(T(1), T(2));
  const Glossy<T> floor(T(0.1), T(0.7), T(90));
  const Glossy<T> bright(T(0.5), T(0.5), T(5));
  const Mirror<T> mirror;
  const Dielectric<T> glass(T(1.6));
  for (const double theta : {0.0, 30.0, 70.0, 89.0}) {
    for (const Transport mode : {Transport::radiance, Transport::importance}) {
      const Vec3<T> w = direction_at<T>(theta, 0.3);
      INFO("theta " << theta << " mode " << int(mode));
      auto check_bounded = [&](const testing::RunningStats& s) {
        INFO("mean " << s.mean() << " +- " << s.standard_error());
        CHECK(s.mean() <= 1 + 5 * s.standard_error());
      };
      const auto a_white = albedo(white, w, mode, ++seed);
      check_bounded(a_white);
      CHECK(a_white.mean() == Approx(1).epsilon(1e-5));  // f cos / pdf = albedo for every sample
      check_bounded(albedo(phong, w, mode, ++seed));
      check_bounded(albedo(broad, w, mode, ++seed));
      check_bounded(albedo(floor, w, mode, ++seed));
      check_bounded(albedo(bright, w, mode, ++seed));
      const auto a_mirror = albedo(mirror, w, mode, ++seed);
      CHECK(a_mirror.mean() == Approx(1).epsilon(1e-5));
      // The glass keeps energy in importance transport; radiance transport scales each
      // refraction by (eta_i / eta_t)^2, here entering the glass: F + (1 - F) / eta^2 <= 1.
      const auto a_glass = albedo(glass, w, mode, ++seed);
      const double f = glass.reflectance(p, w);
      const double expected = mode == Transport::importance ? 1.0 : f + (1 - f) / (1.6 * 1.6);
      CHECK(a_glass.mean() == Approx(expected).epsilon(1e-2));
      CHECK(std::abs(a_glass.mean() - expected) < 5 * a_glass.standard_error() + 1e-6);
    }
  }
  // At normal incidence the Phong lobe about the normal has albedo rho (minus the cut-off's
  // negligible share): a two-sided t-test against 0.7.
  const auto a = albedo(Phong<T>(T(0.7), T(90)), p.normal, Transport::radiance, 77);
  const auto t = testing::student_t_test(a, 0.7 * (1 - std::pow(1e-3, 92)));
  INFO("mean " << a.mean() << " +- " << a.standard_error());
  CHECK_FALSE(t.rejects(suite_alpha()));
}
