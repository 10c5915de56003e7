// MVF, PhF and BDPF (SPEC 1.9): exact in the periodic-slab furnace, factorised clusters give
// the same image as the O(n m) sums, images independent of the thread count, bad options
// rejected.
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/sensors/pinhole_camera.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/lit_plane.hpp>
#include <segpath/testing/periodic_slab.hpp>
#include <segpath/testing/statistics.hpp>

#include <thread>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

/// The slab seen through a pinhole between its planes, looking down at plane A.
template <class T>
class PhotographedSlab : public testing::PeriodicSlab<T> {
 public:
  PhotographedSlab(const testing::PeriodicSlabParameters<T>& p, std::uint32_t size)
      : testing::PeriodicSlab<T>(p, {testing::SlabProbe<T>{}}), camera_(camera(p, size)) {}
  [[nodiscard]] const PinholeCamera<T>& sensor() const noexcept { return camera_; }

 private:
  static PinholeCamera<T> camera(const testing::PeriodicSlabParameters<T>& p, std::uint32_t size) {
    PinholeCameraParameters<T> c;
    c.position = {T(0.3), T(0.2), p.height * T(0.6)};
    c.forward = {0, 0, -1};
    c.right = {1, 0, 0};
    c.up = {0, 1, 0};
    c.width = c.height = size;
    c.fov_x_degrees = c.fov_y_degrees = 60;
    return PinholeCamera<T>(c);
  }
  PinholeCamera<T> camera_;
};

/// Runs `work(i)` for i in [0, n) on two threads.
struct TwoThreads {
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    std::thread other([&] {
      for (std::size_t i = 1; i < n; i += 2) body(i);
    });
    for (std::size_t i = 0; i < n; i += 2) body(i);
    other.join();
  }
};

const testing::PeriodicSlabParameters<double> furnace{1.0, 2.0, 0.7, 0.4, 0.5, 0.6};

}  // namespace

TEST_CASE("segment filtering: bad options are rejected", "[algorithms]") {
  using Scn = PhotographedSlab<double>;
  FilteringOptions<double> o;
  o.max_length = 1;
  CHECK_THROWS_AS(SegmentFiltering<Scn>(o), std::invalid_argument);
  o = {};
  o.light_path_ratio = 0;
  CHECK_THROWS_AS(SegmentFiltering<Scn>(o), std::invalid_argument);
  o.mode = FilteringMode::mvf;  // beta is irrelevant without light paths
  CHECK_NOTHROW(SegmentFiltering<Scn>(o));
  o = {};
  o.initial_cell_size = -1;
  CHECK_THROWS_AS(SegmentFiltering<Scn>(o), std::invalid_argument);
  o = {};
  o.alpha = 1;
  CHECK_THROWS_AS(SegmentFiltering<Scn>(o), std::invalid_argument);
}

TEST_CASE("segment filtering: factorised clusters give the same image", "[algorithms]") {
  const PhotographedSlab<double> scene(furnace, 8);
  for (auto mode : {FilteringMode::mvf, FilteringMode::phf, FilteringMode::bdpf}) {
    FilteringOptions<double> o;
    o.mode = mode;
    o.max_length = 5;
    o.light_path_ratio = 0.5;
    o.initial_cell_size = 0.3;
    SegmentFiltering<PhotographedSlab<double>> fast(o);
    o.factorise = false;
    SegmentFiltering<PhotographedSlab<double>> slow(o);
    Framebuffer<double> a(8, 8), b(8, 8);
    DropCounters drops;
    const auto sa = fast.render_iteration(scene, 1, 0.3, a, drops);
    const auto sb = slow.render_iteration(scene, 1, 0.3, b, drops);
    INFO("mode " << to_string(mode));
    CHECK(sa.factorised_camera_clusters + sa.factorised_light_clusters > 0);
    CHECK(sb.factorised_camera_clusters + sb.factorised_light_clusters == 0);
    CHECK(sa.pair_evaluations < sb.pair_evaluations);
    for (std::uint32_t p = 0; p < 64; ++p) CHECK(a[p] == Approx(b[p]).epsilon(1e-12).margin(1e-300));
    CHECK(drops.total() == 0);
  }
}

TEST_CASE("segment filtering: the image does not depend on the thread count", "[algorithms]") {
  const PhotographedSlab<double> scene(furnace, 8);
  FilteringOptions<double> o;
  o.max_length = 5;
  o.initial_cell_size = 0.3;
  const SegmentFiltering<PhotographedSlab<double>> bdpf(o);
  Framebuffer<double> a(8, 8), b(8, 8);
  DropCounters drops;
  bdpf.render_iteration(scene, 3, 0.3, a, drops, SerialFor{});
  bdpf.render_iteration(scene, 3, 0.3, b, drops, TwoThreads{});
  for (std::uint32_t p = 0; p < 64; ++p) CHECK(a[p] == b[p]);
}

