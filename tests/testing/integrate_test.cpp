#include <segpath/testing/integrate.hpp>

#include "support/catch.hpp"

#include <glm/geometric.hpp>

#include <cmath>
#include <numbers>
#include <stdexcept>

using namespace segpath::testing;

constexpr double pi = std::numbers::pi;

TEST_CASE("integrate_1d reproduces known integrals", "[testing]") {
  CHECK(integrate_1d([](double x) { return std::sin(x); }, 0.0, pi) == Approx(2.0).margin(1e-10));
  CHECK(integrate_1d([](double x) { return std::exp(x); }, 0.0, 1.0, 4) ==
        Approx(std::numbers::e - 1).margin(1e-13));
  // One panel of the 8-point rule is exact for degree 15 but not for degree 16.
  CHECK(integrate_1d([](double x) { return std::pow(x, 15) + 1; }, -1.0, 1.0, 1) ==
        Approx(2.0).margin(1e-14));
  CHECK(integrate_1d([](double x) { return std::pow(x, 14); }, 0.0, 1.0, 1) ==
        Approx(1.0 / 15).margin(1e-14));
  CHECK(std::abs(integrate_1d([](double x) { return std::pow(x, 16); }, -1.0, 1.0, 1) - 2.0 / 17) >
        1e-6);
  CHECK(integrate_1d([](double x) { return x; }, 1.0, 0.0) == Approx(-0.5).margin(1e-14));
  CHECK_THROWS_AS(integrate_1d([](double x) { return x; }, 0.0, 1.0, 0), std::invalid_argument);
}

TEST_CASE("integrate_2d reproduces known integrals", "[testing]") {
  // Integral of x^2 y over [0, 2] x [1, 3] = (8/3) * 4.
  CHECK(integrate_2d([](glm::dvec2 p) { return p.x * p.x * p.y; }, {0, 1}, {2, 3}) ==
        Approx(32.0 / 3).margin(1e-10));
  CHECK(integrate_2d([](const glm::dvec2& p) { return std::cos(p.x) * std::exp(p.y); }, {0, 0},
                     {pi / 2, 1}, 8, 3) == Approx(std::numbers::e - 1).margin(1e-10));
  // A non-separable integrand: integral of 1 / (1 + x + y) over the unit square.
  const double reference = 3 * std::log(3.0) - 4 * std::log(2.0);
  CHECK(integrate_2d([](glm::dvec2 p) { return 1 / (1 + p.x + p.y); }, {0, 0}, {1, 1}) ==
        Approx(reference).margin(1e-10));
  CHECK_THROWS_AS(integrate_2d([](glm::dvec2) { return 1.0; }, {0, 0}, {1, 1}, 1, 0),
                  std::invalid_argument);
}

TEST_CASE("integrate_sphere reproduces known integrals", "[testing]") {
  CHECK(integrate_sphere([](const glm::dvec3&) { return 1.0; }) == Approx(4 * pi).margin(1e-10));
  CHECK(integrate_sphere([](const glm::dvec3& d) { return d.z * d.z; }) ==
        Approx(4 * pi / 3).margin(1e-10));
  CHECK(integrate_sphere([](const glm::dvec3& d) { return d.x * d.x; }) ==
        Approx(4 * pi / 3).margin(1e-10));
  // The clamped cosine over the upper hemisphere: pi (the jump sits on a panel boundary).
  CHECK(integrate_sphere([](const glm::dvec3& d) { return std::max(d.z, 0.0); }) ==
        Approx(pi).margin(1e-10));
  // Directions are unit vectors.
  CHECK(integrate_sphere([](const glm::dvec3& d) { return glm::dot(d, d); }, 4, 8) ==
        Approx(4 * pi).margin(1e-10));
}
