// BDPT, PPM, BPM and VCM against closed forms, iteration by iteration:
//  - BDPT through a pinhole over the lit planes and inside the sphere: every pixel against
//    the pixel average of the closed-form radiance (quadrature);
//  - BDPT and VCM in the periodic-slab furnace seen through a pinhole, and PPM, BPM and VCM
//    in the sphere furnace: exact (the disk kernel has no bias there);
//  - PPM and BPM under the point light: the measured bias is the disk average's, and falls
//    about fourfold when the radius halves;
//  - the same seed gives the same image, bit for bit, serially and on two threads.
#include <segpath/algorithms/vcm.hpp>
#include <segpath/materials/lambertian.hpp>
#include <segpath/materials/mirror.hpp>
#include <segpath/sensors/pinhole_camera.hpp>
#include <segpath/testing/integrate.hpp>
#include <segpath/testing/lit_plane.hpp>
#include <segpath/testing/periodic_slab.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/statistics.hpp>

#include <atomic>
#include <cstring>
#include <thread>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

namespace {

/// An analytic scene seen through a pinhole instead of its probes.
template <class Base>
class Pinhole : public Base {
 public:
  using T = typename Base::Scalar;
  template <class... Args>
  Pinhole(const PinholeCameraParameters<T>& camera, Args&&... args) : Base(std::forward<Args>(args)...), camera_(camera) {}
  [[nodiscard]] const PinholeCamera<T>& sensor() const noexcept { return camera_; }

 private:
  PinholeCamera<T> camera_;
};

template <class T>
PinholeCameraParameters<T> camera(Vec3<T> position, Vec3<T> forward, Vec3<T> right, Vec3<T> up, std::uint32_t w,
                                  std::uint32_t h, T fov) {
  PinholeCameraParameters<T> c;
  c.position = position;
  c.forward = forward;
  c.right = right;
  c.up = up;
  c.width = w;
  c.height = h;
  c.fov_x_degrees = fov;
  c.fov_y_degrees = fov;
  return c;
}

/// The periodic slab with light subpaths started on the whole infinite planes: the slab's own
/// light-start sampler draws cell points, which on the universal cover is not a density over
/// the planes (only sample_towards covers them), so kernel and bridge estimates from cover
/// points would see one lattice translate. Here y is drawn around `centre` with the 2D density
/// a / (2 pi (a^2 + rho^2)^(3/2)) (tails heavier than the transport's), the plane chosen by
/// emission; sample_towards and pdf_towards stay the slab's.
template <Real T>
class InfiniteSlab : public testing::PeriodicSlab<T> {
 public:
  using Base = testing::PeriodicSlab<T>;
  InfiniteSlab(const testing::PeriodicSlabParameters<T>& p, Vec2<T> centre, T spread)
      : Base(p, {testing::SlabProbe<T>{}}), centre_(centre), spread_(spread) {}

  class Emission : public Base::Emission {
   public:
    explicit Emission(const InfiniteSlab& s) : Base::Emission(s), s_(&s) {}
    [[nodiscard]] std::optional<EmissionSample<T>> sample_emission(const EmissionSampleQuery<T>& q) const noexcept {
      const T share_a = s_->share_a();
      const testing::SlabSide side = q.u_select < share_a ? testing::SlabSide::a : testing::SlabSide::b;
      const T u = std::min(q.u_position.x, T(1) - std::numeric_limits<T>::epsilon());
      const T rho = s_->spread_ * std::sqrt(std::max(T(0), T(1) / ((T(1) - u) * (T(1) - u)) - T(1)));
      const T phi = T(2) * pi<T> * q.u_position.y;
      const SurfacePoint<T> y = s_->point_on(side, s_->centre_.x + rho * std::cos(phi), s_->centre_.y + rho * std::sin(phi));
      const Vec3<T> local = square_to_cosine_hemisphere(q.u_direction);
      const T pdf_dir = square_to_cosine_hemisphere_pdf(local);
      const EmissionPdf<T> p = pdf_emission({y, y.shading_frame().to_world(local)});
      if (!(pdf_dir > T(0)) || !(p.position > T(0))) return std::nullopt;
      return EmissionSample<T>{y, y.shading_frame().to_world(local), s_->emission(side), p.position, pdf_dir};
    }
    [[nodiscard]] EmissionPdf<T> pdf_emission(const EmissionPdfQuery<T>& q) const noexcept {
      if (q.point.kind != PointKind::surface || q.point.primitive_id > 1) return {};
      const T share = q.point.primitive_id == 0 ? s_->share_a() : T(1) - s_->share_a();
      const T dx = q.point.position.x - s_->centre_.x, dy = q.point.position.y - s_->centre_.y;
      const T a = s_->spread_;
      const T s2 = a * a + dx * dx + dy * dy;
      const T cosine = glm::dot(q.direction, q.point.normal);
      return {share * a / (T(2) * pi<T> * s2 * std::sqrt(s2)), cosine > T(0) ? cosine * inv_pi<T> : T(0)};
    }

