// Deterministic properties of the reference BSDFs: sample/eval/pdf agreement, reciprocity,
// one-sidedness, finite output at extreme uniforms, normalisation, the delta lobes' geometry
// and coefficients, MaterialSet dispatch and parameter validation.
#include <array>
#include <cmath>
#include <limits>
#include <segpath/core/warp.hpp>
#include <segpath/materials/material_set.hpp>
#include <segpath/testing/integrate.hpp>
#include <stdexcept>
#include <string>

#include "materials/bsdf_test_support.hpp"
#include "support/catch.hpp"

using namespace segpath;
using namespace segpath::test_materials;

static_assert(Bsdf<Lambertian<float>, float>);
static_assert(Bsdf<Phong<double>, double>);
static_assert(Bsdf<Glossy<Rgb<float>>, Rgb<float>>);
static_assert(Bsdf<Mirror<Rgb<double>>, Rgb<double>>);
static_assert(Bsdf<Dielectric<float>, float>);
static_assert(Bsdf<MaterialSet<Rgb<float>>, Rgb<float>>);
static_assert(Bsdf<MaterialSet<double>, double>);
// Path tracing skips next-event estimation at delta-only points through this hook.
static_assert(HasIsDelta<MaterialSet<Rgb<float>>, Rgb<float>>);

namespace {

template <class T>
using Color = Rgb<T>;

/// The Cornell-box materials (cornell-boxes.md).
template <class T>
auto cornell_glossy() {
  return Glossy<Color<T>>(Color<T>(T(0.1)), Color<T>(T(0.7)), T(90));
}
template <class T>
auto cornell_phong() {
  return Phong<Color<T>>(Color<T>(T(0.7)), T(90));
}
template <class T>
auto cornell_red() {
  return Lambertian<Color<T>>{Color<T>(T(0.803922), T(0.152941), T(0.152941))};
}

template <class T>
bool close(const Color<T>& a, const Color<T>& b, double rel) {
  for (int i = 0; i < 3; ++i) {
    const double x = a[i], y = b[i];
    if (std::abs(x - y) > rel * std::max(std::abs(x), std::abs(y))) return false;
  }
  return true;
}
template <class T>
bool close(T a, T b, double rel) {
  return std::abs(double(a) - double(b)) <=
         rel * std::max(std::abs(double(a)), std::abs(double(b)));
}

/// Fixed directions (polar angle about the normal in degrees, azimuth), grazing included.
const std::array<std::pair<double, double>, 5> fixed_directions{
    {{0.0, 0.0}, {5.0, 1.0}, {45.0, 2.5}, {80.0, 4.0}, {89.5, 5.5}}};
const std::array<Transport, 2> modes{Transport::radiance, Transport::importance};

template <class T, class B>
void check_sample_matches_eval_and_pdf(const B& bsdf) {
  const auto p = test_point<T>();
  Pcg32 rng(11, 3);
  for (const auto& [theta, phi] : fixed_directions) {
    for (const Transport mode : modes) {
      const Vec3<T> fixed = direction_at<T>(theta, phi);
      int accepted = 0;
      for (int i = 0; i < 2000; ++i) {
        const auto s =
            bsdf.sample(BsdfSampleQuery<T>{p, fixed, rng.uniform2<T>(), rng.uniform<T>(), mode});
        if (!s) continue;
        ++accepted;
        INFO("theta " << theta << " mode " << int(mode) << " sample " << i);
        REQUIRE_FALSE(s->delta);
        REQUIRE(std::abs(glm::length(s->direction) - T(1)) < T(1e-5));
        const auto q = pair_query(p, fixed, s->direction, mode);
        REQUIRE(s->pdf > T(0));
        CHECK(close(s->pdf, bsdf.pdf(q), 1e-5));
        CHECK(close(s->value, bsdf.eval(q), 1e-5));
      }
      CHECK(accepted > 0);
    }
  }
}

template <class T, class B>
void check_extreme_uniforms(const B& bsdf) {
  const auto p = test_point<T>();
  const T top = T(1) - T(0x1p-24);
  const std::array<T, 2> ends{T(0), top};
  for (const auto& [theta, phi] : fixed_directions) {
    for (const Transport mode : modes) {
      for (const T ux : ends)
        for (const T uy : ends)
          for (const T ul : ends) {
            const auto s = bsdf.sample(
                BsdfSampleQuery<T>{p, direction_at<T>(theta, phi), Vec2<T>(ux, uy), ul, mode});
            if (!s) continue;
            INFO("theta " << theta << " u " << ux << ", " << uy << " u_lobe " << ul);
            CHECK(is_finite(s->direction));
            CHECK(is_finite(s->value));
            CHECK(std::isfinite(s->pdf));
            CHECK(s->pdf > T(0));
          }
    }
  }
}

template <class T, class B>
void check_reciprocity_and_one_sidedness(const B& bsdf, bool pdf_symmetric) {
  const auto p = test_point<T>();
  Pcg32 rng(5, 9);
  int non_zero = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vec3<T> a = square_to_uniform_sphere(rng.uniform2<T>());
    // Half of the partners near the mirror direction, where the Phong lobe lives.
    const Vec3<T> b = i % 2 == 0
                          ? glm::normalize(reflect(a, p.shading_normal) +
                                           T(0.2) * square_to_uniform_sphere(rng.uniform2<T>()))
                          : square_to_uniform_sphere(rng.uniform2<T>());
    for (const Transport mode : modes) {
      const auto ab = bsdf.eval(BsdfQuery<T>{p, a, b, mode});
      const auto ba = bsdf.eval(BsdfQuery<T>{p, b, a, mode});
      CHECK(ab == ba);
      if (pdf_symmetric)
        CHECK(bsdf.pdf(BsdfQuery<T>{p, a, b, mode}) == bsdf.pdf(BsdfQuery<T>{p, b, a, mode}));
      const bool below = !(glm::dot(a, p.normal) > T(1e-6)) || !(glm::dot(b, p.normal) > T(1e-6));
      if (below) {
        CHECK(is_black(ab));
        CHECK(bsdf.pdf(BsdfQuery<T>{p, a, b, mode}) == T(0));
      } else if (!is_black(ab)) {
        ++non_zero;
      }
    }
    if (!(glm::dot(a, p.normal) > T(1e-6)))
      CHECK_FALSE(bsdf.sample(BsdfSampleQuery<T>{p, a, rng.uniform2<T>(), rng.uniform<T>()}));
  }
  CHECK(non_zero > 100);
}

