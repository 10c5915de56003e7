// Chi-square goodness of fit of every sampler's `sample` against its own `pdf` (SPEC 4).
// Segments are 4-dimensional; each test says how it is charted:
//  - both ends random: a 4D histogram over the coordinates of both ends (sphere points by
//    (cos theta, phi), disk points by (rho^2 / r^2, phi), or the end found by tracing by the
//    direction it was traced in), expected counts by nested Gauss quadrature of pdf(s) times
//    the chart Jacobian over each cell;
//  - one end deterministic (Dirac junctions, point lights, approximate junctions): a 2D
//    histogram of the other end (chi_square_2d) with pdf(s) times that end's Jacobian.
// Each test also checks that the pdf integrates to the observed acceptance rate.
#include <segpath/kernels/dirac.hpp>
#include <segpath/kernels/disk.hpp>
#include <segpath/samplers/approximate.hpp>
#include <segpath/samplers/bridge.hpp>
#include <segpath/samplers/bsdf_directed.hpp>
#include <segpath/samplers/light_next.hpp>
#include <segpath/samplers/light_start.hpp>
#include <segpath/samplers/raytraced.hpp>
#include <segpath/samplers/uniform.hpp>

#include "sampler_test_support.hpp"
#include "support/catch.hpp"

using namespace sampler_test;

