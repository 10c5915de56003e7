// Deterministic quadrature for tests: composite Gauss-Legendre rules on intervals, rectangles
// and the sphere of directions (reference values for densities, kernels and estimators).
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <stdexcept>
#include <string>

namespace segpath::testing {

namespace detail {

/// The 8-point Gauss-Legendre rule on [-1, 1] (exact for polynomials of degree <= 15):
/// the positive roots of P_8 and their weights (the rule is symmetric).
inline constexpr std::array<double, 4> gauss_legendre8_nodes{
    0.18343464249564980494, 0.52553240991632898582, 0.79666647741362673959, 0.96028985649753623168};
inline constexpr std::array<double, 4> gauss_legendre8_weights{
    0.36268378337836198297, 0.31370664587788728734, 0.22238103445337447054, 0.10122853629037625915};

inline void require_panels(int panels, const char* who) {
  if (panels < 1)
    throw std::invalid_argument(std::string("segpath::testing::") + who +
                                ": the number of panels must be >= 1, got " +
                                std::to_string(panels));
}

/// Calls visit(x, w) for the 8 * panels nodes and weights of the composite rule on [a, b].
template <class Visit>
void for_each_node(double a, double b, int panels, Visit&& visit) {
  const double h = (b - a) / panels;
  for (int p = 0; p < panels; ++p) {
    const double lo = a + h * p;
    const double hi = p + 1 == panels ? b : a + h * (p + 1);
    const double mid = 0.5 * (lo + hi);
    const double half = 0.5 * (hi - lo);
    for (std::size_t k = 0; k < gauss_legendre8_nodes.size(); ++k) {
      const double w = half * gauss_legendre8_weights[k];
      visit(mid - half * gauss_legendre8_nodes[k], w);
      visit(mid + half * gauss_legendre8_nodes[k], w);
    }
  }
}

/// The unit direction of (cos theta, phi) about +z.
inline glm::dvec3 direction_from_cos_theta_phi(double cos_theta, double phi) noexcept {
  const double z = std::clamp(cos_theta, -1.0, 1.0);
  const double sin_theta = std::sqrt(std::max(0.0, 1.0 - z * z));
  return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), z};
}

}  // namespace detail

/// The integral of f(double) over [a, b] by composite Gauss-Legendre quadrature, 8 nodes in
/// each of `panels` equal panels. Converges like h^16 for smooth f; for f with a jump
/// inside a panel the error is O(h) times the jump, so put panel boundaries on known
/// discontinuities (integrate piecewise) or use many panels. a > b gives the negated integral.
/// Throws std::invalid_argument for panels < 1.
template <class F>
double integrate_1d(F&& f, double a, double b, int panels = 64) {
  detail::require_panels(panels, "integrate_1d");
  double sum = 0;
  detail::for_each_node(
      a, b, panels, [&](double x, double w) { sum += w * static_cast<double>(std::invoke(f, x)); });
  return sum;
}

/// The integral of f(glm::dvec2) over the rectangle [lo.x, hi.x] x [lo.y, hi.y] by the product
/// of two composite Gauss-Legendre rules (panels_x * panels_y panels of 64 nodes each).
/// Throws std::invalid_argument for a panel count < 1.
template <class F>
double integrate_2d(F&& f, glm::dvec2 lo, glm::dvec2 hi, int panels_x = 32, int panels_y = 32) {
  detail::require_panels(panels_x, "integrate_2d");
  detail::require_panels(panels_y, "integrate_2d");
  double sum = 0;
  detail::for_each_node(lo.y, hi.y, panels_y, [&](double y, double wy) {
    double row = 0;
    detail::for_each_node(lo.x, hi.x, panels_x, [&](double x, double wx) {
      row += wx * static_cast<double>(std::invoke(f, glm::dvec2(x, y)));
    });
    sum += wy * row;
  });
  return sum;
}

/// The integral of f(glm::dvec3 unit direction) over the unit sphere in solid angle, as a
/// product rule in (cos theta, phi) over [-1, 1] x [0, 2 pi) (d omega = d cos theta d phi;
/// theta is measured from +z). Exact to rounding for integrands polynomial of degree <= 15
/// in cos theta on each panel and smooth and periodic in phi. An even panels_theta puts a
/// panel boundary on the horizon cos theta = 0, where hemispherical integrands jump.
template <class F>
double integrate_sphere(F&& f, int panels_theta = 32, int panels_phi = 64) {
  detail::require_panels(panels_theta, "integrate_sphere");
  detail::require_panels(panels_phi, "integrate_sphere");
  return integrate_2d(
      [&](const glm::dvec2& p) {
        return static_cast<double>(std::invoke(f, detail::direction_from_cos_theta_phi(p.x, p.y)));
      },
      glm::dvec2(-1.0, 0.0), glm::dvec2(1.0, 2.0 * std::numbers::pi), panels_theta, panels_phi);
}

}  // namespace segpath::testing