/// The integral of the pdf over the sphere, in a frame whose pole is `axis` (fine panels
/// near the pole resolve narrow lobes about it).
template <class T, class B>
double pdf_integral(const B& bsdf, const Vec3<T>& fixed, Transport mode, const glm::dvec3& axis,
                    int panels_theta) {
  const auto p = test_point<T>();
  const auto frame = Frame<double>::from_normal(glm::normalize(axis));
  return testing::integrate_sphere(
      [&](const glm::dvec3& d) {
        return double(bsdf.pdf(pair_query(p, fixed, to_t<T>(frame.to_world(d)), mode)));
      },
      panels_theta, 64);
}

}  // namespace

TEMPLATE_TEST_CASE("Non-delta samples carry eval and pdf of the sampled pair", "[materials]", float,
                   double) {
  using T = TestType;
  SECTION("Lambertian") { check_sample_matches_eval_and_pdf<T>(cornell_red<T>()); }
  SECTION("Phong") { check_sample_matches_eval_and_pdf<T>(cornell_phong<T>()); }
  SECTION("Phong, low exponent") {
    check_sample_matches_eval_and_pdf<T>(Phong<Color<T>>(Color<T>(T(0.9)), T(1.5)));
  }
  SECTION("Glossy") { check_sample_matches_eval_and_pdf<T>(cornell_glossy<T>()); }
}

TEMPLATE_TEST_CASE("Uniforms at 0 and 1 - 2^-24 give finite samples", "[materials]", float,
                   double) {
  using T = TestType;
  check_extreme_uniforms<T>(cornell_red<T>());
  check_extreme_uniforms<T>(cornell_phong<T>());
  check_extreme_uniforms<T>(Phong<Color<T>>(Color<T>(T(1)), T(0)));
  check_extreme_uniforms<T>(cornell_glossy<T>());
  check_extreme_uniforms<T>(Mirror<Color<T>>());
  check_extreme_uniforms<T>(Dielectric<Color<T>>(T(1.6)));
  check_extreme_uniforms<T>(Dielectric<Color<T>>(T(1)));
}

