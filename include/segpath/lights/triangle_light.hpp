// One-sided Lambertian triangle area lights: emissive triangles of one radiance or one radiance
// each, sampled by area, modelling SampledEmitter (N30 light-start ends, N34 next-event ends).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "segpath/concepts/emitter.hpp"
#include "segpath/core/format.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"

namespace segpath {

/// One emissive triangle as the scene knows it. `primitive_id` is the id the scene's
/// intersector reports in SurfacePoint::primitive_id for hits on this triangle: that id is
/// how TriangleLights recognises its points (see TriangleLights). `material_id` is copied
/// into sampled points so that they look like the scene's own hit points. `normal` picks the
/// emitting side: the zero vector (default) means the winding normal
/// normalize(cross(p1 - p0, p2 - p0)); otherwise it must be (anti)parallel to that normal.
template <Real T>
struct EmissiveTriangle {
  Vec3<T> p0{}, p1{}, p2{};
  std::uint32_t primitive_id = invalid_id;
  std::uint32_t material_id = invalid_id;
  Vec3<T> normal{0, 0, 0};
};

/// Several one-sided Lambertian triangles of radiance L (one for all, or one per triangle),
/// sampled as one emitter.
///
/// Scene ids: the light stores the primitive ids it was given. A light end y is emissive iff
/// y.kind == PointKind::surface and y.primitive_id is one of those ids (the position is not
/// checked: the id names the triangle). So a scene passes, for every emissive triangle, the
/// id its intersector reports for that triangle; ids must be unique and != invalid_id.
///
/// Sampling (N30, N34): a triangle is chosen with probability area_i / A (A the total area)
/// by u_select, then a uniform point on it, so every position density is 1/A in area
/// measure, the selection included (also with per-triangle radiances: selection ignores
/// them, so bright small triangles are not favoured). Zero-area triangles are kept (their ids stay known)
/// but are never sampled and have radiance and densities 0. sample_emission adds a
/// cosine-weighted direction about the normal (density cos / pi in solid angle).
template <Spectrum S>
class TriangleLights {
 public:
  using Scalar = spectrum_scalar_t<S>;

  /// Throws std::invalid_argument for non-finite vertices or normals, a normal that is zero
  /// after normalisation or not parallel to the winding normal (|cos| < 1 - 1e-3), an id
  /// equal to invalid_id or repeated, a radiance that is negative or non-finite in some
  /// channel, or a total area that is not finite and > 0 (e.g. no triangles).
  TriangleLights(const std::vector<EmissiveTriangle<Scalar>>& triangles, const S& radiance)
      : TriangleLights(triangles, std::vector<S>(triangles.size(), checked(radiance, "")),
                       radiance) {}

  /// Triangle i emits radiances[i]. Throws std::invalid_argument as the one-radiance
  /// constructor does, and when radiances.size() != triangles.size().
  TriangleLights(const std::vector<EmissiveTriangle<Scalar>>& triangles,
                 const std::vector<S>& radiances)
      : TriangleLights(triangles, radiances,
                       radiances.empty() ? S(Scalar(0)) : radiances.front()) {}

  [[nodiscard]] std::size_t size() const noexcept { return triangles_.size(); }
  [[nodiscard]] Scalar total_area() const noexcept { return total_area_; }
  /// The radiance of the one-radiance constructor; with per-triangle radiances, triangle 0's
  /// (see radiance_of).
  [[nodiscard]] const S& emitted_radiance() const noexcept { return radiance_; }
  /// The radiance of triangle `i` (in the order given to the constructor).
  [[nodiscard]] const S& radiance_of(std::size_t i) const noexcept {
    return triangles_[i].radiance;
  }
  /// The area of triangle `i` (in the order given to the constructor).
  [[nodiscard]] Scalar area(std::size_t i) const noexcept { return triangles_[i].area; }
  /// The unit emitting normal of triangle `i`.
  [[nodiscard]] const Vec3<Scalar>& normal(std::size_t i) const noexcept {
    return triangles_[i].normal;
  }
  /// The index (constructor order) of the triangle with scene primitive id `id`, if any.
  [[nodiscard]] std::optional<std::uint32_t> find(std::uint32_t id) const noexcept {
    const auto it = std::lower_bound(by_id_.begin(), by_id_.end(),
                                     std::pair<std::uint32_t, std::uint32_t>(id, 0));
    if (it == by_id_.end() || it->first != id) return std::nullopt;
    return it->second;
  }

  /// L at a point of a non-degenerate triangle of this light, towards the front side; 0
  /// behind it and at every other endpoint.
  [[nodiscard]] S radiance(const EmissionQuery<Scalar>& q) const noexcept {
    const Entry* e = emitting(q.point);
    if (e == nullptr || !(glm::dot(q.to_sensor, e->normal) > Scalar(0))) return S(Scalar(0));
    return e->radiance;
  }

