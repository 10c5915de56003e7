// Tests of the reference emitters: TriangleLights, DirectionalLight, BackgroundLight and
// LightSet (sampling against densities, normalisation, conventions, bad input).
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <segpath/core/geometry.hpp>
#include <segpath/core/rng.hpp>
#include <segpath/lights/background_light.hpp>
#include <segpath/lights/directional_light.hpp>
#include <segpath/lights/light_set.hpp>
#include <segpath/lights/point_light.hpp>
#include <segpath/lights/triangle_light.hpp>
#include <segpath/testing/chi_square.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/statistics.hpp>
#include <stdexcept>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

static_assert(SampledEmitter<TriangleLights<float>, float>);
static_assert(SampledEmitter<TriangleLights<Rgb<double>>, Rgb<double>>);
static_assert(SampledEmitter<DirectionalLight<Rgb<float>>, Rgb<float>>);
static_assert(SampledEmitter<DirectionalLight<double>, double>);
static_assert(SampledEmitter<BackgroundLight<Rgb<float>>, Rgb<float>>);
static_assert(SampledEmitter<BackgroundLight<double>, double>);
static_assert(SampledEmitter<LightSet<TriangleLights<float>, PointLight<float>>, float>);
static_assert(SampledEmitter<LightSet<DirectionalLight<Rgb<double>>, BackgroundLight<Rgb<double>>>,
                             Rgb<double>>);

namespace {

const double alpha = testing::sidak_alpha(testing::family_alpha, testing::sampler_suite_size);

/// Three triangles of different areas and orientations around a zero-area one (id 13).
template <class T>
std::vector<EmissiveTriangle<T>> test_triangles() {
  std::vector<EmissiveTriangle<T>> t(4);
  t[0] = {Vec3<T>(0, 0, 0), Vec3<T>(1, 0, 0), Vec3<T>(0, 1, 0), 10, 1,
          Vec3<T>(0, 0, 0)};  // area 0.5, +z
  t[1] = {Vec3<T>(2, 0, 0), Vec3<T>(2, 0, 2), Vec3<T>(2, 1, 0), 11, 1,
          Vec3<T>(0, 0, 0)};  // area 1, -x
  t[2] = {Vec3<T>(0, 0, 3), Vec3<T>(1, 1, 3), Vec3<T>(2, 2, 3), 13, 1, Vec3<T>(0, 0, 0)};  // area 0
  t[3] = {Vec3<T>(0, 0, 1), Vec3<T>(0, 3, 1), Vec3<T>(1, 0, 1), 12, 2,
          Vec3<T>(0, 0, -1)};  // area 1.5, -z given
  return t;
}

/// The cornell box 1 emitter (cornell-boxes.md), ids 100 and 101.
template <class T>
std::vector<EmissiveTriangle<T>> cornell_light_triangles() {
  const T z = T(1.26002);
  return {{Vec3<T>(T(-0.25), T(0.25), z), Vec3<T>(T(0.25), T(-0.25), z),
           Vec3<T>(T(-0.25), T(-0.25), z), 100},
          {Vec3<T>(T(0.25), T(-0.25), z), Vec3<T>(T(-0.25), T(0.25), z),
           Vec3<T>(T(0.25), T(0.25), z), 101}};
}

/// (b1, b2) barycentrics of p in triangle (a, b, c) (least squares on the plane).
inline glm::dvec2 barycentric(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b,
                              const glm::dvec3& c) {
  const glm::dvec3 e1 = b - a, e2 = c - a, d = p - a;
  const double d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
  const double r1 = glm::dot(d, e1), r2 = glm::dot(d, e2);
  const double det = d11 * d22 - d12 * d12;
  return {(d22 * r1 - d12 * r2) / det, (d11 * r2 - d12 * r1) / det};
}

/// Maps a point of triangle i to (i + s, t) where (s, t) = the inverse of the uniform
/// triangle warp: uniform on the triangle <=> uniform on the unit square.
template <class T>
glm::dvec2 triangle_chart(const std::vector<EmissiveTriangle<T>>& tris, std::uint32_t index,
                          const Vec3<T>& p) {
  const auto& t = tris[index];
  const glm::dvec2 b =
      barycentric(glm::dvec3(p), glm::dvec3(t.p0), glm::dvec3(t.p1), glm::dvec3(t.p2));
  const double s = std::clamp(1.0 - b.x, 0.0, 1.0);
  const double v = s > 0 ? std::clamp(b.y / s, 0.0, 1.0) : 0.0;
  return {index + s * s, v};
}

template <class T>
const std::array<T, 2> extreme_uniforms{T(0), T(1) - T(0x1p-24)};

template <class T>
bool finite_point(const SurfacePoint<T>& p) {
  return is_finite(p.position) && is_finite(p.normal);
}

}  // namespace

// ---------------------------------------------------------------------------------------
// TriangleLights

TEMPLATE_TEST_CASE("TriangleLights: normals, areas, ids and one-sided radiance", "[lights]", float,
                   double) {
  using T = TestType;
  const TriangleLights<Rgb<T>> light(test_triangles<T>(), Rgb<T>(1, 2, 3));
  CHECK(light.size() == 4);
  CHECK(light.total_area() == Approx(3.0));
  CHECK(light.area(2) == T(0));
  CHECK(light.normal(0) == Vec3<T>(0, 0, 1));
  CHECK(light.normal(1) == Vec3<T>(-1, 0, 0));  // winding: (0, 0, 2) x (0, 1, 0) = (-2, 0, 0)
  CHECK(light.normal(3) == Vec3<T>(0, 0, -1));
  CHECK(light.find(12) == std::optional<std::uint32_t>(3));
  CHECK_FALSE(light.find(14).has_value());

  const auto on0 = SurfacePoint<T>::on_surface(Vec3<T>(T(0.2), T(0.2), 0), Vec3<T>(0, 0, 1), 10);
  CHECK(light.radiance(EmissionQuery<T>{on0, glm::normalize(Vec3<T>(1, 0, 1))}) == Rgb<T>(1, 2, 3));
  CHECK(light.radiance(EmissionQuery<T>{on0, Vec3<T>(0, 0, -1)}) == Rgb<T>(0));  // behind
  auto other = on0;
  other.primitive_id = 14;
  CHECK(light.radiance(EmissionQuery<T>{other, Vec3<T>(0, 0, 1)}) == Rgb<T>(0));
  auto degenerate = on0;
  degenerate.primitive_id = 13;
  CHECK(light.radiance(EmissionQuery<T>{degenerate, Vec3<T>(0, 0, 1)}) == Rgb<T>(0));
  auto as_point = on0;
  as_point.kind = PointKind::point;
  CHECK(light.radiance(EmissionQuery<T>{as_point, Vec3<T>(0, 0, 1)}) == Rgb<T>(0));
  CHECK(light.pdf_towards(EmitterPdfTowardsQuery<T>{other, on0}) == Approx(T(1) / T(3)));
  CHECK(light.pdf_towards(EmitterPdfTowardsQuery<T>{on0, degenerate}) == T(0));
}