TEMPLATE_TEST_CASE("Opaque BSDFs are reciprocal and one-sided", "[materials]", float, double) {
  using T = TestType;
  SECTION("Lambertian") { check_reciprocity_and_one_sidedness<T>(cornell_red<T>(), false); }
  SECTION("Phong") { check_reciprocity_and_one_sidedness<T>(cornell_phong<T>(), true); }
  SECTION("Phong, exponent 3") {
    check_reciprocity_and_one_sidedness<T>(Phong<Color<T>>(Color<T>(T(0.5)), T(3)), true);
  }
  SECTION("Glossy") { check_reciprocity_and_one_sidedness<T>(cornell_glossy<T>(), false); }
  SECTION("Mirror") {
    const auto p = test_point<T>();
    const Mirror<Color<T>> mirror;
    CHECK_FALSE(
        mirror.sample(BsdfSampleQuery<T>{p, direction_at<T>(120, 1), Vec2<T>(T(0.5)), T(0.5)}));
    CHECK_FALSE(
        mirror.sample(BsdfSampleQuery<T>{p, direction_at<T>(90, 1), Vec2<T>(T(0.5)), T(0.5)}));
  }
}

TEMPLATE_TEST_CASE("The Phong lobe is the Cornell-box formula", "[materials]", float, double) {
  using T = TestType;
  const auto p = test_point<T>();
  const auto phong = cornell_phong<T>();
  const Vec3<T> a = direction_at<T>(30, 0.5);
  const Vec3<T> r = reflect(a, p.normal);
  const auto frame = Frame<T>::from_normal(r);
  for (const double alpha : {0.0, 0.05, 0.2, 0.6}) {
    const Vec3<T> b = frame.to_world(Vec3<T>(T(std::sin(alpha)), T(0), T(std::cos(alpha))));
    const double expected = 0.7 * 92.0 / (2 * std::numbers::pi) * std::pow(std::cos(alpha), 90.0);
    CHECK(phong.eval(BsdfQuery<T>{p, a, b}).g == Approx(expected).epsilon(1e-4));
    CHECK(phong.pdf(BsdfQuery<T>{p, a, b}) ==
          Approx(91.0 / (2 * std::numbers::pi) * std::pow(std::cos(alpha), 90.0)).epsilon(1e-4));
  }
  // The cut-off at cos(alpha) = 1e-3, with a low exponent so that the lobe is still large.
  const Phong<T> wide(T(1), T(1));
  for (const double c : {0.0009, 0.0011}) {
    const Vec3<T> b = frame.to_world(Vec3<T>(T(std::sqrt(1 - c * c)), T(0), T(c)));
    if (!(glm::dot(b, p.normal) > T(1e-6))) continue;
    const bool on = c > 0.001;
    CHECK((wide.eval(BsdfQuery<T>{p, a, b}) > T(0)) == on);
    CHECK((wide.pdf(BsdfQuery<T>{p, a, b}) > T(0)) == on);
  }
}

TEMPLATE_TEST_CASE("Densities integrate to 1 where the lobe lies above the surface", "[materials]",
                   float, double) {
  using T = TestType;
  const auto p = test_point<T>();
  const glm::dvec3 n = test_normal();
  for (const Transport mode : modes) {
    for (const double theta : {0.0, 5.0, 45.0}) {
      const Vec3<T> fixed = direction_at<T>(theta, 2.0);
      const glm::dvec3 r = to_d(reflect(fixed, p.normal));
      INFO("theta " << theta << " mode " << int(mode));
      CHECK(pdf_integral<T>(cornell_red<T>(), fixed, mode, n, 32) == Approx(1).epsilon(1e-6));
      CHECK(pdf_integral<T>(cornell_phong<T>(), fixed, mode, r, 384) == Approx(1).epsilon(1e-5));
      CHECK(pdf_integral<T>(cornell_glossy<T>(), fixed, mode, r, 384) == Approx(1).epsilon(1e-5));
    }
    // A grazing fixed direction: half the Phong lobe falls below the surface and is rejected.
    const Vec3<T> grazing = direction_at<T>(87.0, 2.0);
    const double i =
        pdf_integral<T>(cornell_phong<T>(), grazing, mode, to_d(reflect(grazing, p.normal)), 384);
    CHECK(i < 0.9);
    CHECK(i > 0.3);
  }
}