   private:
    const InfiniteSlab* s_;
  };
  [[nodiscard]] Emission emitter() const noexcept { return Emission(*this); }

 private:
  [[nodiscard]] T share_a() const noexcept {
    return this->parameters().emission_a / (this->parameters().emission_a + this->parameters().emission_b);
  }
  Vec2<T> centre_;
  T spread_;
};

/// A ParallelFor on two std::threads (work handed out by an atomic counter).
struct TwoThreads {
  template <class Body>
  void operator()(std::size_t n, Body&& body) const {
    std::atomic<std::size_t> next{0};
    auto work = [&] {
      for (std::size_t i = next++; i < n; i = next++) body(i);
    };
    std::thread helper(work);
    work();
    helper.join();
  }
};

/// Per-pixel statistics over iterations (each iteration is one sample of every pixel).
template <class Scn, class S>
std::vector<testing::RunningStats> run(const VertexConnectionMerging<Scn>& method, const Scn& scene,
                                       std::uint64_t iterations, DropCounters& drops, double fixed_radius = 0) {
  const std::uint32_t pixels = scene.sensor().pixel_count();
  std::vector<testing::RunningStats> stats(pixels + 1);  // the last: the image mean
  Framebuffer<S> image(pixels, 1);
  for (std::uint64_t i = 0; i < iterations; ++i) {
    image.clear();
    if (fixed_radius > 0)
      method.render_iteration_at(scene, i, typename Scn::Scalar(fixed_radius), image, drops, SerialFor{});
    else
      method.render_iteration(scene, i, image, drops, SerialFor{});
    double mean = 0;
    for (std::uint32_t p = 0; p < pixels; ++p) {
      stats[p].add(double(image[p]));
      mean += double(image[p]) / pixels;
    }
    stats[pixels].add(mean);
  }
  return stats;
}

/// The pixel average of `radiance(hit)` over the pixel, hit the first surface the ray meets.
template <class Scn, class F>
double pixel_expectation(const Scn& scene, std::uint32_t pixel, F&& radiance) {
  using T = typename Scn::Scalar;
  return testing::integrate_2d(
      [&](glm::dvec2 u) {
        const auto ray = scene.sensor().sample_ray(SensorSampleQuery<T>{pixel, Vec2<T>(0.5), Vec2<T>(T(u.x), T(u.y))});
        const auto hit = scene.intersect(IntersectQuery<T>{Ray<T>{ray->origin.position, ray->direction}});
        return hit ? double(radiance(hit->point.position)) : 0.0;
      },
      glm::dvec2(0), glm::dvec2(1), 8, 8);
}

VcmOptions options(VcmMode mode, std::size_t max_length, double radius, double factor, std::uint64_t seed) {
  VcmOptions o;
  o.mode = mode;
  o.max_length = max_length;
  o.initial_radius = radius;
  o.light_path_factor = factor;
  o.seed = seed;
  return o;
}

/// The sphere furnace of the PPM, BPM and VCM tests: unit radius, uniform emission 1 and albedo 0.6.
template <class T>
testing::SphereInteriorParameters<T> furnace() {
  testing::SphereInteriorParameters<T> sp;
  sp.radius = 1;
  sp.emission_mean = 1;
  sp.albedo_mean = T(0.6);
  return sp;
}
/// Its 3 x 3 pinhole inside, looking at the wall through 80 degrees.
template <class T>
PinholeCameraParameters<T> furnace_camera() {
  return camera<T>({T(0.2), T(-0.1), 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, 3, 3, T(80));
}

}  // namespace

TEMPLATE_TEST_CASE("BDPT is unbiased through a pinhole over the lit planes and inside the sphere", "[algorithms][stat]",
                   float, double) {
  using T = TestType;
  const auto down = camera<T>({T(0.1), T(-0.05), T(0.6)}, {0, 0, -1}, {1, 0, 0}, {0, 1, 0}, 4, 4, T(70));
  const Pinhole<testing::PointLitPlane<T>> point_lit(down, testing::PointLitPlaneParameters<T>{2, 1, T(1.5), T(0.6)},
                                                     std::vector<Vec2<T>>{{0, 0}});
  const Pinhole<testing::DiskLitPlane<T>> disk_lit(down, testing::DiskLitPlaneParameters<T>{2, 1, T(0.5), 2, T(0.6)},
                                                   std::vector<Vec2<T>>{{0, 0}});
  testing::SphereInteriorParameters<T> sp;
  sp.radius = T(1.3);
  sp.emission_gradient = {T(0.4), 0, T(-0.5)};
  sp.albedo_mean = T(0.5);
  sp.albedo_gradient = {0, T(0.2), T(0.15)};
  const auto inside = camera<T>({T(0.1), T(-0.2), T(0.05)}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, 3, 3, T(80));
  const Pinhole<testing::SphereInterior<T>> sphere(inside, sp, std::vector<Vec3<T>>{{0, 0, 1}});
  const double alpha = testing::sidak_alpha(0.01, 2 * (16 + 16 + 9) * 2);

  auto check = [&](const auto& scene, std::size_t max_length, std::uint64_t iterations, auto&& radiance, const char* name) {
    using Scn = std::remove_cvref_t<decltype(scene)>;
    const VertexConnectionMerging<Scn> bdpt(options(VcmMode::bdpt, max_length, 0.1, 1, 11));
    DropCounters drops;
    const auto stats = run<Scn, T>(bdpt, scene, iterations, drops);
    CHECK(drops.total() == 0);
    for (std::uint32_t p = 0; p < scene.sensor().pixel_count(); ++p) {
      const double expected = pixel_expectation(scene, p, radiance);
      INFO(name << " pixel " << p << ": " << stats[p].mean() << " +- " << stats[p].standard_error() << " vs " << expected);
      CHECK(expected > 0);
      CHECK_FALSE(testing::student_t_test(stats[p], expected).rejects(alpha));
      CHECK(testing::student_t_test(stats[p], 1.05 * expected).rejects(alpha));  // the test has power
    }
  };
  check(point_lit, 4, 3000, [&](const Vec3<T>& x) { return point_lit.radiance_at(x); }, "point-lit plane");
  check(disk_lit, 4, 3000, [&](const Vec3<T>& x) { return disk_lit.radiance_at(x); }, "disk-lit plane");
  const std::size_t max_length = 5;
  check(sphere, max_length, 3000,
        [&](const Vec3<T>& x) {
          T sum = 0;
          for (unsigned b = 0; b < max_length; ++b) sum += sphere.bounce_radiance_at(x, b);
          return sum;
        },
        "sphere");
}

TEMPLATE_TEST_CASE("BDPT and VCM are exact in the periodic-slab furnace", "[algorithms][stat]", float, double) {
  using T = TestType;
  testing::PeriodicSlabParameters<T> p;
  p.height = 1;
  p.emission_a = 1;
  p.emission_b = T(0.5);
  p.albedo_a = T(0.5);
  p.albedo_b = T(0.3);
  const auto down = camera<T>({T(0.3), T(0.2), T(0.5)}, {0, 0, -1}, {1, 0, 0}, {0, 1, 0}, 3, 3, T(60));
  using Scn = Pinhole<InfiniteSlab<T>>;
  const Scn scene(down, p, Vec2<T>(T(0.3), T(0.2)), T(1));
  static_assert(LightSampledScene<Scn>);
  const std::size_t max_length = 5;
  const double expected = scene.radiance_up_to(testing::SlabSide::a, unsigned(max_length - 1));
  const double alpha = testing::sidak_alpha(0.01, 2 * 5 * 2);
  struct Case {
    VcmMode mode;
    double radius;
    double light_path_factor;
    bool progressive;
    std::uint64_t iterations;
    std::size_t roulette_from = 0;
  };
  // Light subpaths started on infinite planes give photons of unbounded weight (the
  // second moment of a photon estimate diverges there); the MIS of BDPT and VCM keeps them
  // tame, PPM and BPM are tested in the sphere furnace below.
  // Russian roulette on both subpaths (from their first scattering) keeps the estimate exact.
  for (const Case c : {Case{VcmMode::bdpt, 0.2, 6, false, 1500}, Case{VcmMode::vcm, 0.25, 6, false, 1500},
                       Case{VcmMode::vcm, 0.4, 6, true, 1500}, Case{VcmMode::bdpt, 0.2, 6, false, 1500, 1},
                       Case{VcmMode::vcm, 0.25, 6, false, 1500, 1}}) {
    VcmOptions o = options(c.mode, max_length, c.radius, c.light_path_factor, 5);
    o.alpha = 0.6;
    o.roulette_from = c.roulette_from;
    const VertexConnectionMerging<Scn> method(o);
    DropCounters drops;
    const auto stats = run<Scn, T>(method, scene, c.iterations, drops, c.progressive ? 0.0 : c.radius);
    const auto& mean = stats.back();
    INFO(to_string(c.mode) << (c.progressive ? " (progressive)" : "") << ", roulette from " << c.roulette_from << ": " << mean.mean() << " +- "
                           << mean.standard_error() << " vs " << expected);
    CHECK(drops.total() == 0);
    CHECK_FALSE(testing::student_t_test(mean, expected).rejects(alpha));
    CHECK(testing::student_t_test(mean, 1.03 * expected).rejects(alpha));  // the test has power
  }
}

TEMPLATE_TEST_CASE("PPM, BPM and VCM are exact in the sphere furnace", "[algorithms][stat]", float, double) {
  // Uniform emission and albedo: L is uniform, and the points of a sphere within distance r
  // of a point form a cap of area exactly pi r^2 (Archimedes), so the disk kernel's estimate
  // is exact up to the photons that arrive within ~r/R of a camera end's tangent plane.
  using T = TestType;
  const auto sp = furnace<T>();
  const auto inside = furnace_camera<T>();
  using Scn = Pinhole<testing::SphereInterior<T>>;
  const Scn scene(inside, sp, std::vector<Vec3<T>>{{0, 0, 1}});
  const std::size_t max_length = 5;
  double expected = 0;
  for (unsigned b = 0; b < max_length; ++b) expected += scene.bounce_radiance_at(Vec3<T>(0, 0, 1), b);
  const double alpha = testing::sidak_alpha(0.01, 2 * 2 * 3 * 2);
  for (const std::size_t roulette_from : {std::size_t(0), std::size_t(1)})
    for (const VcmMode mode : {VcmMode::ppm, VcmMode::bpm, VcmMode::vcm}) {
      VcmOptions o = options(mode, max_length, 0.1, 40, 8);
      o.roulette_from = roulette_from;
      const VertexConnectionMerging<Scn> method(o);
      DropCounters drops;
      const auto stats = run<Scn, T>(method, scene, 800, drops, 0.1);
      const auto& mean = stats.back();
      INFO(to_string(mode) << ", roulette from " << roulette_from << ": " << mean.mean() << " +- " << mean.standard_error()
                           << " vs " << expected);
      CHECK(drops.total() == 0);
      CHECK_FALSE(testing::student_t_test(mean, expected).rejects(alpha));
      CHECK(testing::student_t_test(mean, 1.03 * expected).rejects(alpha));  // the test has power
    }
}

namespace {
/// The sphere furnace with a material of both kinds of lobe: a mirror of reflectance `mirror`
/// and a Lambertian lobe of albedo albedo_mean - mirror, picked by u_lobe in proportion to
/// their albedos. It says it is not delta-only (is_delta), as a user's coated material would.
template <Real T>
class MixedSphere : public Pinhole<testing::SphereInterior<T>> {
 public:
  using Base = Pinhole<testing::SphereInterior<T>>;
  MixedSphere(const PinholeCameraParameters<T>& camera, const testing::SphereInteriorParameters<T>& p, T mirror)
      : Base(camera, p, std::vector<Vec3<T>>{{0, 0, 1}}), mirror_(mirror) {}

