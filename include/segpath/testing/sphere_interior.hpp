// Analytic scene: the inside of a Lambertian sphere with position-dependent emission and
// albedo (SPEC section 2). Any two inner points see each other with G = 1/(4R^2), so
//   L(x) = L_e(x) + rho(x) <L_e> / (1 - <rho>),  bounce k >= 1: rho(x) <rho>^(k-1) <L_e>.
#pragma once

#include "segpath/concepts/scene.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"
#include "segpath/materials/lambertian.hpp"
#include "segpath/sensors/pinhole_camera.hpp"
#include "segpath/sensors/probe.hpp"

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath::testing {

/// Emission and albedo are affine in the outward unit vector u = (x - c) / R:
/// L_e(x) = emission_mean + emission_gradient . u, rho(x) = albedo_mean + albedo_gradient . u,
/// whose area averages are emission_mean and albedo_mean.
template <Real T>
struct SphereInteriorParameters {
  Vec3<T> center{0, 0, 0};
  T radius = 1;
  T emission_mean = 1;
  Vec3<T> emission_gradient{0, 0, 0};
  T albedo_mean = T(0.5);
  Vec3<T> albedo_gradient{0, 0, 0};
};

/// The scene; it models Scene and LightSampledScene with scalar spectra. Probes (the
/// sensor's pixels) look from the centre at given points of the sphere.
template <Real T>
class SphereInterior {
 public:
  using Scalar = T;
  using Spectrum = T;

  /// `probe_directions`: one probe per direction, measuring L at center + R * direction.
  SphereInterior(const SphereInteriorParameters<T>& p, const std::vector<Vec3<T>>& probe_directions)
      : p_(validated(p)), inverse_radius_(T(1) / p.radius), sensor_(probe_rays(p, probe_directions)) {}

  // ---- closed forms -------------------------------------------------------------------
  [[nodiscard]] T emission_at(const Vec3<T>& x) const noexcept { return p_.emission_mean + glm::dot(p_.emission_gradient, unit(x)); }
  [[nodiscard]] T albedo_at(const Vec3<T>& x) const noexcept { return p_.albedo_mean + glm::dot(p_.albedo_gradient, unit(x)); }
  /// L(x) = L_e(x) + rho(x) <L_e> / (1 - <rho>).
  [[nodiscard]] T radiance_at(const Vec3<T>& x) const noexcept {
    return emission_at(x) + albedo_at(x) * p_.emission_mean / (T(1) - p_.albedo_mean);
  }
  /// The part of L(x) carried by paths with exactly `bounces` reflections.
  [[nodiscard]] T bounce_radiance_at(const Vec3<T>& x, unsigned bounces) const noexcept {
    if (bounces == 0) return emission_at(x);
    return albedo_at(x) * std::pow(p_.albedo_mean, T(bounces - 1)) * p_.emission_mean;
  }
  /// The surface point probe `pixel` looks at.
  [[nodiscard]] Vec3<T> probe_target(std::uint32_t pixel) const noexcept {
    const Ray<T>& r = sensor_.probe(pixel);
    return r.origin + r.direction * p_.radius;
  }
  [[nodiscard]] const SphereInteriorParameters<T>& parameters() const noexcept { return p_; }

  // ---- Manifold ----------------------------------------------------------------------
  [[nodiscard]] T area() const noexcept { return T(4) * pi<T> * p_.radius * p_.radius; }

  [[nodiscard]] std::optional<AreaSample<T>> sample_area(const AreaSampleQuery<T>& q) const noexcept {
    const Vec3<T> u = square_to_uniform_sphere(q.u);
    return in_place_optional<AreaSample<T>>(point_at(u), T(1) / area());
  }

  /// Rays start inside or on the sphere; the hit is the far root of |o + t d - c| = R, so a
  /// ray leaving a surface point never re-hits it.
  [[nodiscard]] std::optional<Hit<T>> intersect(const IntersectQuery<T>& q) const noexcept {
    const Vec3<T> oc = q.ray.origin - p_.center;
    const T b = glm::dot(q.ray.direction, oc);
    const T c = glm::dot(oc, oc) - p_.radius * p_.radius;
    const T disc = b * b - c;
    if (!(disc >= T(0))) return std::nullopt;
    const T t = -b + std::sqrt(disc);
    if (!(t > T(0)) || !(t < q.t_max)) return std::nullopt;
    return in_place_optional<Hit<T>>(point_at(glm::normalize(oc + q.ray.direction * t)), t);
  }

  /// The sphere is convex: every two points inside or on it see each other from inside.
  [[nodiscard]] bool visible(const VisibilityQuery<T>&) const noexcept { return true; }

  // ---- radiometry --------------------------------------------------------------------
  class Materials {
   public:
    explicit Materials(const SphereInterior& s) : s_(&s) {}
    [[nodiscard]] T eval(const BsdfQuery<T>& q) const noexcept { return at(q.point).eval(q); }
    [[nodiscard]] std::optional<BsdfSample<T>> sample(const BsdfSampleQuery<T>& q) const noexcept { return at(q.point).sample(q); }
    [[nodiscard]] T pdf(const BsdfQuery<T>& q) const noexcept { return at(q.point).pdf(q); }

   private:
    [[nodiscard]] Lambertian<T> at(const SurfacePoint<T>& p) const noexcept { return Lambertian<T>{s_->albedo_at(p.position)}; }
    const SphereInterior* s_;
  };

  /// Lambertian emission L_e(x) into the inside; area-uniform emission sampling.
  class Emission {
   public:
    explicit Emission(const SphereInterior& s) : s_(&s) {}
    [[nodiscard]] T radiance(const EmissionQuery<T>& q) const noexcept {
      if (q.point.kind != PointKind::surface || glm::dot(q.to_sensor, q.point.normal) <= T(0)) return T(0);
      return s_->emission_at(q.point.position);
    }
    [[nodiscard]] std::optional<EmissionSample<T>> sample_emission(const EmissionSampleQuery<T>& q) const noexcept {
      const SurfacePoint<T> y = s_->point_at(square_to_uniform_sphere(q.u_position));
      const Vec3<T> local = square_to_cosine_hemisphere(q.u_direction);
      const T pdf_dir = square_to_cosine_hemisphere_pdf(local);
      if (!(pdf_dir > T(0))) return std::nullopt;
      return in_place_optional<EmissionSample<T>>(y, y.shading_frame().to_world(local), s_->emission_at(y.position), T(1) / s_->area(), pdf_dir);
    }
    [[nodiscard]] EmissionPdf<T> pdf_emission(const EmissionPdfQuery<T>& q) const noexcept {
      const T cosine = glm::dot(q.direction, q.point.normal);
      return EmissionPdf<T>{T(1) / s_->area(), cosine > T(0) ? cosine * inv_pi<T> : T(0)};
    }
    [[nodiscard]] std::optional<EmitterTowardsSample<T>> sample_towards(const EmitterTowardsQuery<T>& q) const noexcept {
      const SurfacePoint<T> y = s_->point_at(square_to_uniform_sphere(q.u));
      const Vec3<T> to_receiver = q.receiver.position - y.position;
      const T d2 = glm::dot(to_receiver, to_receiver);
      if (!(d2 > T(0))) return std::nullopt;
      const T le = radiance(EmissionQuery<T>{y, to_receiver / std::sqrt(d2)});
      return in_place_optional<EmitterTowardsSample<T>>(y, le, T(1) / s_->area());
    }
    [[nodiscard]] T pdf_towards(const EmitterPdfTowardsQuery<T>&) const noexcept { return T(1) / s_->area(); }

   private:
    const SphereInterior* s_;
  };

  [[nodiscard]] Materials bsdf() const noexcept { return Materials(*this); }
  [[nodiscard]] Emission emitter() const noexcept { return Emission(*this); }
  [[nodiscard]] const ProbeSensor<T>& sensor() const noexcept { return sensor_; }

  /// The surface point at outward unit vector u (its normal points inwards).
  [[nodiscard]] SurfacePoint<T> point_at(const Vec3<T>& u) const noexcept {
    return SurfacePoint<T>::on_surface(p_.center + u * p_.radius, -u, 0, 0);
  }

 private:
  [[nodiscard]] Vec3<T> unit(const Vec3<T>& x) const noexcept { return (x - p_.center) * inverse_radius_; }

  static SphereInteriorParameters<T> validated(const SphereInteriorParameters<T>& p) {
    auto fail = [](const std::string& what) {
      throw std::invalid_argument("segpath::testing::SphereInterior: " + what);
    };
    if (!is_finite(p.center) || !is_finite(p.emission_gradient) || !is_finite(p.albedo_gradient) ||
        !std::isfinite(p.radius) || !std::isfinite(p.emission_mean) || !std::isfinite(p.albedo_mean))
      fail("parameters must be finite");
    if (!(p.radius > T(0))) fail("radius must be > 0, got " + std::to_string(p.radius));
    if (p.emission_mean - glm::length(p.emission_gradient) < T(0))
      fail("emission must be >= 0 everywhere (emission_mean >= |emission_gradient|)");
    const T g = glm::length(p.albedo_gradient);
    if (p.albedo_mean - g < T(0) || !(p.albedo_mean + g < T(1)) || !(p.albedo_mean < T(1)))
      fail("albedo must lie in [0, 1) everywhere (|albedo_gradient| <= albedo_mean < 1 - |albedo_gradient|)");
    return p;
  }

  static std::vector<Ray<T>> probe_rays(const SphereInteriorParameters<T>& p, const std::vector<Vec3<T>>& directions) {
    std::vector<Ray<T>> rays;
    rays.reserve(directions.size());
    for (const auto& d : directions) rays.push_back(Ray<T>{p.center, d});
    return rays;
  }

  SphereInteriorParameters<T> p_;
  T inverse_radius_;
  ProbeSensor<T> sensor_;
};

/// The sphere interior seen from its centre through a 90-degree pinhole of size x size pixels
/// looking down -z: a closed Lambertian furnace for image-based methods (every pixel's
/// expectation has the closed form of the point it sees), without periodic images, where a
/// disk support is exact (a cap of chord radius r has area pi r^2).
template <Real T>
class PhotographedSphereInterior : public SphereInterior<T> {
 public:
  explicit PhotographedSphereInterior(std::uint32_t size, const SphereInteriorParameters<T>& p = {})
      : SphereInterior<T>(p, {{0, 0, -1}}), camera_(camera(p, size)) {}
  [[nodiscard]] const PinholeCamera<T>& sensor() const noexcept { return camera_; }

 private:
  static PinholeCamera<T> camera(const SphereInteriorParameters<T>& p, std::uint32_t size) {
    PinholeCameraParameters<T> c;
    c.position = p.center;
    c.forward = {0, 0, -1};
    c.right = {1, 0, 0};
    c.up = {0, 1, 0};
    c.width = c.height = size;
    c.fov_x_degrees = c.fov_y_degrees = 90;
    return PinholeCamera<T>(c);
  }
  PinholeCamera<T> camera_;
};

}  // namespace segpath::testing