TEMPLATE_TEST_CASE("Mirror reflects exactly with coefficient R / |cos|", "[materials]", float,
                   double) {
  using T = TestType;
  const auto p = test_point<T>();
  const Mirror<Color<T>> mirror(Color<T>(T(0.9), T(0.5), T(1)));
  const double eps = std::is_same_v<T, float> ? 1e-6 : 1e-14;
  for (const auto& [theta, phi] : fixed_directions) {
    for (const Transport mode : modes) {
      const Vec3<T> w = direction_at<T>(theta, phi);
      const auto s = mirror.sample(BsdfSampleQuery<T>{p, w, Vec2<T>(T(0.3), T(0.8)), T(0.4), mode});
      REQUIRE(s);
      CHECK(s->delta);
      CHECK(s->pdf == T(1));
      const glm::dvec3 d = to_d(s->direction), wd = to_d(w), n = to_d(p.normal);
      const glm::dvec3 expected = 2.0 * glm::dot(wd, n) * n - wd;
      CHECK(glm::length(d - expected) < 4 * eps);
      const double c = std::abs(glm::dot(d, n));
      CHECK(close(s->value * T(c) / s->pdf, mirror.reflectance(), 4 * eps));
      CHECK(is_black(mirror.eval(BsdfQuery<T>{p, w, s->direction, mode})));
      CHECK(mirror.pdf(BsdfQuery<T>{p, w, s->direction, mode}) == T(0));
    }
  }
}

TEMPLATE_TEST_CASE("Dielectric refracts by Snell's law with the mode's scale", "[materials]", float,
                   double) {
  using T = TestType;
  const auto p = test_point<T>();
  const T eta = T(1.6);
  const Dielectric<T> glass(eta);
  const double eps = std::is_same_v<T, float> ? 2e-6 : 1e-13;
  const glm::dvec3 n = to_d(p.normal);
  // Outside (theta < 90) and inside (theta > 90; the critical angle is 38.68 deg from -n).
  for (const double theta : {0.0, 20.0, 60.0, 85.0, 180.0, 160.0, 145.0, 140.0, 130.0, 95.0}) {
    for (const Transport mode : modes) {
      INFO("theta " << theta << " mode " << int(mode));
      const Vec3<T> w = direction_at<T>(theta, 0.7);
      const glm::dvec3 wd = to_d(w);
      const bool outside = glm::dot(wd, n) > 0;
      const double e = outside ? 1.0 / double(eta) : double(eta);
      const double cos_i = std::abs(glm::dot(wd, n));
      const double f = fresnel_dielectric(cos_i, e);
      CHECK(double(glass.reflectance(p, w)) == Approx(f).epsilon(1e-5));
      const double sin2_t = e * e * (1 - cos_i * cos_i);
      const bool tir = sin2_t >= 1;
      CHECK(tir == (f == 1.0));
      // Reflection: u_lobe just below F.
      const auto r = glass.sample(BsdfSampleQuery<T>{p, w, Vec2<T>(T(0.5)), T(0), mode});
      REQUIRE(r);
      CHECK(r->delta);
      CHECK(r->pdf == Approx(f).epsilon(1e-5));
      CHECK(glm::length(to_d(r->direction) - (2.0 * glm::dot(wd, n) * n - wd)) < 4 * eps);
      CHECK(double(r->value) * std::abs(glm::dot(to_d(r->direction), n)) / double(r->pdf) ==
            Approx(1).epsilon(1e-5));
      // Refraction: u_lobe just below 1.
      const auto t =
          glass.sample(BsdfSampleQuery<T>{p, w, Vec2<T>(T(0.5)), T(1) - T(0x1p-24), mode});
      if (tir) {
        REQUIRE(t);
        CHECK(glm::dot(to_d(t->direction), n) * glm::dot(wd, n) > 0);
        continue;
      }
      REQUIRE(t);
      CHECK(t->delta);
      const glm::dvec3 d = to_d(t->direction);
      CHECK(glm::dot(d, n) * glm::dot(wd, n) < 0);                // other side
      CHECK(std::abs(glm::dot(glm::cross(wd, n), d)) < 8 * eps);  // plane of incidence
      const double sin_i = glm::length(glm::cross(wd, n));
      const double sin_t = glm::length(glm::cross(d, n));
      CHECK(sin_t == Approx(e * sin_i).margin(8 * eps));  // Snell
      if (sin_i > 1e-3) CHECK(glm::dot(d - glm::dot(d, n) * n, wd - glm::dot(wd, n) * n) < 0);
      CHECK(double(t->pdf) == Approx(1 - f).epsilon(1e-5));
      const double scale = mode == Transport::radiance ? e * e : 1.0;
      CHECK(double(t->value) * std::abs(glm::dot(d, n)) / double(t->pdf) ==
            Approx(scale).epsilon(1e-5));
      // F is the same seen from the refracted side.
      CHECK(double(glass.reflectance(p, t->direction)) == Approx(f).epsilon(1e-4).margin(1e-6));
      CHECK(glass.eval(BsdfQuery<T>{p, w, t->direction, mode}) == T(0));
      CHECK(glass.pdf(BsdfQuery<T>{p, w, t->direction, mode}) == T(0));
    }
  }
  // Normal incidence: F = ((eta - 1) / (eta + 1))^2.
  CHECK(double(glass.reflectance(p, p.normal)) == Approx(std::pow(0.6 / 2.6, 2)).epsilon(1e-5));
  // Index 1: nothing reflects, the direction passes straight through.
  const Dielectric<T> air(T(1));
  const Vec3<T> w = direction_at<T>(50, 1);
  const auto s = air.sample(BsdfSampleQuery<T>{p, w, Vec2<T>(T(0.5)), T(0)});
  REQUIRE(s);
  CHECK(glm::length(to_d(s->direction) + to_d(w)) < 1e-5);
  CHECK(s->pdf == T(1));
  // A fixed direction in the tangent plane has no lobe.
  CHECK_FALSE(glass.sample(BsdfSampleQuery<T>{p, direction_at<T>(90, 1), Vec2<T>(T(0.5)), T(0.5)}));
}