  class Materials {
   public:
    Materials(T diffuse, T mirror) : diffuse_(diffuse), mirror_(mirror), p_mirror_(mirror / (diffuse + mirror)) {}
    [[nodiscard]] T eval(const BsdfQuery<T>& q) const noexcept { return diffuse_.eval(q); }
    [[nodiscard]] T pdf(const BsdfQuery<T>& q) const noexcept { return (T(1) - p_mirror_) * diffuse_.pdf(q); }
    [[nodiscard]] std::optional<BsdfSample<T>> sample(const BsdfSampleQuery<T>& q) const noexcept {
      auto s = q.u_lobe < p_mirror_ ? mirror_.sample(q) : diffuse_.sample(q);
      if (s) s->pdf *= q.u_lobe < p_mirror_ ? p_mirror_ : T(1) - p_mirror_;
      return s;
    }
    [[nodiscard]] bool is_delta(const SurfacePoint<T>&) const noexcept { return false; }

   private:
    Lambertian<T> diffuse_;
    Mirror<T> mirror_;
    T p_mirror_;
  };
  [[nodiscard]] Materials bsdf() const noexcept { return Materials(this->parameters().albedo_mean - mirror_, mirror_); }

 private:
  T mirror_;
};
}  // namespace

TEST_CASE("PPM is exact in the sphere furnace with a material of both delta and non-delta lobes", "[algorithms][stat]") {
  // PPM gathers wherever the material has a non-delta lobe (is_delta false) and follows a
  // sampled mirror lobe on; gathering only where the sampled lobe is not a delta (or stopping
  // at the first gather) would lose the share of the other lobe. Uniform emission E and albedo
  // a (mirror 0.3 + diffuse 0.3): every bounce multiplies by a, L = E (1 + a + ... + a^4).
  using T = double;
  const auto sp = furnace<T>();
  const MixedSphere<T> scene(furnace_camera<T>(), sp, T(0.3));
  const std::size_t max_length = 5;
  double expected = 0;
  for (unsigned b = 0; b < max_length; ++b) expected += std::pow(0.6, double(b));
  const double alpha = testing::sidak_alpha(0.01, 2 * 2);
  for (const std::size_t roulette_from : {std::size_t(0), std::size_t(1)}) {
    VcmOptions o = options(VcmMode::ppm, max_length, 0.1, 40, 9);
    o.roulette_from = roulette_from;
    const VertexConnectionMerging<MixedSphere<T>> method(o);
    DropCounters drops;
    const auto stats = run<MixedSphere<T>, T>(method, scene, 800, drops, 0.1);
    const auto& mean = stats.back();
    INFO("roulette from " << roulette_from << ": " << mean.mean() << " +- " << mean.standard_error() << " vs " << expected);
    CHECK(drops.total() == 0);
    CHECK_FALSE(testing::student_t_test(mean, expected).rejects(alpha));
    CHECK(testing::student_t_test(mean, 1.03 * expected).rejects(alpha));  // the test has power
  }
}

TEST_CASE("PPM and BPM are consistent under the point light: bias of the disk average, about r^2", "[algorithms][stat]") {
  using T = double;
  using Scn = testing::PointLitPlane<T>;
  const testing::PointLitPlaneParameters<T> p{2, 1, 1, T(0.5)};
  const Scn scene(p, std::vector<Vec2<T>>{{0, 0}});
  const Vec3<T> x(0, 0, 0);
  const double truth = scene.radiance_at(x);
  // The kernel estimate's expectation on the plane: the disk average of L around x,
  // (rho / pi) (2 I / r^2) (1 - h / sqrt(h^2 + r^2)) at the foot of the light.
  const auto disk_average = [&](double r) { return p.albedo / pi<double> * 2 * p.intensity / (r * r) * (1 - p.height / std::sqrt(p.height * p.height + r * r)); };
  const double r1 = 0.5, r2 = 0.25;
  // The leading-order prediction agrees with the exact disk average at the smaller radius.
  CHECK(scene.kernel_bias_estimate(x, r2) == Approx(disk_average(r2) - truth).epsilon(0.06));
  const double alpha = testing::sidak_alpha(0.01, 2 * 6);
  for (const VcmMode mode : {VcmMode::ppm, VcmMode::bpm}) {
    double bias[2], error[2];
    for (int i = 0; i < 2; ++i) {
      const double r = i == 0 ? r1 : r2;
      const VertexConnectionMerging<Scn> method(options(mode, 4, r, 1000, 21 + i));
      DropCounters drops;
      const auto stats = run<Scn, T>(method, scene, i == 0 ? 600 : 2400, drops, r);
      const auto& s = stats[0];
      INFO(to_string(mode) << " r = " << r << ": " << s.mean() << " +- " << s.standard_error() << ", disk average "
                           << disk_average(r) << ", L " << truth);
      CHECK(drops.total() == 0);
      CHECK_FALSE(testing::student_t_test(s, disk_average(r)).rejects(alpha));
      CHECK(testing::student_t_test(s, truth).rejects(alpha));  // the bias is resolved
      bias[i] = s.mean() - truth;
      error[i] = s.standard_error();
    }
    // Halving r cuts the bias about fourfold (exactly: the disk averages' ratio, ~3.5 here).
    const double ratio = bias[0] / bias[1];
    const double ratio_error = std::abs(ratio) * std::hypot(error[0] / bias[0], error[1] / bias[1]);
    const double exact = (disk_average(r1) - truth) / (disk_average(r2) - truth);
    INFO(to_string(mode) << " bias ratio " << ratio << " +- " << ratio_error << " vs " << exact);
    CHECK(std::abs(ratio - exact) < 3.5 * ratio_error);
    CHECK(ratio > 2.5);
  }
}

TEMPLATE_TEST_CASE("every mode gives the same image for a seed serially and on two threads", "[algorithms][vcm]", float,
                   double) {
  using T = TestType;
  const auto down = camera<T>({T(0.1), T(-0.05), T(0.6)}, {0, 0, -1}, {1, 0, 0}, {0, 1, 0}, 9, 8, T(70));
  using Scn = Pinhole<testing::DiskLitPlane<T>>;
  const Scn scene(down, testing::DiskLitPlaneParameters<T>{2, 1, T(0.5), 2, T(0.6)}, std::vector<Vec2<T>>{{0, 0}});
  for (const VcmMode mode : {VcmMode::bdpt, VcmMode::ppm, VcmMode::bpm, VcmMode::vcm}) {
    const VertexConnectionMerging<Scn> method(options(mode, 6, 0.2, 1.5, 99));
    Framebuffer<T> serial(9, 8), threaded(9, 8);
    DropCounters d1, d2;
    for (std::uint64_t i = 0; i < 3; ++i) {
      method.render_iteration(scene, i, serial, d1, SerialFor{});
      method.render_iteration(scene, i, threaded, d2, TwoThreads{});
    }
    INFO(to_string(mode));
    CHECK(std::memcmp(serial.pixels().data(), threaded.pixels().data(), sizeof(T) * serial.pixel_count()) == 0);
    CHECK(d1.counts == d2.counts);
    double sum = 0;
    for (const T v : serial.pixels()) sum += double(v);
    CHECK(sum > 0);
    // A different seed gives a different image.
    const VertexConnectionMerging<Scn> other(options(mode, 6, 0.2, 1.5, 100));
    Framebuffer<T> image(9, 8);
    for (std::uint64_t i = 0; i < 3; ++i) other.render_iteration(scene, i, image, d1, SerialFor{});
    CHECK(std::memcmp(serial.pixels().data(), image.pixels().data(), sizeof(T) * serial.pixel_count()) != 0);
  }
}

// A fast check of every mode for the sanitizer build (which runs no [stat] test): the sphere
// furnace at 300 iterations of 3 x 3 pixels, each estimate within 5 standard errors (fixed seeds,
// so deterministic). It catches a weight off by a constant factor, not small biases.
TEST_CASE("BDPT, PPM, BPM and VCM: a fast sphere-furnace check for the sanitizer run", "[algorithms][vcm]") {
  using T = double;
  const auto sp = furnace<T>();
  const auto inside = furnace_camera<T>();
  using Scn = Pinhole<testing::SphereInterior<T>>;
  const Scn scene(inside, sp, std::vector<Vec3<T>>{{0, 0, 1}});
  const std::size_t max_length = 4;
  double expected = 0;
  for (unsigned b = 0; b < max_length; ++b) expected += scene.bounce_radiance_at(Vec3<T>(0, 0, 1), b);
  for (const VcmMode mode : {VcmMode::bdpt, VcmMode::ppm, VcmMode::bpm, VcmMode::vcm}) {
    const VertexConnectionMerging<Scn> method(options(mode, max_length, 0.1, 10, 8));
    DropCounters drops;
    const auto stats = run<Scn, T>(method, scene, 300, drops, 0.1);
    const auto& mean = stats.back();
    INFO(to_string(mode) << ": " << mean.mean() << " +- " << mean.standard_error() << " vs " << expected);
    CHECK(drops.total() == 0);
    CHECK(std::abs(mean.mean() - expected) <= 5 * mean.standard_error());
    CHECK(mean.standard_error() < 0.03 * expected);
  }
}
