#include <segpath/testing/chi_square.hpp>

#include "support/catch.hpp"

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>
#include <optional>

using segpath::Pcg32;
using namespace segpath::testing;

namespace {
constexpr double pi = std::numbers::pi;

std::optional<glm::dvec2> cosine_hemisphere(Pcg32& rng) {
  const double u1 = rng.uniform<double>(), u2 = rng.uniform<double>();
  const double r = std::sqrt(u1), phi = 2 * pi * u2;
  return direction_to_cos_theta_phi({r * std::cos(phi), r * std::sin(phi), std::sqrt(1 - u1)});
}
std::optional<glm::dvec2> uniform_hemisphere(Pcg32& rng) {
  const double z = rng.uniform<double>(), phi = 2 * pi * rng.uniform<double>();
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  return direction_to_cos_theta_phi({r * std::cos(phi), r * std::sin(phi), z});
}
double cosine_pdf(const glm::dvec2& p) {
  return std::max(cos_theta_phi_to_direction(p).z, 0.0) / pi;
}

ChiSquare2DConfig sphere_config() {
  ChiSquare2DConfig c;
  c.lo = {-1, 0};
  c.hi = {1, 2 * pi};
  c.cells_x = 16;  // even: the horizon cos theta = 0 is a cell boundary
  c.cells_y = 16;
  c.samples = 200'000;
  return c;
}
}  // namespace

TEST_CASE("direction <-> (cos theta, phi) round trip", "[testing]") {
  const glm::dvec3 dirs[] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0.6, -0.8, 0}, {-0.48, 0.6, 0.64}};
  for (const glm::dvec3& d : dirs) {
    const glm::dvec2 p = direction_to_cos_theta_phi(d);
    CHECK(p.x >= -1);
    CHECK(p.x <= 1);
    CHECK(p.y >= 0);
    CHECK(p.y < 2 * pi);
    const glm::dvec3 back = cos_theta_phi_to_direction(p);
    CHECK(glm::length(back - d) < 1e-12);
  }
  // A direction just below phi = 0 must not map to 2 pi, outside [0, 2 pi).
  CHECK(direction_to_cos_theta_phi({1, -1e-300, 0}).y < 2 * pi);
}

TEST_CASE("chi_square_2d accepts cosine sampling against the cosine density", "[testing][stat]") {
  const double alpha = sidak_alpha(family_alpha, sampler_suite_size);
  const ChiSquare2DReport r = chi_square_2d(cosine_hemisphere, cosine_pdf, sphere_config(), 17);
  INFO(r.table);
  CHECK_FALSE(r.rejects(alpha));
  CHECK(r.integral_of_pdf == Approx(1.0).margin(1e-6));
  CHECK(r.outside_domain == 0);
  CHECK(r.failed_samples == 0);
  CHECK(r.zero_expected_hits == 0);
}

TEST_CASE("chi_square_2d rejects uniform hemisphere samples against the cosine density",
          "[testing][stat]") {
  const double alpha = sidak_alpha(family_alpha, sampler_suite_size);
  const ChiSquare2DReport r = chi_square_2d(uniform_hemisphere, cosine_pdf, sphere_config(), 17);
  CHECK(r.rejects(alpha));
  // ... and it is the density, not the harness: the uniform density accepts the same samples.
  const ChiSquare2DReport u = chi_square_2d(
      uniform_hemisphere, [](const glm::dvec2& p) { return p.x >= 0 ? 1 / (2 * pi) : 0.0; },
      sphere_config(), 17);
  INFO(u.table);
  CHECK_FALSE(u.rejects(alpha));
}

TEST_CASE("chi_square_2d hard failures: zero-density hits and samples outside the domain",
          "[testing]") {
  ChiSquare2DConfig c = sphere_config();
  c.samples = 20'000;
  // Cosine samples, one in a hundred flipped to the lower hemisphere where the pdf is 0.
  std::uint64_t count = 0;
  const ChiSquare2DReport flipped = chi_square_2d(
      [&](Pcg32& rng) {
        std::optional<glm::dvec2> p = cosine_hemisphere(rng);
        if (++count % 100 == 0) p->x = -p->x;
        return p;
      },
      cosine_pdf, c, 3);
  CHECK(flipped.zero_expected_hits == 200);
  CHECK(flipped.p_value == 0);

  const ChiSquare2DReport outside = chi_square_2d(
      [&](Pcg32& rng) {
        std::optional<glm::dvec2> p = cosine_hemisphere(rng);
        if (rng.uniform<double>() < 1e-3) p->y = 7.0;
        return p;
      },
      cosine_pdf, c, 3);
  CHECK(outside.outside_domain > 0);
  CHECK(outside.p_value == 0);
  CHECK(outside.table.find("outside the domain") != std::string::npos);

  CHECK_THROWS_AS(
      chi_square_2d(cosine_hemisphere, cosine_pdf, ChiSquare2DConfig{{0, 0}, {0, 1}}, 1),
      std::invalid_argument);
}

TEST_CASE("chi_square_2d with failed samples: the pdf integrates to the acceptance rate",
          "[testing][stat]") {
  // Rejection sampling of the unit disk from the square [-1, 1]^2: P(sample in A) =
  // area(A and disk) / 4, so pdf = 1/4 on the disk and the acceptance rate is pi / 4.
  ChiSquare2DConfig c;
  c.lo = {-1, -1};
  c.hi = {1, 1};
  c.cells_x = c.cells_y = 16;
  c.samples = 200'000;
  c.integration_panels = 16;  // the pdf jumps at the circle, inside cells
  const auto rejection = [](Pcg32& rng) -> std::optional<glm::dvec2> {
    const glm::dvec2 p(2 * rng.uniform<double>() - 1, 2 * rng.uniform<double>() - 1);
    if (glm::dot(p, p) >= 1) return std::nullopt;
    return p;
  };
  const auto pdf = [](const glm::dvec2& p) { return glm::dot(p, p) < 1 ? 0.25 : 0.0; };
  const double alpha = sidak_alpha(family_alpha, sampler_suite_size);
  const ChiSquare2DReport r = chi_square_2d(rejection, pdf, c, 11);
  INFO(r.table);
  CHECK_FALSE(r.rejects(alpha));
  CHECK(r.integral_of_pdf == Approx(pi / 4).margin(2e-4));
  CHECK(double(r.failed_samples) / double(c.samples) == Approx(1 - pi / 4).margin(5e-3));
  // The density normalised as if every sample succeeded is rejected.
  const ChiSquare2DReport wrong = chi_square_2d(
      rejection, [](const glm::dvec2& p) { return glm::dot(p, p) < 1 ? 1 / pi : 0.0; }, c, 11);
  CHECK(wrong.rejects(alpha));
}
