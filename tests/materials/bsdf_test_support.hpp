// Test helpers for the reference BSDFs: a tilted surface point, directions about its normal,
// and the direction chart the chi-square tests histogram samples in.
#pragma once

#include <cmath>
#include <numbers>
#include <optional>
#include <segpath/concepts/bsdf.hpp>
#include <segpath/core/frame.hpp>
#include <segpath/core/rng.hpp>
#include <segpath/testing/chi_square.hpp>

namespace segpath::test_materials {

/// A tilted normal, so that frame bugs cannot hide behind the world axes.
inline glm::dvec3 test_normal() { return glm::normalize(glm::dvec3(0.2, -0.3, 0.9)); }

template <class T>
Vec3<T> to_t(const glm::dvec3& v) {
  return Vec3<T>(T(v.x), T(v.y), T(v.z));
}
template <class T>
glm::dvec3 to_d(const Vec3<T>& v) {
  return glm::dvec3(double(v.x), double(v.y), double(v.z));
}

template <class T>
SurfacePoint<T> test_point() {
  return SurfacePoint<T>::on_surface(Vec3<T>(T(0.25), T(-1), T(0.5)), to_t<T>(test_normal()));
}

/// The unit direction at polar angle theta (degrees) and azimuth phi (radians) about the
/// test normal (theta > 90 is below the surface).
template <class T>
Vec3<T> direction_at(double theta_degrees, double phi) {
  const double theta = theta_degrees * std::numbers::pi / 180.0;
  const auto frame = Frame<double>::from_normal(test_normal());
  const glm::dvec3 local(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                         std::cos(theta));
  return glm::normalize(to_t<T>(frame.to_world(local)));
}

/// A chart of the sphere of directions for chi_square_2d: (x, phi) in [0, 1] x [0, 2 pi] with
/// x = ((1 - cos theta) / 2)^(1 / k), theta and phi about `axis`. k = 1 is the plain
/// (cos theta, phi) chart (reversed and halved); k > 1 stretches the neighbourhood of the axis
/// so that a narrow lobe about it spreads over many cells. The density w.r.t. dx dphi is the
/// solid-angle density times |d cos theta / dx| = 2 k x^(k - 1).
struct LobeChart {
  Frame<double> frame;
  double k = 1;

  LobeChart(const glm::dvec3& axis, double power)
      : frame(Frame<double>::from_normal(glm::normalize(axis))), k(power) {}

  [[nodiscard]] glm::dvec2 to_chart(const glm::dvec3& d) const {
    const glm::dvec2 p = testing::direction_to_cos_theta_phi(glm::normalize(frame.to_local(d)));
    return {std::pow(std::max(0.0, (1.0 - p.x) * 0.5), 1.0 / k), p.y};
  }
  [[nodiscard]] glm::dvec3 to_direction(const glm::dvec2& c) const {
    const double cos_theta = 1.0 - 2.0 * std::pow(c.x, k);
    return frame.to_world(testing::cos_theta_phi_to_direction({cos_theta, c.y}));
  }
  [[nodiscard]] double jacobian(const glm::dvec2& c) const {
    return 2.0 * k * std::pow(c.x, k - 1.0);
  }
};

/// The pair (to_sensor, to_light) with `fixed` in the role `mode` fixes.
template <class T>
BsdfQuery<T> pair_query(const SurfacePoint<T>& p, const Vec3<T>& fixed, const Vec3<T>& free,
                        Transport mode) {
  return mode == Transport::radiance ? BsdfQuery<T>{p, fixed, free, mode}
                                     : BsdfQuery<T>{p, free, fixed, mode};
}

/// chi_square_2d of bsdf.sample against bsdf.pdf for one fixed direction, in `chart` with
/// cells_x * cells_y cells.
template <class T, class B>
testing::ChiSquare2DReport chi_square_bsdf(const B& bsdf, const SurfacePoint<T>& point,
                                           const Vec3<T>& fixed, Transport mode,
                                           const LobeChart& chart, std::uint64_t seed, int cells_x,
                                           int cells_y, std::uint64_t samples = 1'000'000) {
  testing::ChiSquare2DConfig config;
  config.lo = {0.0, 0.0};
  config.hi = {1.0, 2.0 * std::numbers::pi};
  config.cells_x = cells_x;
  config.cells_y = cells_y;
  config.samples = samples;
  config.integration_panels = 6;
  return testing::chi_square_2d(
      [&](Pcg32& rng) -> std::optional<glm::dvec2> {
        const Vec2<T> u = rng.uniform2<T>();
        const T u_lobe = rng.uniform<T>();
        const auto s = bsdf.sample(BsdfSampleQuery<T>{point, fixed, u, u_lobe, mode});
        if (!s) return std::nullopt;
        return chart.to_chart(to_d(s->direction));
      },
      [&](const glm::dvec2& c) {
        const Vec3<T> d = to_t<T>(chart.to_direction(c));
        return double(bsdf.pdf(pair_query(point, fixed, d, mode))) * chart.jacobian(c);
      },
      config, seed);
}

/// The significance of each chi-square (and binomial) test of the sampler suite.
inline double suite_alpha() {
  return testing::sidak_alpha(testing::family_alpha, testing::sampler_suite_size);
}

}  // namespace segpath::test_materials