namespace {

/// Coordinates of both ends by two independent charts.
template <class T, class ChartX, class ChartY>
struct BothCharted {
  ChartX cx;
  ChartY cy;
  [[nodiscard]] std::array<double, 4> coordinates(const Segment<T>& s) const {
    const glm::dvec2 a = cx.coordinates(s.x), b = cy.coordinates(s.y);
    return {a.x, a.y, b.x, b.y};
  }
  /// The segment at c and the Jacobian d(x, y) / d(coordinates), or nullopt.
  [[nodiscard]] std::optional<std::pair<Segment<T>, double>> segment(const std::array<double, 4>& c) const {
    return std::pair{Segment<T>{cx.point({c[0], c[1]}), cy.point({c[2], c[3]})}, cx.jacobian() * cy.jacobian()};
  }
  [[nodiscard]] std::array<double, 4> lo() const { return {cx.lo.x, cx.lo.y, cy.lo.x, cy.lo.y}; }
  [[nodiscard]] std::array<double, 4> hi() const { return {cx.hi.x, cx.hi.y, cy.hi.x, cy.hi.y}; }
};

/// One end by a chart, the other by the direction from the charted end to it (the first hit
/// along it): dA = d^2 / |n . s^| d omega at the traced end. `traced_is_x` picks which end.
template <class T, class Scn, class Chart>
struct TracedFrom {
  const Scn* scene;
  Chart chart;
  bool traced_is_x;
  double cos_lo = -1, cos_hi = 1;
  [[nodiscard]] std::array<double, 4> coordinates(const Segment<T>& s) const {
    const SurfacePoint<T>& from = traced_is_x ? s.y : s.x;
    const SurfacePoint<T>& to = traced_is_x ? s.x : s.y;
    const glm::dvec2 a = chart.coordinates(from);
    const glm::dvec2 d = st::direction_to_cos_theta_phi(glm::normalize(glm::dvec3(to.position - from.position)));
    return traced_is_x ? std::array<double, 4>{d.x, d.y, a.x, a.y} : std::array<double, 4>{a.x, a.y, d.x, d.y};
  }
  [[nodiscard]] std::optional<std::pair<Segment<T>, double>> segment(const std::array<double, 4>& c) const {
    const glm::dvec2 a = traced_is_x ? glm::dvec2(c[2], c[3]) : glm::dvec2(c[0], c[1]);
    const glm::dvec2 dc = traced_is_x ? glm::dvec2(c[0], c[1]) : glm::dvec2(c[2], c[3]);
    const SurfacePoint<T> from = chart.point(a);
    const Vec3<T> d(st::cos_theta_phi_to_direction(dc));
    const auto hit = scene->intersect(IntersectQuery<T>{Ray<T>{from.position, d}});
    if (!hit) return std::nullopt;
    const double cosine = std::abs(double(glm::dot(hit->point.normal, d)));
    if (!(cosine > 0)) return std::nullopt;
    const double jac = chart.jacobian() * double(hit->distance) * double(hit->distance) / cosine;
    const Segment<T> s = traced_is_x ? Segment<T>{hit->point, from} : Segment<T>{from, hit->point};
    return std::pair{s, jac};
  }
  [[nodiscard]] std::array<double, 4> lo() const {
    return traced_is_x ? std::array<double, 4>{cos_lo, 0, chart.lo.x, chart.lo.y}
                       : std::array<double, 4>{chart.lo.x, chart.lo.y, cos_lo, 0};
  }
  [[nodiscard]] std::array<double, 4> hi() const {
    const double tau = 2 * std::numbers::pi;
    return traced_is_x ? std::array<double, 4>{cos_hi, tau, chart.hi.x, chart.hi.y}
                       : std::array<double, 4>{chart.hi.x, chart.hi.y, cos_hi, tau};
  }
};

/// |integral of pdf - acceptance rate| against the binomial standard error (a z-test at the
/// suite's alpha; exact agreement required when every sample was accepted).
void check_acceptance(double integral, std::uint64_t failed, std::uint64_t n) {
  const double acceptance = 1.0 - double(failed) / double(n);
  const double se = std::sqrt(acceptance * (1 - acceptance) / double(n));
  INFO("integral of pdf " << integral << ", acceptance " << acceptance << " (se " << se << ")");
  if (se == 0) {
    // Everything accepted: only the pdf's rounding (float: a few ulp per factor) remains.
    CHECK(std::abs(integral - acceptance) < 1e-5);
  } else {
    const double p = 2 * (1 - st::normal_cdf(std::abs(integral - acceptance) / se));
    CHECK(p >= chi_square_alpha());
  }
}

template <class T, class Smp, class Scn, class Map>
Report4D run_4d(const Smp& smp, const Scn& scene, const typename Smp::Technique& t, const Map& map,
                std::array<int, 4> cells, std::uint64_t seed) {
  Histogram4D h{map.lo(), map.hi(), cells};
  return chi_square_4d(
      [&](Pcg32& rng) -> std::optional<std::array<double, 4>> {
        const auto s = smp.sample(scene, t, rng);
        if (!s) return std::nullopt;
        return map.coordinates(s->segment);
      },
      [&](const std::array<double, 4>& c) {
        const auto s = map.segment(c);
        return s ? double(smp.pdf(scene, t, s->first)) * s->second : 0.0;
      },
      h, seed);
}

void check_report(const Report4D& r, std::uint64_t n) {
  INFO(r.result.table);
  CHECK(r.outside == 0);
  CHECK(r.result.zero_expected_hits == 0);
  CHECK_FALSE(r.result.rejects(chi_square_alpha()));
  check_acceptance(r.integral, r.failed, n);
}

void check_report(const st::ChiSquare2DReport& r, std::uint64_t n) {
  INFO(r.table);
  CHECK(r.outside_domain == 0);
  CHECK(r.zero_expected_hits == 0);
  CHECK_FALSE(r.rejects(chi_square_alpha()));
  check_acceptance(r.integral_of_pdf, r.failed_samples, n);
}

/// chi_square_2d of the free end of samples whose other end is fixed.
template <class T, class Smp, class Scn, class Chart>
st::ChiSquare2DReport run_2d(const Smp& smp, const Scn& scene, const typename Smp::Technique& t, const Chart& chart,
                             bool free_is_y, const SurfacePoint<T>& fixed, double extra_jacobian,
                             std::uint64_t seed, int cells_x = 16, int cells_y = 32) {
  st::ChiSquare2DConfig config;
  config.lo = chart.lo;
  config.hi = chart.hi;
  config.cells_x = cells_x;
  config.cells_y = cells_y;
  return st::chi_square_2d(
      [&](Pcg32& rng) -> std::optional<glm::dvec2> {
        const auto s = smp.sample(scene, t, rng);
        if (!s) return std::nullopt;
        const SurfacePoint<T>& end = free_is_y ? s->segment.y : s->segment.x;
        const SurfacePoint<T>& other = free_is_y ? s->segment.x : s->segment.y;
        if (other.position != fixed.position) return glm::dvec2(-1e300, -1e300);  // a hard failure
        return chart.coordinates(end);
      },
      [&](const glm::dvec2& c) {
        const SurfacePoint<T> p = chart.point(c);
        const Segment<T> s = free_is_y ? Segment<T>{fixed, p} : Segment<T>{p, fixed};
        return double(smp.pdf(scene, t, s)) * chart.jacobian() * extra_jacobian;
      },
      config, seed);
}

constexpr std::uint64_t n_samples = 1'000'000;
constexpr std::array<int, 4> sphere_cells{4, 8, 4, 8};

}  // namespace