TEST_CASE("MVF, PhF and BDPF are exact in the periodic-slab furnace", "[algorithms][stat]") {
  // The slab is a flat torus: clustering keys its points by their canonical image, and an
  // unjittered grid of voxels dividing the period tiles the fundamental cell exactly. MVF
  // has no unconditional technique past the sensor segment, so it is biased by the chance
  // that a cluster holds no technique sample (the SMIS coverage bias): 2 x 2 voxels per
  // period keep that chance negligible.
  const PhotographedSlab<double> scene(furnace, 16);
  const std::size_t max_length = 6;
  // Paths of up to 6 segments seen from plane A: L_A truncated after 5 reflections.
  double expected = 0;
  for (unsigned k = 0; k < max_length; ++k) expected += scene.bounce_radiance(testing::SlabSide::a, k);
  const double alpha = testing::sidak_alpha(0.01, 3);
  for (auto mode : {FilteringMode::mvf, FilteringMode::phf, FilteringMode::bdpf}) {
    FilteringOptions<double> o;
    o.mode = mode;
    o.max_length = max_length;
    o.light_path_ratio = 1.0;
    o.jitter = false;
    o.seed = 11;
    const SegmentFiltering<PhotographedSlab<double>> method(o);
    // Each iteration's image mean is one sample (pixels of one iteration are correlated).
    testing::RunningStats stats;
    DropCounters drops;
    for (std::uint64_t it = 1; it <= 60; ++it) {
      Framebuffer<double> image(16, 16);
      method.render_iteration(scene, it, 0.5, image, drops);
      double mean = 0;
      for (auto v : image.pixels()) mean += v;
      stats.add(mean / 256.0);
    }
    INFO(to_string(mode) << ": " << stats.mean() << " +- " << stats.standard_error() << " vs " << expected);
    CHECK(drops.total() == 0);
    if (stats.variance() < 1e-20) {
      CHECK(stats.mean() == Approx(expected).epsilon(1e-9));  // MVF in the furnace: every sample exact
    } else {
      CHECK_FALSE(testing::student_t_test(stats, expected).rejects(alpha));
    }
  }
}

TEST_CASE("the BDPF furnace test has the power to see a 1 % error", "[algorithms][stat]") {
  const PhotographedSlab<double> scene(furnace, 16);
  FilteringOptions<double> o;
  o.max_length = 3;
  o.jitter = false;
  o.light_path_ratio = 1.0;
  double expected = 0;
  for (unsigned k = 0; k < 3; ++k) expected += scene.bounce_radiance(testing::SlabSide::a, k);
  const SegmentFiltering<PhotographedSlab<double>> right(o);
  testing::RunningStats good;
  for (std::uint64_t it = 1; it <= 40; ++it) {
    Framebuffer<double> image(16, 16);
    DropCounters drops;
    right.render_iteration(scene, it, 0.5, image, drops);
    double mean = 0;
    for (auto v : image.pixels()) mean += v;
    good.add(mean / 256.0);
  }
  CHECK_FALSE(testing::student_t_test(good, expected).rejects(0.001));
  CHECK(testing::student_t_test(good, expected * 1.01).rejects(0.001));  // 1 % off is caught
}

TEST_CASE("every MMIS denominator includes every technique sample of its cluster", "[algorithms]") {
  // Recompute D(s) (N39) for every pooled segment by enumerating ALL pooled segments as
  // candidate technique samples, using only cluster ids — not the clusters' member lists the
  // algorithm iterates over — and compare.
  using Scn = PhotographedSlab<double>;
  using Filter = SegmentFiltering<Scn>;
  const Scn scene(furnace, 8);
  for (bool factorise : {false, true}) {
    FilteringOptions<double> o;
    o.max_length = 5;
    o.light_path_ratio = 0.75;
    o.factorise = factorise;
    const Filter filter(o);
    typename Filter::Pool pool;
    filter.build_pool(scene, 2, pool, SerialFor{});
    Clustering<double> clustering;
    filter.cluster(scene, filter.grid(0.4, 2), pool, clustering);
    FilteringStats stats;
    filter.compute_densities(scene, pool, clustering, stats, SerialFor{});

    const auto bsdf = scene.bsdf();
    const double n_light = double(filter.light_path_count(scene));
    std::size_t checked = 0, with_techniques = 0;
    for (std::uint32_t s = 0; s < pool.size(); ++s) {
      const auto& seg = pool.segments[s];
      const std::uint8_t f = pool.flags[s];
      double d = 0;
      int techniques = 0;
      for (std::uint32_t t = 0; t < pool.size(); ++t) {
        // A camera technique sample: a continued segment whose y shares s's x cluster.
        if ((pool.flags[t] & Filter::camera_technique) && clustering.cluster_of_x(s) != no_cluster &&
            clustering.cluster_of_y(t) == clustering.cluster_of_x(s) && !(f & Filter::delta_light)) {
          const double k = clustering.clusters()[clustering.cluster_of_x(s)].kernel;
          d += k * bsdf.pdf(BsdfQuery<double>{pool.segments[t].y, -pool.last_direction[t], pool.first_direction[s],
                                              Transport::radiance}) *
               solid_angle_to_area(1.0, seg.x, seg.y);
          ++techniques;
        }
        // A light technique sample: a continued light segment whose x shares s's y cluster.
        if ((pool.flags[t] & Filter::light_technique) && clustering.cluster_of_y(s) != no_cluster &&
            clustering.cluster_of_x(t) == clustering.cluster_of_y(s) && seg.x.kind == PointKind::surface &&
            !(f & (Filter::chain_segment | Filter::delta_light))) {
          const double k = clustering.clusters()[clustering.cluster_of_y(s)].kernel;
          d += k * bsdf.pdf(BsdfQuery<double>{pool.segments[t].x, -pool.last_direction[s], pool.first_direction[t],
                                              Transport::importance}) *
               solid_angle_to_area(1.0, seg.y, seg.x);
          ++techniques;
        }
      }
      if (f & Filter::sensor_segment) {
        const auto p = scene.sensor().pdf(SensorQuery<double>{seg.x, pool.first_direction[s]});
        d += p.position * p.direction * solid_angle_to_area(1.0, seg.x, seg.y);
      }
      if (seg.x.kind == PointKind::surface) {
        const auto e = scene.emitter().pdf_emission(EmissionPdfQuery<double>{seg.y, -pool.last_direction[s]});
        d += n_light * e.position * e.direction * solid_angle_to_area(1.0, seg.y, seg.x);
      }
      CHECK(pool.density[s] == Approx(d).epsilon(1e-12).margin(1e-300));
      ++checked;
      if (techniques > 1) ++with_techniques;
    }
    CHECK(checked > 500);
    CHECK(with_techniques > checked / 4);  // the pools exercise clusters with several technique samples
  }
}