TEMPLATE_TEST_CASE("Fresnel reflectance matches known values", "[materials]", float, double) {
  using T = TestType;
  // Glass 1.5 at 45 degrees: Rs = 0.0920, Rp = 0.00847 (Hecht).
  const T c45 = T(std::sqrt(0.5));
  CHECK(fresnel_dielectric(c45, T(1) / T(1.5)) == Approx((0.092013 + 0.0084663) / 2).epsilon(1e-4));
  CHECK(fresnel_dielectric(T(1), T(1) / T(1.5)) == Approx(0.04).epsilon(1e-5));
  CHECK(fresnel_dielectric(T(0), T(1) / T(1.5)) == T(1));
  CHECK(fresnel_dielectric(T(0.5), T(1.6)) == T(1));  // beyond the critical angle inside
}

TEMPLATE_TEST_CASE("MaterialSet dispatches on the material id", "[materials]", float, double) {
  using T = TestType;
  MaterialSet<Color<T>> set;
  const auto red = set.add(cornell_red<T>());
  const auto floor = set.add(cornell_glossy<T>());
  const auto mirror = set.add(Mirror<Color<T>>());
  const auto glass = set.add(Dielectric<Color<T>>(T(1.6)));
  const auto phong = set.add(cornell_phong<T>());
  CHECK(set.size() == 5);
  auto p = test_point<T>();
  const Vec3<T> a = direction_at<T>(30, 1), b = direction_at<T>(31, 1 + std::numbers::pi);
  const BsdfSampleQuery<T> sq{p, a, Vec2<T>(T(0.3), T(0.6)), T(0.5)};
  auto same = [&](std::uint32_t id, const auto& bsdf) {
    p.material_id = id;
    CHECK(set.eval(BsdfQuery<T>{p, a, b}) == bsdf.eval(BsdfQuery<T>{p, a, b}));
    CHECK(set.pdf(BsdfQuery<T>{p, a, b}) == bsdf.pdf(BsdfQuery<T>{p, a, b}));
    const auto s1 = set.sample(sq);
    const auto s2 = bsdf.sample(sq);
    REQUIRE(bool(s1) == bool(s2));
    if (s1) {
      CHECK(s1->direction == s2->direction);
      CHECK(s1->value == s2->value);
      CHECK(s1->pdf == s2->pdf);
      CHECK(s1->delta == s2->delta);
      CHECK(set.is_delta(p) == s1->delta);
    }
  };
  same(red, cornell_red<T>());
  same(floor, cornell_glossy<T>());
  same(mirror, Mirror<Color<T>>());
  same(glass, Dielectric<Color<T>>(T(1.6)));
  same(phong, cornell_phong<T>());
  for (const std::uint32_t id : {std::uint32_t(5), invalid_id}) {
    p.material_id = id;
    CHECK(is_black(set.eval(BsdfQuery<T>{p, a, b})));
    CHECK(set.pdf(BsdfQuery<T>{p, a, b}) == T(0));
    CHECK_FALSE(set.sample(sq));
    CHECK_FALSE(set.is_delta(p));
  }
}