TEMPLATE_TEST_CASE("uniform sampler: 4D chi-square on the sphere (N26)", "[samplers][stat]", float, double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  const UniformSegmentSampler<Scn> smp;
  const BothCharted<T, SphereChart<T>, SphereChart<T>> map{{&scene}, {&scene, 0.1}};
  check_report(run_4d<T>(smp, scene, {}, map, sphere_cells, 11), n_samples);
}

TEMPLATE_TEST_CASE("ray-traced sampler: 4D chi-square on the sphere (N27)", "[samplers][stat]", float, double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  const RaytracedSegmentSampler<Scn> smp;
  const BothCharted<T, SphereChart<T>, SphereChart<T>> map{{&scene}, {&scene, 0.1}};
  check_report(run_4d<T>(smp, scene, {}, map, sphere_cells, 12), n_samples);
}

TEMPLATE_TEST_CASE("BSDF-directed sampler: 4D chi-square on the sphere (N28)", "[samplers][stat]", float, double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  const BsdfDirectedSegmentSampler<Scn> smp;
  // Only x with n_x . s^' > 0 (the lower half, cos theta < 0: a cell boundary) can sample.
  const typename BsdfDirectedSegmentSampler<Scn>::Technique t{Vec3<T>(0, 0, 1)};
  const BothCharted<T, SphereChart<T>, SphereChart<T>> map{{&scene}, {&scene, 0.1}};
  check_report(run_4d<T>(smp, scene, t, map, sphere_cells, 13), n_samples);
}