  /// A uniform area point (u_select chooses the triangle, u_position the point; density 1/A)
  /// and a cosine direction about its normal from u_direction (density cos / pi);
  /// nullopt for a grazing direction (density 0).
  [[nodiscard]] std::optional<EmissionSample<S>> sample_emission(
      const EmissionSampleQuery<Scalar>& q) const noexcept {
    const Entry& e = triangles_[select(q.u_select)];
    const SurfacePoint<Scalar> y = sample_point(e, q.u_position);
    const Vec3<Scalar> w =
        Frame<Scalar>::from_normal(y.normal).to_world(square_to_cosine_hemisphere(q.u_direction));
    // The density from the world direction, exactly as pdf_emission computes it.
    const Scalar pdf_direction = glm::dot(w, y.normal) * inv_pi<Scalar>;
    if (!(pdf_direction > Scalar(0))) return std::nullopt;
    return in_place_optional<EmissionSample<S>>(y, w, e.radiance, inv_total_area_, pdf_direction);
  }

  /// {1/A, max(cos, 0)/pi} at this light's points, {0, 0} elsewhere.
  [[nodiscard]] EmissionPdf<Scalar> pdf_emission(const EmissionPdfQuery<Scalar>& q) const noexcept {
    const Entry* e = emitting(q.point);
    if (e == nullptr) return EmissionPdf<Scalar>{};
    const Scalar cosine = glm::dot(q.direction, e->normal);
    return EmissionPdf<Scalar>{inv_total_area_,
                               cosine > Scalar(0) ? cosine * inv_pi<Scalar> : Scalar(0)};
  }

  /// A uniform area point whatever the receiver (density 1/A in area measure) and the
  /// radiance it sends towards the receiver (0 when the receiver is behind it); nullopt for
  /// a receiver at the sampled point.
  [[nodiscard]] std::optional<EmitterTowardsSample<S>> sample_towards(
      const EmitterTowardsQuery<Scalar>& q) const noexcept {
    const Entry& e = triangles_[select(q.u_select)];
    const SurfacePoint<Scalar> y = sample_point(e, q.u);
    Vec3<Scalar> to_receiver = q.receiver.position;  // a `direction` receiver stores it
    if (q.receiver.kind != PointKind::direction) {
      to_receiver -= y.position;
      const Scalar d2 = glm::dot(to_receiver, to_receiver);
      if (!(d2 > Scalar(0)) || !std::isfinite(d2)) return std::nullopt;
      to_receiver /= std::sqrt(d2);
    }
    const S le = glm::dot(to_receiver, y.normal) > Scalar(0) ? e.radiance : S(Scalar(0));
    return in_place_optional<EmitterTowardsSample<S>>(y, le, inv_total_area_);
  }

  /// 1/A at this light's points, 0 elsewhere (the density does not depend on the receiver).
  [[nodiscard]] Scalar pdf_towards(const EmitterPdfTowardsQuery<Scalar>& q) const noexcept {
    return emitting(q.point) != nullptr ? inv_total_area_ : Scalar(0);
  }

 private:
  struct Entry {
    Vec3<Scalar> p0{}, e1{}, e2{}, normal{0, 0, 1};
    Scalar area = 0;
    std::uint32_t primitive_id = invalid_id;
    std::uint32_t material_id = invalid_id;
    S radiance{};
  };

  /// `radiance` unchanged if it is finite and >= 0 in every channel; `which` names its triangle.
  static const S& checked(const S& radiance, const std::string& which) {
    if (!is_finite(radiance) || max_component(radiance * Scalar(-1)) > Scalar(0))
      throw std::invalid_argument("segpath::TriangleLights: " + which +
                                  "radiance must be finite and >= 0 in every channel, got " +
                                  least_channel_text(radiance));
    return radiance;
  }