namespace {

/// The point-lit plane through a 4 x 4 pinhole half a unit above it, looking down.
class PhotographedPointLitPlane : public testing::PointLitPlane<double> {
 public:
  PhotographedPointLitPlane()
      : testing::PointLitPlane<double>(testing::PointLitPlaneParameters<double>{2, 1, 1, 0.6}, {{0, 0}}),
        camera_([] {
          PinholeCameraParameters<double> c;
          c.position = {0, 0, 0.5};
          c.forward = {0, 0, -1};
          c.right = {1, 0, 0};
          c.up = {0, 1, 0};
          c.width = c.height = 4;
          c.fov_x_degrees = c.fov_y_degrees = 20;
          return c;
        }()) {}
  [[nodiscard]] const PinholeCamera<double>& sensor() const noexcept { return camera_; }

 private:
  PinholeCamera<double> camera_;
};

}  // namespace

TEST_CASE("BDPF is consistent under the point-lit plane: halving the voxel quarters the bias", "[algorithms][stat]") {
  // Single-bounce light: the kernel estimate blurs the irradiance over a voxel; with
  // E'' < 0 under the light the blur lowers the image by ~ (h^2 / 24) Laplacian(E) rho / pi.
  const PhotographedPointLitPlane scene;
  double expected = 0;  // the image mean: the closed form averaged over every pixel
  for (std::uint32_t p = 0; p < 16; ++p)
    expected += testing::integrate_2d(
                    [&](glm::dvec2 u) {
                      const auto ray = scene.sensor().sample_ray(SensorSampleQuery<double>{p, Vec2<double>(0.5), Vec2<double>(u.x, u.y)});
                      const double t = -ray->origin.position.z / ray->direction.z;
                      return scene.radiance_at(ray->origin.position + ray->direction * t);
                    },
                    {0, 0}, {1, 1}, 8, 8) /
                16;
  FilteringOptions<double> o;
  o.max_length = 2;
  o.light_path_ratio = 4096;  // photons near the axis: N_L / (4 pi) per unit area
  o.seed = 5;
  const SegmentFiltering<PhotographedPointLitPlane> bdpf(o);
  auto bias = [&](double cell) {
    testing::RunningStats stats;
    for (std::uint64_t it = 1; it <= 120; ++it) {
      Framebuffer<double> image(4, 4);
      DropCounters drops;
      bdpf.render_iteration(scene, it, cell, image, drops);
      double mean = 0;
      for (auto v : image.pixels()) mean += v / 16;
      stats.add(mean);
    }
    return std::pair{stats.mean() - expected, stats.standard_error()};
  };
  const auto [coarse, coarse_se] = bias(0.3);
  const auto [fine, fine_se] = bias(0.15);
  INFO("bias at h = 0.3: " << coarse << " +- " << coarse_se << ", at h/2: " << fine << " +- " << fine_se);
  CHECK(coarse < -5 * coarse_se);  // the blur is real and has the predicted sign
  CHECK(std::abs(fine - coarse / 4) < 5 * std::sqrt(fine_se * fine_se + coarse_se * coarse_se / 16));
  CHECK(std::abs(fine) < std::abs(coarse));
}