TEMPLATE_TEST_CASE("the 4D harness rejects a wrong density", "[samplers][stat]", float, double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  // Ray-traced samples (x anywhere) against the BSDF-directed density (x in the lower half).
  const RaytracedSegmentSampler<Scn> drawn;
  const BsdfDirectedSegmentSampler<Scn> claimed;
  const typename BsdfDirectedSegmentSampler<Scn>::Technique t{Vec3<T>(0, 0, 1)};
  const BothCharted<T, SphereChart<T>, SphereChart<T>> map{{&scene}, {&scene, 0.1}};
  Histogram4D h{map.lo(), map.hi(), sphere_cells, 100'000};
  const auto r = chi_square_4d(
      [&](Pcg32& rng) -> std::optional<std::array<double, 4>> {
        const auto s = drawn.sample(scene, {}, rng);
        if (!s) return std::nullopt;
        return map.coordinates(s->segment);
      },
      [&](const std::array<double, 4>& c) {
        const auto s = map.segment(c);
        return double(claimed.pdf(scene, t, s->first)) * s->second;
      },
      h, 14);
  CHECK(r.result.rejects(chi_square_alpha()));
  CHECK(r.result.zero_expected_hits > 0);
}

TEMPLATE_TEST_CASE("light-start sampler: 4D chi-square on the sphere (N30)", "[samplers][stat]", float, double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  const LightStartSampler<Scn> smp;
  const BothCharted<T, SphereChart<T>, SphereChart<T>> map{{&scene}, {&scene, 0.1}};
  check_report(run_4d<T>(smp, scene, {}, map, sphere_cells, 15), n_samples);
}

TEMPLATE_TEST_CASE("light-start sampler: x under a point light (N30)", "[samplers][stat]", float, double) {
  using T = TestType;
  using Scn = st::PointLitPlane<T>;
  const Scn scene(st::PointLitPlaneParameters<T>{T(2), T(1), T(3), T(0.5)}, {Vec2<T>(0, 0)});
  const LightStartSampler<Scn> smp;
  // y is the light's point; x by its (x, y) on the square (dA = dx dy).
  struct SquareChart {
    [[nodiscard]] glm::dvec2 coordinates(const SurfacePoint<T>& p) const { return {p.position.x, p.position.y}; }
    [[nodiscard]] SurfacePoint<T> point(const glm::dvec2& c) const {
      return SurfacePoint<T>::on_surface(Vec3<T>(T(c.x), T(c.y), T(0)), Vec3<T>(0, 0, 1), 0, 0);
    }
    [[nodiscard]] double jacobian() const { return 1; }
    glm::dvec2 lo{-2, -2}, hi{2, 2};
  };
  const auto r = run_2d<T>(smp, scene, {}, SquareChart{}, false, scene.emitter().point(), 1.0, 16, 32, 32);
  check_report(r, n_samples);
  // About 0.39 of the directions of a point light at height 1 hit the 4 x 4 square.
  CHECK(double(r.failed_samples) / double(n_samples) > 0.5);
}

TEMPLATE_TEST_CASE("light-side next sampler, Dirac kernel: x_i on the sphere", "[samplers][stat]", float, double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  const LightNextSegmentSampler<Scn, DiracKernel<T>> smp{DiracKernel<T>{}};
  const Segment<T> next{scene.point_at(glm::normalize(Vec3<T>(T(0.2), T(0.3), T(-0.9)))),
                        scene.point_at(glm::normalize(Vec3<T>(T(-0.5), T(0.1), T(0.8))))};
  const auto r = run_2d<T>(smp, scene, {next}, SphereChart<T>{&scene}, false, next.x, 1.0, 17);
  check_report(r, n_samples);
}

TEMPLATE_TEST_CASE("light-side next sampler, disk kernel: 4D chi-square on the slab", "[samplers][stat]", float,
                   double) {
  using T = TestType;
  using Scn = SlabWithCamera<T>;
  const Scn scene;
  const DiskKernel<T> kernel(T(0.3));
  const LightNextSegmentSampler<Scn, DiskKernel<T>> smp{kernel};
  const Segment<T> next{scene.point_on(st::SlabSide::b, T(0.3), T(-0.4)),
                        scene.point_on(st::SlabSide::a, T(1.0), T(0.2))};
  // y_i in the disk around x_{i+1} (plane B), x_i traced downwards from it (cos theta < 0).
  const TracedFrom<T, Scn, DiskChart<T>> map{&scene, {next.x, 0.3}, true, -1, 0};
  check_report(run_4d<T>(smp, scene, {next}, map, {4, 8, 4, 8}, 18), n_samples);
}

TEMPLATE_TEST_CASE("approximate samplers: the free end given the copied junction (N33)", "[samplers][stat]", float,
                   double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  const DiskKernel<T> kernel(T(0.2));
  const double centre_area = std::numbers::pi * 0.2 * 0.2;  // 1 / p_K at the kernel's centre
  const Segment<T> s{scene.point_at(glm::normalize(Vec3<T>(T(0.2), T(0.3), T(-0.9)))),
                     scene.point_at(glm::normalize(Vec3<T>(T(-0.5), T(0.1), T(0.8))))};
  SECTION("sensor side: y_{i+1} given x_{i+1} = y_i") {
    const ApproximateNextSegmentSampler<Scn, DiskKernel<T>> smp{kernel};
    check_report(run_2d<T>(smp, scene, {s}, SphereChart<T>{&scene}, true, s.y, centre_area, 19), n_samples);
  }
  SECTION("light side: x_i given y_i = x_{i+1}") {
    const ApproximateLightNextSegmentSampler<Scn, DiskKernel<T>> smp{kernel};
    check_report(run_2d<T>(smp, scene, {s}, SphereChart<T>{&scene}, false, s.x, centre_area, 20), n_samples);
  }
}

TEMPLATE_TEST_CASE("kernel bridge: 4D chi-square of both kernel ends on the slab (N34)", "[samplers][stat]", float,
                   double) {
  using T = TestType;
  using Scn = SlabWithCamera<T>;
  const Scn scene;
  const KernelBridgeSampler<Scn, DiskKernel<T>> smp{DiskKernel<T>(T(0.3))};
  const Segment<T> camera{scene.point_on(st::SlabSide::b, T(0.7), T(0.1)),
                          scene.point_on(st::SlabSide::a, T(0.2), T(0.3))};
  const Segment<T> light{scene.point_on(st::SlabSide::b, T(-0.4), T(0.6)),
                         scene.point_on(st::SlabSide::a, T(1.5), T(-0.5))};
  const BothCharted<T, DiskChart<T>, DiskChart<T>> map{{camera.y, 0.3}, {light.x, 0.3}};
  check_report(run_4d<T>(smp, scene, {camera, light}, map, {4, 8, 4, 8}, 21), n_samples);
}

TEMPLATE_TEST_CASE("light bridge (next-event): the light end on the sphere, Dirac kernel", "[samplers][stat]", float,
                   double) {
  using T = TestType;
  const auto scene = make_sphere<T>();
  using Scn = st::SphereInterior<T>;
  const LightBridgeSampler<Scn, DiracKernel<T>> smp{DiracKernel<T>{}};
  const Segment<T> camera{scene.point_at(glm::normalize(Vec3<T>(T(0.2), T(0.3), T(-0.9)))),
                          scene.point_at(glm::normalize(Vec3<T>(T(-0.5), T(0.1), T(0.8))))};
  check_report(run_2d<T>(smp, scene, {camera}, SphereChart<T>{&scene}, true, camera.y, 1.0, 22), n_samples);
}

TEMPLATE_TEST_CASE("light bridge (next-event), disk kernel: 4D chi-square on the slab", "[samplers][stat]", float,
                   double) {
  using T = TestType;
  using Scn = SlabWithCamera<T>;
  const Scn scene;
  const LightBridgeSampler<Scn, DiskKernel<T>> smp{DiskKernel<T>(T(0.3))};
  const Segment<T> camera{scene.point_on(st::SlabSide::b, T(0.7), T(0.1)),
                          scene.point_on(st::SlabSide::a, T(0.2), T(0.3))};
  // x_i in the disk around y_{i-1} (plane A); y_i by the direction towards it (upwards).
  const TracedFrom<T, Scn, DiskChart<T>> map{&scene, {camera.y, 0.3}, false, 0, 1};
  check_report(run_4d<T>(smp, scene, {camera}, map, {4, 8, 4, 8}, 23), n_samples);
}

TEMPLATE_TEST_CASE("sensor bridge: y_1 in the kernel around x_2, pinhole x_1 (N34)", "[samplers][stat]", float,
                   double) {
  using T = TestType;
  using Scn = SlabWithCamera<T>;
  const Scn scene;
  const SensorBridgeSampler<Scn, DiskKernel<T>> smp{DiskKernel<T>(T(0.3))};
  const Segment<T> light{scene.point_on(st::SlabSide::a, T(0.5), T(0.4)),
                         scene.point_on(st::SlabSide::b, T(-0.3), T(0.2))};
  const SurfacePoint<T> pinhole = SurfacePoint<T>::at_point(Vec3<T>(T(0.1), T(-0.2), T(0.5)));
  check_report(run_2d<T>(smp, scene, {light}, DiskChart<T>{light.x, 0.3}, true, pinhole, 1.0, 24), n_samples);
}