namespace {

/// HasScattersFrom's promise for one fixed direction w where scatters_from(p, w) is false:
/// eval and pdf are 0 for every pair that has w as either direction (both modes), and sample
/// with fixed w fails for every uniform. Returns the pairs and draws checked.
template <class T, class B>
int check_scatters_nothing(const B& bsdf, const SurfacePoint<T>& p, const Vec3<T>& w) {
  int checked = 0;
  for (double theta = 0; theta <= 180; theta += 7.5) {
    for (double phi = 0.1; phi < 6.2; phi += 0.7) {
      const Vec3<T> v = direction_at<T>(theta, phi);
      for (const Transport mode : {Transport::radiance, Transport::importance}) {
        CHECK(is_black(bsdf.eval(BsdfQuery<T>{p, w, v, mode})));
        CHECK(is_black(bsdf.eval(BsdfQuery<T>{p, v, w, mode})));
        CHECK(bsdf.pdf(BsdfQuery<T>{p, w, v, mode}) == T(0));
        CHECK(bsdf.pdf(BsdfQuery<T>{p, v, w, mode}) == T(0));
        ++checked;
      }
    }
  }
  for (double u = 0.05; u < 1; u += 0.15) {
    for (double lobe : {0.01, 0.5, 0.99}) {
      for (const Transport mode : {Transport::radiance, Transport::importance}) {
        CHECK_FALSE(bsdf.sample(BsdfSampleQuery<T>{p, w, Vec2<T>(T(u), T(1 - u)), T(lobe), mode}));
        ++checked;
      }
    }
  }
  return checked;
}

/// scatters_from over a sweep of fixed directions: true above the surface (and, for a
/// two-sided material, below it), and where false, nothing scatters (check_scatters_nothing).
/// At the test point, and at one whose shading normal leans 20 degrees off its geometric one
/// (the one-sided tests use the geometric normal).
template <class T, class B>
void check_scatters_from(const B& bsdf, bool two_sided) {
  static_assert(HasScattersFrom<B, Color<T>>);
  auto tilted = test_point<T>();
  tilted.shading_normal = direction_at<T>(20, 0.7);
  for (const bool tilt : {false, true}) {
    const SurfacePoint<T> p = tilt ? tilted : test_point<T>();
    int behind = 0;
    for (double theta = 0; theta <= 180; theta += 2.5) {
      for (double phi : {0.3, 0.7, 2.9, 5.1}) {
        const Vec3<T> w = direction_at<T>(theta, phi);
        INFO("theta " << theta << ", phi " << phi << ", shading normal tilted " << tilt);
        if (theta < 89 || (two_sided && theta > 91)) CHECK(bsdf.scatters_from(p, w));
        if (!bsdf.scatters_from(p, w)) behind += check_scatters_nothing<T>(bsdf, p, w) > 0;
      }
    }
    CHECK(behind >= (two_sided ? 0 : 4 * 36));  // every direction below a one-sided surface
  }
}

}  // namespace

TEMPLATE_TEST_CASE("scatters_from is false only where nothing scatters", "[materials]", float, double) {
  using T = TestType;
  SECTION("Lambertian") { check_scatters_from<T>(cornell_red<T>(), false); }
  SECTION("Phong") { check_scatters_from<T>(cornell_phong<T>(), false); }
  SECTION("Glossy") { check_scatters_from<T>(cornell_glossy<T>(), false); }
  SECTION("Mirror") { check_scatters_from<T>(Mirror<Color<T>>(), false); }
  SECTION("Dielectric") { check_scatters_from<T>(Dielectric<Color<T>>(T(1.6)), true); }
  SECTION("MaterialSet, and a point without a material") {
    MaterialSet<Color<T>> set;
    const auto red = set.add(cornell_red<T>());
    const auto glass = set.add(Dielectric<Color<T>>(T(1.6)));
    auto p = test_point<T>();
    const Vec3<T> above = direction_at<T>(40, 1), below = direction_at<T>(140, 1);
    p.material_id = red;
    CHECK(set.scatters_from(p, above));
    CHECK_FALSE(set.scatters_from(p, below));
    p.material_id = glass;
    CHECK(set.scatters_from(p, above));
    CHECK(set.scatters_from(p, below));
    p.material_id = invalid_id;  // black: eval 0, pdf 0, sample nullopt
    CHECK_FALSE(set.scatters_from(p, above));
    check_scatters_nothing<T>(set, p, above);
  }
}

