// Segment endpoints: points of the scene manifold M, plus the point-like and
// infinitely distant endpoints that pinhole cameras, point lights and distant lights need.
#pragma once

#include "segpath/core/frame.hpp"

#include <cstdint>
#include <limits>

namespace segpath {

inline constexpr std::uint32_t invalid_id = std::numeric_limits<std::uint32_t>::max();

/// The measure an endpoint is integrated in. It decides which factors the geometry term
/// (core/geometry.hpp) carries at that end:
///  - surface:   area measure on M; G has |n . s| at this end and 1/d^2 overall.
///  - point:     a delta position (pinhole, point light); no cosine at this end, the
///               sensor or emitter carries it. Its density is a discrete probability.
///  - direction: a point at infinity (distant light, environment); `position` is unused,
///               no cosine at this end and no 1/d^2; densities at the other end are in
///               solid angle.
enum class PointKind : std::uint8_t { surface, point, direction };

/// A segment endpoint (SPEC 1.1). `normal` is the geometric normal: the side it points to
/// is the front of one-sided surfaces. `shading_normal` defines the shading frame BSDFs are
/// evaluated in (shading_frame(); its tangent is the canonical one of Frame::from_normal).
/// Kept small on purpose: segment pools hold millions of these.
template <Real T>
struct SurfacePoint {
  Vec3<T> position{};
  Vec3<T> normal{0, 0, 1};
  Vec3<T> shading_normal{0, 0, 1};
  std::uint32_t primitive_id = invalid_id;
  std::uint32_t material_id = invalid_id;
  PointKind kind = PointKind::surface;

  [[nodiscard]] Frame<T> shading_frame() const noexcept { return Frame<T>::from_normal(shading_normal); }

  /// A surface point whose shading frame is built from the geometric normal.
  [[nodiscard]] static SurfacePoint on_surface(const Vec3<T>& p, const Vec3<T>& n,
                                               std::uint32_t primitive = invalid_id,
                                               std::uint32_t material = invalid_id) noexcept {
    return SurfacePoint{p, n, n, primitive, material, PointKind::surface};
  }
  /// The endpoint at infinity in direction `d` (unit): where a ray that leaves the scene ends.
  [[nodiscard]] static SurfacePoint at_infinity(const Vec3<T>& d) noexcept {
    return SurfacePoint{d, -d, -d, invalid_id, invalid_id, PointKind::direction};
  }
  /// A delta position without a surface (pinhole, point light); `n` is only a reference axis.
  [[nodiscard]] static SurfacePoint at_point(const Vec3<T>& p,
                                             const Vec3<T>& n = Vec3<T>(0, 0, 1)) noexcept {
    return SurfacePoint{p, n, n, invalid_id, invalid_id, PointKind::point};
  }
};

}  // namespace segpath