TEMPLATE_TEST_CASE("TriangleLights: the cornell box 1 emitter faces down", "[lights]", float,
                   double) {
  using T = TestType;
  const TriangleLights<Rgb<T>> light(cornell_light_triangles<T>(), Rgb<T>(T(25.03329849)));
  CHECK(light.total_area() == Approx(0.25));
  CHECK(light.normal(0) == Vec3<T>(0, 0, -1));
  CHECK(light.normal(1) == Vec3<T>(0, 0, -1));
  // Irradiance on the floor point below the centre: L * (projected solid angle), checked by
  // quadrature of L cos cos / d^2 over the square against the sample mean.
  const auto x = SurfacePoint<T>::on_surface(Vec3<T>(0, 0, T(-1.28002)), Vec3<T>(0, 0, 1));
  const double h = 1.26002 + 1.28002;
  const double exact = 25.03329849 * testing::integrate_2d(
                                         [&](const glm::dvec2& p) {
                                           const double d2 = p.x * p.x + p.y * p.y + h * h;
                                           return h * h / (d2 * d2);
                                         },
                                         {-0.25, -0.25}, {0.25, 0.25}, 4, 4);
  testing::RunningStats stats;
  Pcg32 rng(3, 0);
  for (int i = 0; i < 20000; ++i) {
    const auto s =
        light.sample_towards(EmitterTowardsQuery<T>{x, rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(s);
    stats.add(double(s->radiance.g * geometry_term(Segment<T>{x, s->point}) / s->pdf));
  }
  CHECK_FALSE(testing::student_t_test(stats, exact).rejects(1e-4));
}

TEMPLATE_TEST_CASE("TriangleLights: sampled densities equal the pdf functions", "[lights]", float,
                   double) {
  using T = TestType;
  const TriangleLights<T> light(test_triangles<T>(), T(2));
  const auto receiver = SurfacePoint<T>::on_surface(Vec3<T>(1, 1, 2), Vec3<T>(0, 0, -1));
  Pcg32 rng(5, 0);
  for (int i = 0; i < 2000; ++i) {
    const auto e = light.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(e);
    CHECK(e->point.primitive_id != 13);
    CHECK(e->point.material_id == (e->point.primitive_id == 12 ? 2u : 1u));
    const auto pdf = light.pdf_emission(EmissionPdfQuery<T>{e->point, e->direction});
    CHECK(pdf.position == Approx(e->pdf_position).epsilon(1e-5));
    CHECK(pdf.direction == Approx(e->pdf_direction).epsilon(1e-5));
    CHECK(e->pdf_position == Approx(1.0 / 3.0).epsilon(1e-5));
    CHECK(light.radiance(EmissionQuery<T>{e->point, e->direction}) == e->radiance);

    const auto s =
        light.sample_towards(EmitterTowardsQuery<T>{receiver, rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(s);
    CHECK(light.pdf_towards(EmitterPdfTowardsQuery<T>{receiver, s->point}) ==
          Approx(s->pdf).epsilon(1e-5));
    const Vec3<T> to_receiver = glm::normalize(receiver.position - s->point.position);
    CHECK(light.radiance(EmissionQuery<T>{s->point, to_receiver}) == s->radiance);
  }
}

TEMPLATE_TEST_CASE("TriangleLights: the emission direction density integrates to 1", "[lights]",
                   float, double) {
  using T = TestType;
  const TriangleLights<T> light(test_triangles<T>(), T(1));
  for (std::uint32_t id : {10u, 11u, 12u}) {
    const auto i = *light.find(id);
    const auto y = SurfacePoint<T>::on_surface(Vec3<T>(0), light.normal(i), id);
    const Frame<double> frame = Frame<double>::from_normal(glm::dvec3(light.normal(i)));
    // In the normal's frame the pdf's jump at the horizon is a panel boundary.
    const double total = testing::integrate_sphere([&](const glm::dvec3& local) {
      return double(
          light.pdf_emission(EmissionPdfQuery<T>{y, Vec3<T>(frame.to_world(local))}).direction);
    });
    CHECK(total == Approx(1.0).epsilon(1e-5));
  }
}

TEMPLATE_TEST_CASE(
    "TriangleLights: extreme uniforms give finite samples, zero-area triangles are never drawn",
    "[lights]", float, double) {
  using T = TestType;
  const TriangleLights<T> light(test_triangles<T>(), T(1));
  const auto receiver = SurfacePoint<T>::on_surface(Vec3<T>(1, 1, 2), Vec3<T>(0, 0, -1));
  for (T a : extreme_uniforms<T>)
    for (T b : extreme_uniforms<T>)
      for (T c : extreme_uniforms<T>)
        for (T d : extreme_uniforms<T>)
          for (T sel : extreme_uniforms<T>) {
            const auto e =
                light.sample_emission(EmissionSampleQuery<T>{Vec2<T>(a, b), Vec2<T>(c, d), sel});
            if (e) {
              CHECK(finite_point(e->point));
              CHECK(is_finite(e->direction));
              CHECK(std::isfinite(e->pdf_direction));
              CHECK(e->pdf_direction > T(0));
            }
            const auto s =
                light.sample_towards(EmitterTowardsQuery<T>{receiver, Vec2<T>(a, b), sel});
            REQUIRE(s);
            CHECK(finite_point(s->point));
            CHECK(s->point.primitive_id != 13);
          }
  // u_select exactly on and around the cumulative-area boundaries (0.5/3 and 1.5/3, the
  // zero-width interval of triangle 2 sits at 1.5/3).
  for (double boundary : {0.5 / 3.0, 1.5 / 3.0}) {
    for (int k = -4; k <= 4; ++k) {
      const T sel =
          std::nextafter(T(boundary), T(k < 0 ? 0 : 1)) + T(k) * std::numeric_limits<T>::epsilon();
      const auto s =
          light.sample_towards(EmitterTowardsQuery<T>{receiver, Vec2<T>(T(0.5), T(0.5)), sel});
      REQUIRE(s);
      CHECK(s->point.primitive_id != 13);
    }
  }
  Pcg32 rng(9, 0);
  for (int i = 0; i < 100000; ++i) {
    const auto s =
        light.sample_towards(EmitterTowardsQuery<T>{receiver, rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(s);
    if (s->point.primitive_id == 13) FAIL("a zero-area triangle was sampled");
  }
}

TEMPLATE_TEST_CASE("TriangleLights rejects bad parameters", "[lights]", float, double) {
  using T = TestType;
  using Tri = EmissiveTriangle<T>;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const Tri good{Vec3<T>(0, 0, 0), Vec3<T>(1, 0, 0), Vec3<T>(0, 1, 0), 1};
  CHECK_NOTHROW(TriangleLights<T>({good}, T(1)));
  CHECK_THROWS_AS(TriangleLights<T>({}, T(1)), std::invalid_argument);
  Tri degenerate{Vec3<T>(0, 0, 0), Vec3<T>(1, 1, 1), Vec3<T>(2, 2, 2), 2};
  CHECK_THROWS_AS(TriangleLights<T>({degenerate}, T(1)), std::invalid_argument);  // total area 0
  CHECK_NOTHROW(TriangleLights<T>({degenerate, good}, T(1)));
  CHECK_THROWS_AS(TriangleLights<T>({good, good}, T(1)), std::invalid_argument);  // repeated id
  Tri no_id = good;
  no_id.primitive_id = invalid_id;
  CHECK_THROWS_AS(TriangleLights<T>({no_id}, T(1)), std::invalid_argument);
  Tri bad_vertex = good;
  bad_vertex.p1.x = nan;
  CHECK_THROWS_AS(TriangleLights<T>({bad_vertex}, T(1)), std::invalid_argument);
  Tri tilted = good;
  tilted.normal = Vec3<T>(1, 0, 1);
  CHECK_THROWS_AS(TriangleLights<T>({tilted}, T(1)), std::invalid_argument);
  Tri nan_normal = good;
  nan_normal.normal = Vec3<T>(0, 0, nan);
  CHECK_THROWS_AS(TriangleLights<T>({nan_normal}, T(1)), std::invalid_argument);
  CHECK_THROWS_AS(TriangleLights<T>({good}, T(-1)), std::invalid_argument);
  CHECK_THROWS_AS(TriangleLights<T>({good}, nan), std::invalid_argument);
  CHECK_THROWS_AS(TriangleLights<Rgb<T>>({good}, Rgb<T>(1, -1, 1)), std::invalid_argument);
}

TEMPLATE_TEST_CASE("TriangleLights: positions are uniform by area over all triangles",
                   "[lights][chi2][stat]", float, double) {
  using T = TestType;
  using namespace segpath::testing;
  const auto tris = test_triangles<T>();
  const TriangleLights<T> light(tris, T(1));
  ChiSquare2DConfig config;
  config.lo = {0.0, 0.0};
  config.hi = {4.0, 1.0};
  config.cells_x = 32;
  config.cells_y = 16;
  // Chart density: triangle i occupies [i, i + 1) x [0, 1) with probability area_i / A.
  const auto chart_pdf = [&](const glm::dvec2& p) {
    const auto i = std::min<std::size_t>(static_cast<std::size_t>(p.x), 3);
    return double(light.area(i)) / double(light.total_area());
  };
  const auto receiver = SurfacePoint<T>::on_surface(Vec3<T>(1, 1, 2), Vec3<T>(0, 0, -1));
  const auto towards = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s =
        light.sample_towards(EmitterTowardsQuery<T>{receiver, rng.uniform2<T>(), rng.uniform<T>()});
    if (!s) return std::nullopt;
    return triangle_chart(tris, *light.find(s->point.primitive_id), s->point.position);
  };
  const auto report = chi_square_2d(towards, chart_pdf, config, 21);
  INFO(report.table);
  CHECK(report.failed_samples == 0);
  CHECK(report.integral_of_pdf == Approx(1.0).epsilon(1e-9));
  CHECK_FALSE(report.rejects(alpha));

  const auto emission = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s = light.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    if (!s) return std::nullopt;
    return triangle_chart(tris, *light.find(s->point.primitive_id), s->point.position);
  };
  const auto report_emission = chi_square_2d(emission, chart_pdf, config, 22);
  INFO(report_emission.table);
  CHECK_FALSE(report_emission.rejects(alpha));

  // Power: choosing triangles by count instead of by area is rejected.
  const auto by_count = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    static constexpr std::array<std::uint32_t, 3> ids{10, 11, 12};
    const std::uint32_t id =
        ids[std::min(2u, static_cast<std::uint32_t>(rng.uniform<double>() * 3))];
    const TriangleLights<T> single({tris[*light.find(id)]}, T(1));
    const auto s = single.sample_towards(EmitterTowardsQuery<T>{receiver, rng.uniform2<T>(), T(0)});
    return triangle_chart(tris, *light.find(id), s->point.position);
  };
  ChiSquare2DConfig small = config;
  small.samples = 20000;
  CHECK(chi_square_2d(by_count, chart_pdf, small, 23).rejects(alpha));
}

TEMPLATE_TEST_CASE("TriangleLights: emission directions are cosine-distributed",
                   "[lights][chi2][stat]", float, double) {
  using T = TestType;
  using namespace segpath::testing;
  const auto tris = test_triangles<T>();
  const TriangleLights<T> light(tris, T(1));
  ChiSquare2DConfig config;
  config.lo = {-1.0, 0.0};
  config.hi = {1.0, 2.0 * pi<double>};
  config.cells_x = 32;  // even: the horizon cos = 0 is a cell boundary
  config.cells_y = 32;
  // Local (cos theta, phi) about the sampled triangle's normal; pdf_emission supplies the
  // density, so emission directions of all three orientations share one histogram.
  const auto local = [&](const SurfacePoint<T>& y, const Vec3<T>& w) {
    return Frame<double>::from_normal(glm::dvec3(y.normal)).to_local(glm::dvec3(w));
  };
  const SurfacePoint<T> reference = SurfacePoint<T>::on_surface(Vec3<T>(0), Vec3<T>(0, 0, 1), 10);
  const auto pdf = [&](const glm::dvec2& p) {
    return double(
        light.pdf_emission(EmissionPdfQuery<T>{reference, Vec3<T>(cos_theta_phi_to_direction(p))})
            .direction);
  };
  const auto sample = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s = light.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    if (!s) return std::nullopt;
    return direction_to_cos_theta_phi(local(s->point, s->direction));
  };
  const auto report = chi_square_2d(sample, pdf, config, 31);
  INFO(report.table);
  CHECK(report.failed_samples < 10);
  CHECK(report.integral_of_pdf == Approx(1.0).epsilon(1e-6));
  CHECK_FALSE(report.rejects(alpha));

  // Power: uniform hemisphere directions are rejected.
  const auto uniform = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    return direction_to_cos_theta_phi(
        glm::dvec3(square_to_uniform_hemisphere(rng.uniform2<double>())));
  };
  ChiSquare2DConfig small = config;
  small.samples = 20000;
  CHECK(chi_square_2d(uniform, pdf, small, 32).rejects(alpha));
}

// ---------------------------------------------------------------------------------------
// DirectionalLight

namespace {
/// The disk frame's polar chart (rho^2 / r^2, phi / (2 pi)): uniform on the disk <=>
/// uniform on the unit square. `to_light` is the disk's normal, `centre` its centre.
inline std::optional<glm::dvec2> disk_chart(const glm::dvec3& origin, const glm::dvec3& centre,
                                            const glm::dvec3& to_light, double radius) {
  const Frame<double> frame = Frame<double>::from_normal(to_light);
  const glm::dvec3 local = frame.to_local(origin - centre);
  if (std::abs(local.z) > 1e-4 * radius)
    return glm::dvec2(-1, -1);  // off the disk's plane: outside
  double phi = std::atan2(local.y, local.x);
  if (phi < 0) phi += 2 * pi<double>;
  return glm::dvec2((local.x * local.x + local.y * local.y) / (radius * radius),
                    std::min(phi / (2 * pi<double>), 1.0));
}
}  // namespace

TEMPLATE_TEST_CASE("DirectionalLight: delta convention and irradiance", "[lights]", float, double) {
  using T = TestType;
  const Vec3<T> d = glm::normalize(Vec3<T>(-1, T(1.5), -1));
  const DirectionalLight<Rgb<T>> sun(Vec3<T>(-2, 3, -2), Rgb<T>(10, 4, 0), Vec3<T>(0, 0, 0),
                                     T(2.5));
  CHECK(glm::length(sun.direction() - d) < T(1e-6));
  const auto y = sun.point();
  CHECK(y.kind == PointKind::direction);
  CHECK(y.position == -sun.direction());
  const auto x = SurfacePoint<T>::on_surface(Vec3<T>(0, 0, T(-1.28)), Vec3<T>(0, 0, 1));
  const auto s = sun.sample_towards(EmitterTowardsQuery<T>{x, Vec2<T>(T(0.3), T(0.6))});
  REQUIRE(s);
  CHECK(s->pdf == T(1));
  CHECK(s->point.position == y.position);
  // L_e G / p = E cos: the floor receives E (n . -d).
  const Rgb<T> e = s->radiance * (geometry_term(Segment<T>{x, s->point}) / s->pdf);
  CHECK(e.r == Approx(10 * -d.z).epsilon(1e-5));
  CHECK(e.g == Approx(4 * -d.z).epsilon(1e-5));
  CHECK(sun.pdf_towards(EmitterPdfTowardsQuery<T>{x, s->point}) == T(1));
  CHECK(sun.radiance(EmissionQuery<T>{y, -s->point.position}) == Rgb<T>(10, 4, 0));
  // Any other direction endpoint, and finite points, are not the sun.
  const auto near = detail::direction_endpoint(glm::normalize(y.position + Vec3<T>(0, 0, T(1e-3))));
  CHECK(sun.radiance(EmissionQuery<T>{near, Vec3<T>(0, 0, 1)}) == Rgb<T>(0));
  CHECK(sun.pdf_towards(EmitterPdfTowardsQuery<T>{x, near}) == T(0));
  CHECK(sun.pdf_emission(EmissionPdfQuery<T>{x, Vec3<T>(0, 0, 1)}).position == T(0));
  CHECK_FALSE(sun.sample_towards(EmitterTowardsQuery<T>{y, Vec2<T>(0, 0)}).has_value());
}

TEMPLATE_TEST_CASE("DirectionalLight: emission rays start on the disk upstream of the scene",
                   "[lights]", float, double) {
  using T = TestType;
  const Vec3<T> c(1, -2, T(0.5));
  const T r = T(1.75);
  const DirectionalLight<T> sun(Vec3<T>(1, 2, -3), T(3), c, r);
  const Vec3<T> d = sun.direction();
  Pcg32 rng(41, 0);
  testing::RunningStats hits;
  for (int i = 0; i < 20000; ++i) {
    const auto s = sun.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(s);
    CHECK(s->point.position == -d);
    CHECK(s->pdf_position == T(1));
    CHECK(s->pdf_direction == Approx(1.0 / (pi<double> * r * r)).epsilon(1e-6));
    const Vec3<T> o = s->direction;  // the ray origin, see DirectionalLight's comment
    CHECK(glm::dot(o - c, -d) ==
          Approx(r).epsilon(1e-4));  // on the disk's plane, outside the sphere
    const auto pdf = sun.pdf_emission(EmissionPdfQuery<T>{s->point, o});
    CHECK(pdf.position == s->pdf_position);
    CHECK(pdf.direction == Approx(s->pdf_direction).epsilon(1e-5));
    // Any point of the ray gives the same density.
    CHECK(sun.pdf_emission(EmissionPdfQuery<T>{s->point, o + d * T(2)}).direction ==
          Approx(s->pdf_direction).epsilon(1e-5));
    // Light-start estimate of the power hitting a unit sphere inside the bound: photons of
    // weight E / pdf_direction that hit it; the expectation is E pi 1^2.
    const Vec3<T> oc = o - c;
    const T b = glm::dot(oc, d);
    const T disc = b * b - (glm::dot(oc, oc) - T(1));
    hits.add(disc > T(0) ? double(s->radiance / s->pdf_direction) : 0.0);
  }
  CHECK_FALSE(testing::student_t_test(hits, 3.0 * pi<double>).rejects(1e-4));
  CHECK(sun.pdf_emission(EmissionPdfQuery<T>{sun.point(), c + Vec3<T>(3, 0, 0) * r}).direction ==
        T(0));
}

TEMPLATE_TEST_CASE("DirectionalLight: the disk density integrates to 1", "[lights]", float,
                   double) {
  using T = TestType;
  const Vec3<T> c(1, -2, T(0.5));
  const T r = T(1.75);
  const DirectionalLight<T> sun(Vec3<T>(1, 2, -3), T(3), c, r);
  const Frame<double> frame = Frame<double>::from_normal(glm::dvec3(-sun.direction()));
  // Polar coordinates on the plane through c perpendicular to d, out to 2 r (the jump at r
  // is a panel boundary): the integral of rho * pdf.
  const auto f = [&](const glm::dvec2& p) {
    const glm::dvec3 q = glm::dvec3(c) + frame.tangent * (p.x * std::cos(p.y)) +
                         frame.bitangent * (p.x * std::sin(p.y));
    return p.x * double(sun.pdf_emission(EmissionPdfQuery<T>{sun.point(), Vec3<T>(q)}).direction);
  };
  const double inside =
      testing::integrate_2d(f, {0.0, 0.0}, {double(r) * (1 - 1e-6), 2 * pi<double>}, 4, 4);
  const double outside = testing::integrate_2d(f, {double(r) * (1 + 1e-6), 0.0},
                                               {2.0 * double(r), 2 * pi<double>}, 4, 4);
  CHECK(inside == Approx(1.0).epsilon(1e-5));
  CHECK(outside == 0.0);
}

TEMPLATE_TEST_CASE("DirectionalLight: disk points are uniform", "[lights][chi2][stat]", float,
                   double) {
  using T = TestType;
  using namespace segpath::testing;
  const Vec3<T> c(1, -2, T(0.5));
  const T r = T(1.75);
  const DirectionalLight<T> sun(Vec3<T>(1, 2, -3), T(3), c, r);
  const glm::dvec3 to_light(-sun.direction());
  const glm::dvec3 disk_centre = glm::dvec3(c) + to_light * double(r);
  ChiSquare2DConfig config;
  // Chart density: the light's own disk density times the chart's Jacobian pi r^2.
  const auto pdf = [&](const glm::dvec2& p) {
    const double rho = std::sqrt(p.x) * double(r);
    const glm::dvec3 q = disk_centre + Frame<double>::from_normal(to_light).to_world(
                                           {rho * std::cos(2 * pi<double> * p.y),
                                            rho * std::sin(2 * pi<double> * p.y), 0});
    return pi<double> * double(r) * double(r) *
           double(sun.pdf_emission(EmissionPdfQuery<T>{sun.point(), Vec3<T>(q)}).direction);
  };
  const auto sample = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s = sun.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    if (!s) return std::nullopt;
    return disk_chart(glm::dvec3(s->direction), disk_centre, to_light, double(r));
  };
  const auto report = chi_square_2d(sample, pdf, config, 51);
  INFO(report.table);
  CHECK(report.failed_samples == 0);
  CHECK(report.integral_of_pdf == Approx(1.0).epsilon(1e-5));
  CHECK_FALSE(report.rejects(alpha));

  // Power: the polar map without the square root (points crowd the centre) is rejected.
  const auto crowded = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const glm::dvec2 u = rng.uniform2<double>();
    return glm::dvec2(u.x * u.x, u.y);
  };
  ChiSquare2DConfig small = config;
  small.samples = 20000;
  CHECK(chi_square_2d(crowded, pdf, small, 52).rejects(alpha));
}