TEMPLATE_TEST_CASE("Material constructors reject bad parameters", "[materials]", float, double) {
  using T = TestType;
  const T inf = std::numeric_limits<T>::infinity();
  const T nan = std::numeric_limits<T>::quiet_NaN();
  CHECK_THROWS_AS(Phong<T>(T(0.5), T(-1)), std::invalid_argument);
  CHECK_THROWS_AS(Phong<T>(T(0.5), nan), std::invalid_argument);
  CHECK_THROWS_AS(Phong<T>(inf, T(2)), std::invalid_argument);
  CHECK_THROWS_AS(Glossy<T>(T(-0.5), T(0.5), T(2)), std::invalid_argument);
  CHECK_THROWS_AS(Glossy<T>(nan, T(0.5), T(2)), std::invalid_argument);
  CHECK_THROWS_AS(Glossy<T>(T(0.5), T(0.5), inf), std::invalid_argument);
  CHECK_THROWS_AS(Mirror<T>(nan), std::invalid_argument);
  CHECK_THROWS_AS(Dielectric<T>(T(0)), std::invalid_argument);
  CHECK_THROWS_AS(Dielectric<T>(T(-1.5)), std::invalid_argument);
  CHECK_THROWS_AS(Dielectric<T>(inf), std::invalid_argument);
  try {
    (void)Dielectric<T>(T(-2));
    FAIL("no exception");
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    CHECK(message.find("Dielectric") != std::string::npos);
    CHECK(message.find("-2") != std::string::npos);
  }
  CHECK_NOTHROW(Phong<T>(T(0), T(0)));
  CHECK_NOTHROW(Glossy<T>(T(0), T(0), T(1)));
}

// A negative channel rendered negative pixels (a Mirror of -1: PT's least pixel -1.19), and a
// Glossy with a negative diffuse channel passed while the channels' average was >= 0.
TEMPLATE_TEST_CASE("Materials reject a negative channel, naming it", "[materials]", float, double) {
  using T = TestType;
  using C = Rgb<T>;
  const C negative_green(T(0.5), T(-0.25), T(0.5));
  CHECK_THROWS_WITH(Phong<C>(negative_green, T(2)), Catch::Contains("Phong") && Catch::Contains("-0.25"));
  CHECK_THROWS_WITH(Glossy<C>(C(T(-1), T(1), T(1)), C(T(0.2)), T(2)), Catch::Contains("diffuse") && Catch::Contains("-1"));
  CHECK_THROWS_WITH(Glossy<C>(C(T(0.2)), negative_green, T(2)), Catch::Contains("-0.25"));
  CHECK_THROWS_WITH(Mirror<C>(negative_green), Catch::Contains("Mirror") && Catch::Contains("-0.25"));
  CHECK_THROWS_WITH(Mirror<T>(T(-1)), Catch::Contains("Mirror"));
  // A Lambertian is an aggregate: the set checks its albedo, naming the material.
  CHECK_THROWS_WITH(MaterialSet<C>({Lambertian<C>{C(T(0.5))}, Lambertian<C>{negative_green}}),
                    Catch::Contains("material 1 (Lambertian)") && Catch::Contains("-0.25"));
  MaterialSet<C> set;
  CHECK(set.add(Lambertian<C>{C(T(0.5))}) == 0);
  CHECK_THROWS_WITH(set.add(Lambertian<C>{C(std::numeric_limits<T>::quiet_NaN())}),
                    Catch::Contains("material 1 (Lambertian)") && Catch::Contains("non-finite"));
  CHECK(set.size() == 1);
  CHECK_NOTHROW(Glossy<C>(C(T(0)), C(T(0.5), T(0), T(1)), T(2)));
  CHECK_NOTHROW(Mirror<C>(C(T(0))));
}