  TriangleLights(const std::vector<EmissiveTriangle<Scalar>>& triangles,
                 const std::vector<S>& radiances, const S& first)
      : radiance_(first) {
    if (radiances.size() != triangles.size())
      throw std::invalid_argument("segpath::TriangleLights: " + std::to_string(radiances.size()) +
                                  " radiances for " + std::to_string(triangles.size()) +
                                  " triangles (give one per triangle)");
    if (triangles.size() >= invalid_id)
      throw std::invalid_argument("segpath::TriangleLights: too many triangles");
    triangles_.reserve(triangles.size());
    cdf_.reserve(triangles.size());
    by_id_.reserve(triangles.size());
    double total = 0;
    for (std::size_t i = 0; i < triangles.size(); ++i) {
      const EmissiveTriangle<Scalar>& t = triangles[i];
      const std::string which = "segpath::TriangleLights: triangle " + std::to_string(i);
      if (!is_finite(t.p0) || !is_finite(t.p1) || !is_finite(t.p2))
        throw std::invalid_argument(which + " has a non-finite vertex");
      if (t.primitive_id == invalid_id)
        throw std::invalid_argument(which + " has primitive_id == invalid_id");
      Entry e;
      e.radiance = checked(radiances[i], "triangle " + std::to_string(i) + ": ");
      e.p0 = t.p0;
      e.e1 = t.p1 - t.p0;
      e.e2 = t.p2 - t.p0;
      e.primitive_id = t.primitive_id;
      e.material_id = t.material_id;
      const Vec3<Scalar> c = glm::cross(e.e1, e.e2);
      const Scalar twice_area = glm::length(c);
      if (!std::isfinite(twice_area)) throw std::invalid_argument(which + " has a non-finite area");
      e.area = twice_area / Scalar(2);
      const Vec3<Scalar> winding = twice_area > Scalar(0) ? c / twice_area : Vec3<Scalar>(0, 0, 1);
      if (t.normal == Vec3<Scalar>(0, 0, 0)) {
        e.normal = winding;
      } else {
        const Scalar len = glm::length(t.normal);
        if (!is_finite(t.normal) || !std::isfinite(len) || !(len > Scalar(0)))
          throw std::invalid_argument(which + " has a non-finite normal");
        e.normal = t.normal / len;
        if (e.area > Scalar(0) && std::abs(glm::dot(e.normal, winding)) < Scalar(1) - Scalar(1e-3))
          throw std::invalid_argument(
              which + ": the given normal is not perpendicular to the triangle (|cos| = " +
              format_number(double(std::abs(glm::dot(e.normal, winding)))) + ")");
      }
      total += static_cast<double>(e.area);
      cdf_.push_back(static_cast<Scalar>(total));
      if (e.area > Scalar(0)) last_positive_ = static_cast<std::uint32_t>(i);
      by_id_.emplace_back(t.primitive_id, static_cast<std::uint32_t>(i));
      triangles_.push_back(e);
    }
    total_area_ = static_cast<Scalar>(total);
    if (!(total_area_ > Scalar(0)) || !std::isfinite(total_area_))
      throw std::invalid_argument(
          "segpath::TriangleLights: the total area must be finite and > 0, got " +
          format_number(double(total)));
    inv_total_area_ = Scalar(1) / total_area_;
    std::sort(by_id_.begin(), by_id_.end());
    for (std::size_t i = 1; i < by_id_.size(); ++i)
      if (by_id_[i].first == by_id_[i - 1].first)
        throw std::invalid_argument("segpath::TriangleLights: primitive id " +
                                    std::to_string(by_id_[i].first) + " is given twice");
  }


  /// The non-degenerate triangle `p` lies on, or nullptr.
  [[nodiscard]] const Entry* emitting(const SurfacePoint<Scalar>& p) const noexcept {
    if (p.kind != PointKind::surface) return nullptr;
    const auto i = find(p.primitive_id);
    if (!i) return nullptr;
    const Entry& e = triangles_[*i];
    return e.area > Scalar(0) ? &e : nullptr;
  }

  /// The triangle whose cumulative-area interval holds u_select * A: the first i with
  /// cdf_[i] > u_select * A, so an interval of zero width (a degenerate triangle) is never hit.
  [[nodiscard]] std::uint32_t select(Scalar u_select) const noexcept {
    const Scalar x = u_select * total_area_;
    const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), x);
    if (it == cdf_.end()) return last_positive_;  // u_select * A rounded up to A
    return static_cast<std::uint32_t>(it - cdf_.begin());
  }

  [[nodiscard]] static SurfacePoint<Scalar> sample_point(const Entry& e,
                                                         const Vec2<Scalar>& u) noexcept {
    const Vec2<Scalar> b = square_to_uniform_triangle(u);
    return SurfacePoint<Scalar>::on_surface(e.p0 + e.e1 * b.x + e.e2 * b.y, e.normal,
                                            e.primitive_id, e.material_id);
  }

  std::vector<Entry> triangles_;
  std::vector<Scalar> cdf_;  ///< cdf_[i] = area of triangles 0..i
  std::vector<std::pair<std::uint32_t, std::uint32_t>> by_id_;  ///< (primitive id, index), sorted
  S radiance_;
  Scalar total_area_ = 0;
  Scalar inv_total_area_ = 0;
  std::uint32_t last_positive_ = 0;
};

}  // namespace segpath