TEMPLATE_TEST_CASE("DirectionalLight and BackgroundLight reject bad parameters", "[lights]", float,
                   double) {
  using T = TestType;
  const T nan = std::numeric_limits<T>::quiet_NaN();
  const T inf = std::numeric_limits<T>::infinity();
  const Vec3<T> c(0);
  CHECK_NOTHROW(DirectionalLight<T>(Vec3<T>(0, 0, -1), T(1), c, T(1)));
  CHECK_THROWS_AS(DirectionalLight<T>(Vec3<T>(0, 0, 0), T(1), c, T(1)), std::invalid_argument);
  CHECK_THROWS_AS(DirectionalLight<T>(Vec3<T>(0, nan, 1), T(1), c, T(1)), std::invalid_argument);
  CHECK_THROWS_AS(DirectionalLight<T>(Vec3<T>(0, 0, -1), T(-1), c, T(1)), std::invalid_argument);
  CHECK_THROWS_AS(DirectionalLight<Rgb<T>>(Vec3<T>(0, 0, -1), Rgb<T>(1, inf, 1), c, T(1)),
                  std::invalid_argument);
  CHECK_THROWS_AS(DirectionalLight<T>(Vec3<T>(0, 0, -1), T(1), c, T(0)), std::invalid_argument);
  CHECK_THROWS_AS(DirectionalLight<T>(Vec3<T>(0, 0, -1), T(1), c, -T(1)), std::invalid_argument);
  CHECK_THROWS_AS(DirectionalLight<T>(Vec3<T>(0, 0, -1), T(1), c, inf), std::invalid_argument);
  CHECK_THROWS_AS(DirectionalLight<T>(Vec3<T>(0, 0, -1), T(1), Vec3<T>(nan), T(1)),
                  std::invalid_argument);
  CHECK_NOTHROW(BackgroundLight<T>(T(1), c, T(1)));
  CHECK_THROWS_AS(BackgroundLight<T>(T(-1), c, T(1)), std::invalid_argument);
  CHECK_THROWS_AS(BackgroundLight<T>(nan, c, T(1)), std::invalid_argument);
  CHECK_THROWS_AS(BackgroundLight<T>(T(1), c, T(0)), std::invalid_argument);
  CHECK_THROWS_AS(BackgroundLight<T>(T(1), Vec3<T>(inf), T(1)), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------
// BackgroundLight

TEMPLATE_TEST_CASE("BackgroundLight: radiance, densities and the irradiance pi L", "[lights]",
                   float, double) {
  using T = TestType;
  const Rgb<T> sky(T(135) / 255, T(206) / 255, T(250) / 255);
  const BackgroundLight<Rgb<T>> light(sky, Vec3<T>(0), T(2));
  const auto x =
      SurfacePoint<T>::on_surface(Vec3<T>(T(0.2), 0, 0), glm::normalize(Vec3<T>(1, 2, 3)));
  const auto p = SurfacePoint<T>::at_point(Vec3<T>(0, 1, 0));
  CHECK(light.radiance(EmissionQuery<T>{BackgroundLight<Rgb<T>>::point(Vec3<T>(0, 0, 1)),
                                        Vec3<T>(0, 0, 1)}) == sky);
  CHECK(light.radiance(EmissionQuery<T>{x, Vec3<T>(0, 0, 1)}) == Rgb<T>(0));
  testing::RunningStats irradiance;
  Pcg32 rng(61, 0);
  for (int i = 0; i < 4000; ++i) {
    for (const auto* receiver : {&x, &p}) {
      const auto s = light.sample_towards(
          EmitterTowardsQuery<T>{*receiver, rng.uniform2<T>(), rng.uniform<T>()});
      REQUIRE(s);
      CHECK(s->point.kind == PointKind::direction);
      CHECK(glm::length(s->point.position) == Approx(1.0).epsilon(1e-5));
      CHECK(light.pdf_towards(EmitterPdfTowardsQuery<T>{*receiver, s->point}) ==
            Approx(s->pdf).epsilon(1e-5));
      CHECK(light.radiance(EmissionQuery<T>{s->point, s->point.position}) == s->radiance);
      if (receiver == &x)
        irradiance.add(double(s->radiance.b * geometry_term(Segment<T>{x, s->point}) / s->pdf));
    }
    const auto e = light.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(e);
    const auto pdf = light.pdf_emission(EmissionPdfQuery<T>{e->point, e->direction});
    CHECK(pdf.position == Approx(e->pdf_position).epsilon(1e-5));
    CHECK(pdf.direction == Approx(e->pdf_direction).epsilon(1e-5));
    CHECK(glm::dot(e->direction - Vec3<T>(0), e->point.position) == Approx(2.0).epsilon(1e-4));
  }
  // Cosine sampling makes L G / p exactly pi L: zero variance.
  CHECK(irradiance.mean() == Approx(pi<double> * 250.0 / 255.0).epsilon(1e-5));
  CHECK(irradiance.variance() < 1e-8);
  // pdf_towards integrates to 1 over the sphere for both receivers.
  const Frame<double> frame = Frame<double>::from_normal(glm::dvec3(x.normal));
  for (const auto* receiver : {&x, &p}) {
    const double total = testing::integrate_sphere([&](const glm::dvec3& local) {
      const auto y = BackgroundLight<Rgb<T>>::point(Vec3<T>(frame.to_world(local)));
      return double(light.pdf_towards(EmitterPdfTowardsQuery<T>{*receiver, y}));
    });
    CHECK(total == Approx(1.0).epsilon(1e-5));
  }
  CHECK(light.pdf_towards(
            EmitterPdfTowardsQuery<T>{x, BackgroundLight<Rgb<T>>::point(-x.normal)}) == T(0));
  CHECK_FALSE(light.sample_towards(
      EmitterTowardsQuery<T>{BackgroundLight<Rgb<T>>::point(x.normal), Vec2<T>(0)}));
}

TEMPLATE_TEST_CASE("BackgroundLight and DirectionalLight: extreme uniforms give finite samples",
                   "[lights]", float, double) {
  using T = TestType;
  const BackgroundLight<T> sky(T(1), Vec3<T>(1, 2, 3), T(4));
  const DirectionalLight<T> sun(Vec3<T>(0, 0, -1), T(1), Vec3<T>(1, 2, 3), T(4));
  const auto x = SurfacePoint<T>::on_surface(Vec3<T>(0), Vec3<T>(0, 0, -1));
  const auto p = SurfacePoint<T>::at_point(Vec3<T>(0));
  for (T a : extreme_uniforms<T>)
    for (T b : extreme_uniforms<T>)
      for (T c : extreme_uniforms<T>)
        for (T d : extreme_uniforms<T>) {
          for (const auto& e :
               {sky.sample_emission(EmissionSampleQuery<T>{Vec2<T>(a, b), Vec2<T>(c, d), a}),
                sun.sample_emission(EmissionSampleQuery<T>{Vec2<T>(a, b), Vec2<T>(c, d), a})}) {
            REQUIRE(e);
            CHECK(finite_point(e->point));
            CHECK(is_finite(e->direction));
          }
          for (const auto* receiver : {&x, &p}) {
            const auto s = sky.sample_towards(EmitterTowardsQuery<T>{*receiver, Vec2<T>(a, b), c});
            if (s) {
              CHECK(finite_point(s->point));
              CHECK(std::isfinite(s->pdf));
              CHECK(s->pdf > T(0));
            }
          }
        }
}

TEMPLATE_TEST_CASE("BackgroundLight: sampled directions match pdf_towards and pdf_emission",
                   "[lights][chi2][stat]", float, double) {
  using T = TestType;
  using namespace segpath::testing;
  const BackgroundLight<T> light(T(1), Vec3<T>(1, 0, -1), T(3));
  ChiSquare2DConfig config;
  config.lo = {-1.0, 0.0};
  config.hi = {1.0, 2.0 * pi<double>};
  config.cells_x = 32;
  config.cells_y = 32;
  const Vec3<T> n = glm::normalize(Vec3<T>(-1, 2, T(0.5)));
  const auto x = SurfacePoint<T>::on_surface(Vec3<T>(0), n);
  const auto p = SurfacePoint<T>::at_point(Vec3<T>(0));
  // Global (cos theta, phi); the cosine lobe's horizon is not a cell boundary here, so
  // integrate each cell more finely.
  config.integration_panels = 8;
  std::uint64_t seed = 71;
  for (const auto* receiver : {&x, &p}) {
    const auto pdf = [&](const glm::dvec2& q) {
      return double(light.pdf_towards(EmitterPdfTowardsQuery<T>{
          *receiver, BackgroundLight<T>::point(Vec3<T>(cos_theta_phi_to_direction(q)))}));
    };
    const auto sample = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
      const auto s = light.sample_towards(
          EmitterTowardsQuery<T>{*receiver, rng.uniform2<T>(), rng.uniform<T>()});
      if (!s) return std::nullopt;
      return direction_to_cos_theta_phi(glm::dvec3(s->point.position));
    };
    const auto report = chi_square_2d(sample, pdf, config, seed++);
    INFO(report.table);
    CHECK(report.failed_samples < 10);
    CHECK(report.integral_of_pdf == Approx(1.0).epsilon(1e-4));
    CHECK_FALSE(report.rejects(alpha));
  }
  // Emission: the direction (uniform) and the disk point (uniform on its disk).
  config.integration_panels = 4;
  const auto uniform_pdf = [&](const glm::dvec2& q) {
    return double(light
                      .pdf_emission(EmissionPdfQuery<T>{
                          BackgroundLight<T>::point(Vec3<T>(cos_theta_phi_to_direction(q))),
                          Vec3<T>(1, 0, -1)})
                      .position);
  };
  const auto directions = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s = light.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    if (!s) return std::nullopt;
    return direction_to_cos_theta_phi(glm::dvec3(s->point.position));
  };
  const auto report = chi_square_2d(directions, uniform_pdf, config, seed++);
  INFO(report.table);
  CHECK(report.integral_of_pdf == Approx(1.0).epsilon(1e-6));
  CHECK_FALSE(report.rejects(alpha));

  ChiSquare2DConfig disk;
  const auto disk_sample = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s = light.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    if (!s) return std::nullopt;
    const glm::dvec3 w(s->point.position);
    return disk_chart(glm::dvec3(s->direction), glm::dvec3(1, 0, -1) + w * 3.0, w, 3.0);
  };
  // Uniform on the chart, through pdf_emission at a point on the disk (the constant density
  // times the chart's Jacobian pi r^2).
  const auto disk_pdf = [&](const glm::dvec2&) {
    const auto y = BackgroundLight<T>::point(Vec3<T>(0, 0, 1));
    return 9.0 * pi<double> *
           double(light.pdf_emission(EmissionPdfQuery<T>{y, Vec3<T>(1, 0, 2)}).direction);
  };
  const auto disk_report = chi_square_2d(disk_sample, disk_pdf, disk, seed++);
  INFO(disk_report.table);
  CHECK(disk_report.integral_of_pdf == Approx(1.0).epsilon(1e-6));
  CHECK_FALSE(disk_report.rejects(alpha));

  // Power: uniform-sphere directions for the surface receiver are rejected.
  const auto wrong = [&](Pcg32& rng) -> std::optional<glm::dvec2> {
    const auto s = light.sample_towards(EmitterTowardsQuery<T>{p, rng.uniform2<T>(), T(0)});
    return direction_to_cos_theta_phi(glm::dvec3(s->point.position));
  };
  const auto cosine_pdf = [&](const glm::dvec2& q) {
    return double(light.pdf_towards(EmitterPdfTowardsQuery<T>{
        x, BackgroundLight<T>::point(Vec3<T>(cos_theta_phi_to_direction(q)))}));
  };
  ChiSquare2DConfig small = config;
  small.samples = 20000;
  CHECK(chi_square_2d(wrong, cosine_pdf, small, seed++).rejects(alpha));
}

