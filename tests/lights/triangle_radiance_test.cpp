// Tests of TriangleLights with one radiance per triangle: each triangle's points carry its
// own radiance in every query, the emitted power matches sum_i pi L_i A_i, bad input.
#include <cmath>
#include <numbers>
#include <optional>
#include <segpath/core/rng.hpp>
#include <segpath/lights/triangle_light.hpp>
#include <segpath/testing/chi_square.hpp>
#include <segpath/testing/statistics.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

static_assert(SampledEmitter<TriangleLights<Rgb<float>>, Rgb<float>>);

namespace {

/// Triangles of area 0.5 (+z), 1 (-x) and 0 (degenerate), ids 10, 11, 12.
template <class T>
std::vector<EmissiveTriangle<T>> three_triangles() {
  return {{Vec3<T>(0, 0, 0), Vec3<T>(1, 0, 0), Vec3<T>(0, 1, 0), 10, 1},
          {Vec3<T>(2, 0, 0), Vec3<T>(2, 0, 2), Vec3<T>(2, 1, 0), 11, 2},
          {Vec3<T>(0, 0, 3), Vec3<T>(1, 1, 3), Vec3<T>(2, 2, 3), 12, 3}};
}

template <class T>
std::vector<Rgb<T>> three_radiances() {
  return {Rgb<T>(1, 2, 3), Rgb<T>(T(0.5), 0, 4), Rgb<T>(7, 7, 7)};
}

}  // namespace

TEMPLATE_TEST_CASE("TriangleLights: every query returns the radiance of the point's triangle",
                   "[lights]", float, double) {
  using T = TestType;
  using S = Rgb<T>;
  const auto triangles = three_triangles<T>();
  const auto radiances = three_radiances<T>();
  const TriangleLights<S> light(triangles, radiances);
  for (std::size_t i = 0; i < 3; ++i) CHECK(light.radiance_of(i) == radiances[i]);
  CHECK(light.emitted_radiance() == radiances[0]);

  // radiance(): front side of each triangle; the degenerate one never emits.
  const auto p0 = SurfacePoint<T>::on_surface(Vec3<T>(T(0.2), T(0.2), 0), Vec3<T>(0, 0, 1), 10);
  const auto p1 = SurfacePoint<T>::on_surface(Vec3<T>(2, T(0.2), T(0.2)), Vec3<T>(-1, 0, 0), 11);
  const auto p2 = SurfacePoint<T>::on_surface(Vec3<T>(1, 1, 3), Vec3<T>(0, 0, 1), 12);
  CHECK(light.radiance({p0, Vec3<T>(0, 0, 1)}) == radiances[0]);
  CHECK(light.radiance({p1, Vec3<T>(-1, 0, 0)}) == radiances[1]);
  CHECK(is_black(light.radiance({p1, Vec3<T>(1, 0, 0)})));
  CHECK(is_black(light.radiance({p2, Vec3<T>(0, 0, 1)})));

  // Sampled points carry their own triangle's radiance (sample_towards from a receiver in
  // front of both non-degenerate triangles).
  const auto receiver = SurfacePoint<T>::on_surface(Vec3<T>(1, T(0.3), 1), Vec3<T>(0, 0, 1));
  Pcg32 rng(7, 1);
  int seen[2] = {0, 0};
  for (int k = 0; k < 2000; ++k) {
    const auto e = light.sample_emission({rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(e);
    const auto i = light.find(e->point.primitive_id);
    REQUIRE(i);
    REQUIRE(*i < 2);
    ++seen[*i];
    CHECK(e->radiance == radiances[*i]);
    const auto t = light.sample_towards({receiver, rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(t);
    const auto j = light.find(t->point.primitive_id);
    REQUIRE(j);
    CHECK(t->radiance == radiances[*j]);
  }
  CHECK(seen[0] > 0);
  CHECK(seen[1] > 0);
}

TEST_CASE("TriangleLights: equal per-triangle radiances behave as one radiance", "[lights]") {
  using S = Rgb<double>;
  const auto triangles = three_triangles<double>();
  const TriangleLights<S> one(triangles, S(2, 3, 4));
  const TriangleLights<S> each(triangles, std::vector<S>(3, S(2, 3, 4)));
  Pcg32 a(3, 0), b(3, 0);
  for (int k = 0; k < 200; ++k) {
    const auto ea = one.sample_emission({a.uniform2<double>(), a.uniform2<double>(), a.uniform<double>()});
    const auto eb = each.sample_emission({b.uniform2<double>(), b.uniform2<double>(), b.uniform<double>()});
    REQUIRE(ea);
    REQUIRE(eb);
    CHECK(ea->point.position == eb->point.position);
    CHECK(ea->direction == eb->direction);
    CHECK(ea->radiance == eb->radiance);
    CHECK(ea->pdf_position == eb->pdf_position);
    CHECK(ea->pdf_direction == eb->pdf_direction);
  }
}

TEST_CASE("TriangleLights: per-triangle emitted power is sum_i pi L_i A_i", "[lights][stat]") {
  // Phi = integral over area and hemisphere of L cos = pi sum_i L_i A_i; sample_emission's
  // estimator L cos / (p_A p_omega) is unbiased for it. A light that used one radiance for
  // all triangles would give pi (0.5 + 1) L_0 instead.
  using T = double;
  using S = Rgb<T>;
  const TriangleLights<S> light(three_triangles<T>(), three_radiances<T>());
  const double alpha = testing::sidak_alpha(testing::family_alpha, testing::sampler_suite_size);
  testing::RunningStats channel[3];
  Pcg32 rng(11, 5);
  for (int k = 0; k < 20000; ++k) {
    const auto e = light.sample_emission({rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(e);
    const double weight =
        glm::dot(e->direction, e->point.normal) / (e->pdf_position * e->pdf_direction);
    for (int c = 0; c < 3; ++c) channel[c].add(e->radiance[c] * weight);
  }
  const S expected = (S(1, 2, 3) * T(0.5) + S(T(0.5), 0, 4) * T(1)) * std::numbers::pi;
  const S wrong = S(1, 2, 3) * T(1.5) * std::numbers::pi;
  for (int c = 0; c < 3; ++c) {
    INFO("channel " << c << ": mean " << channel[c].mean() << ", expected " << expected[c]);
    CHECK_FALSE(testing::student_t_test(channel[c], expected[c]).rejects(alpha));
    if (wrong[c] != expected[c]) CHECK(testing::student_t_test(channel[c], wrong[c]).rejects(alpha));
  }
}

TEST_CASE("TriangleLights: per-triangle radiances are checked", "[lights]") {
  using S = Rgb<float>;
  const auto triangles = three_triangles<float>();
  CHECK_THROWS_AS(TriangleLights<S>(triangles, std::vector<S>(2, S(1))), std::invalid_argument);
  CHECK_THROWS_AS(TriangleLights<S>(triangles, std::vector<S>{}), std::invalid_argument);
  std::vector<S> negative(3, S(1));
  negative[1] = S(1, -1, 1);
  std::string message;
  try {
    TriangleLights<S> light(triangles, negative);
  } catch (const std::invalid_argument& e) {
    message = e.what();
  }
  CHECK(message.find("triangle 1") != std::string::npos);
  std::vector<S> nan(3, S(1));
  nan[2] = S(std::nanf(""), 0, 0);
  CHECK_THROWS_AS(TriangleLights<S>(triangles, nan), std::invalid_argument);
  CHECK_THROWS_AS(TriangleLights<S>(triangles, S(-1)), std::invalid_argument);
}