// ---------------------------------------------------------------------------------------
// LightSet

TEMPLATE_TEST_CASE("LightSet: uniform selection folded into consistent densities", "[lights]",
                   float, double) {
  using T = TestType;
  using S = Rgb<T>;
  const TriangleLights<S> area(cornell_light_triangles<T>(), S(T(25.03329849)));
  const DirectionalLight<S> sun(Vec3<T>(-1, T(1.5), -1), S(10, 4, 0), Vec3<T>(0), T(2.3));
  const BackgroundLight<S> sky(S(T(0.5), T(0.8), T(1)), Vec3<T>(0), T(2.3));
  const PointLight<S> bulb(Vec3<T>(0, T(-0.5), 1), S(T(70) / (4 * pi<T>)));
  const LightSet set(area, sun, sky, bulb);
  static_assert(decltype(set)::size == 4);

  // Ownership: the sun's endpoint belongs to the sun although the sky emits there too.
  CHECK(set.owner(sun.point()) == 1);
  CHECK(set.owner(BackgroundLight<S>::point(Vec3<T>(0, 0, 1))) == 2);
  CHECK(set.owner(bulb.point()) == 3);
  const auto on_area =
      SurfacePoint<T>::on_surface(Vec3<T>(0, 0, T(1.26002)), Vec3<T>(0, 0, -1), 101);
  CHECK(set.owner(on_area) == 0);
  CHECK(set.owner(SurfacePoint<T>::on_surface(Vec3<T>(0), Vec3<T>(0, 0, 1), 7)) == 4);
  CHECK(set.radiance(EmissionQuery<T>{sun.point(), Vec3<T>(0, 0, 1)}) == S(10, 4, 0));

  // Next-event estimate of the irradiance at a floor point: the sum of the four members'.
  const auto x =
      SurfacePoint<T>::on_surface(Vec3<T>(T(0.1), T(0.2), T(-1.28002)), Vec3<T>(0, 0, 1));
  const double h = 1.26002 + 1.28002;
  const double area_e = 25.03329849 * testing::integrate_2d(
                                          [&](const glm::dvec2& q) {
                                            const glm::dvec3 d(q.x - 0.1, q.y - 0.2, h);
                                            const double d2 = glm::dot(d, d);
                                            return h * h / (d2 * d2);
                                          },
                                          {-0.25, -0.25}, {0.25, 0.25}, 4, 4);
  const double sun_e = 10.0 / std::sqrt(1 + 2.25 + 1);
  const double sky_e = pi<double> * 0.5;
  const glm::dvec3 to_bulb = glm::dvec3(0, -0.5, 1) - glm::dvec3(x.position);
  const double bulb_e = 70.0 / (4 * pi<double>)*to_bulb.z / std::pow(glm::length(to_bulb), 3.0);
  testing::RunningStats red;
  std::array<int, 4> chosen{};
  Pcg32 rng(81, 0);
  for (int i = 0; i < 40000; ++i) {
    const auto s =
        set.sample_towards(EmitterTowardsQuery<T>{x, rng.uniform2<T>(), rng.uniform<T>()});
    REQUIRE(s);
    const std::size_t o = set.owner(s->point);
    REQUIRE(o < 4);
    ++chosen[o];
    CHECK(set.pdf_towards(EmitterPdfTowardsQuery<T>{x, s->point}) == Approx(s->pdf).epsilon(1e-5));
    const Vec3<T> to_x = s->point.kind == PointKind::direction
                             ? s->point.position
                             : glm::normalize(x.position - s->point.position);
    CHECK(set.radiance(EmissionQuery<T>{s->point, to_x}) == s->radiance);
    red.add(double(s->radiance.r * geometry_term(Segment<T>{x, s->point}) / s->pdf));

    const auto e = set.sample_emission(
        EmissionSampleQuery<T>{rng.uniform2<T>(), rng.uniform2<T>(), rng.uniform<T>()});
    if (!e) continue;
    const auto pdf = set.pdf_emission(EmissionPdfQuery<T>{e->point, e->direction});
    CHECK(pdf.position == Approx(e->pdf_position).epsilon(1e-5));
    CHECK(pdf.direction == Approx(e->pdf_direction).epsilon(1e-5));
  }
  for (int c : chosen) CHECK(std::abs(c - 10000) < 5 * std::sqrt(10000 * 0.75));
  const double expected = area_e + sun_e + sky_e + bulb_e;
  INFO("mean " << red.mean() << " +- " << red.standard_error() << ", expected " << expected);
  CHECK_FALSE(testing::student_t_test(red, expected).rejects(1e-4));
  // The test can fail: without the 1/n folded into the densities the mean would be a
  // quarter of this, many standard errors away.
  CHECK(std::abs(red.mean() / 4 - expected) > 10 * red.standard_error());
}

TEMPLATE_TEST_CASE("LightSet: extreme u_select stays in range", "[lights]", float, double) {
  using T = TestType;
  const LightSet set(TriangleLights<T>(test_triangles<T>(), T(1)),
                     BackgroundLight<T>(T(1), Vec3<T>(0), T(5)),
                     DirectionalLight<T>(Vec3<T>(0, 0, -1), T(1), Vec3<T>(0), T(5)));
  const auto x = SurfacePoint<T>::on_surface(Vec3<T>(1, 1, 2), Vec3<T>(0, 0, -1));
  for (T sel : extreme_uniforms<T>)
    for (T u : extreme_uniforms<T>) {
      const auto s = set.sample_towards(EmitterTowardsQuery<T>{x, Vec2<T>(u, u), sel});
      REQUIRE(s);
      CHECK(finite_point(s->point));
      CHECK(s->point.primitive_id != 13);
      const auto e = set.sample_emission(EmissionSampleQuery<T>{Vec2<T>(u, u), Vec2<T>(u, u), sel});
      if (e) CHECK(is_finite(e->direction));
    }
  CHECK(set.owner(set.sample_towards(EmitterTowardsQuery<T>{x, Vec2<T>(T(0.5)), T(0)})->point) ==
        0);
  CHECK(set.owner(set.sample_towards(EmitterTowardsQuery<T>{x, Vec2<T>(T(0.5)), T(0.5)})->point) ==
        1);
  CHECK(set.owner(set.sample_towards(EmitterTowardsQuery<T>{x, Vec2<T>(T(0.5)), T(1) - T(0x1p-24)})
                      ->point) == 2);
}
