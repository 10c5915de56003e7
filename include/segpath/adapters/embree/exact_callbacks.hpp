// The machinery behind EmbreeManifold (adapters/embree.hpp): the scene data and per-query
// context Embree's callbacks read, Embree's error callback, and the callbacks that re-test every
// candidate Embree proposes exactly, in double (triangles: the ray-plane distance; spheres: an
// exact ray-sphere test), ignoring the surfaces a query's endpoints lie on.
#pragma once

#include "segpath/concepts/manifold.hpp"
#include "segpath/core/warp.hpp"
#include <embree3/rtcore.h>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace segpath {

namespace detail {

[[nodiscard]] inline double max_abs(const Vec3<double>& v) noexcept {
  return std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
}

/// Half-width of the band around a surface inside which a point counts as lying on it: 2 to
/// 4 ulps of T at the point's largest coordinate (a point the manifold returns is within
/// 0.87 ulp of its surface: it is computed in double and rounded once), plus the rounding of
/// the double-precision surface data of magnitude `surface_scale`. Relative, so there is no
/// scene-scale epsilon.
template <Real T>
[[nodiscard]] double embree_on_surface_tolerance(const Vec3<double>& p,
                                                 double surface_scale) noexcept {
  constexpr double band = sizeof(T) <= sizeof(float) ? 0x1p-22 : 0x1p-48;
  return band * max_abs(p) + 0x1p-48 * surface_scale;
}

template <Real T>
[[nodiscard]] Vec3<double> to_double(const Vec3<T>& v) noexcept {
  return Vec3<double>(double(v.x), double(v.y), double(v.z));
}

/// The plane of one triangle in double precision; `normal` is zero for a degenerate triangle.
struct EmbreeTrianglePlane {
  Vec3<double> normal{0, 0, 0};
  double offset = 0;  ///< dot(normal, v0)
  double scale = 0;   ///< largest vertex coordinate magnitude
};

struct EmbreeTriangle {
  std::array<std::uint32_t, 3> vertex{};
  std::uint32_t material_id = 0;
  bool smooth = false;  ///< has per-vertex shading normals
};

struct EmbreeSphereData {
  Vec3<double> center{};
  double radius = 1;
  double scale = 0;  ///< max |center coordinate| + radius
  std::uint32_t material_id = 0;
};

/// Everything the Embree callbacks read; heap-allocated so a moved EmbreeManifold keeps the
/// pointers Embree holds valid.
template <Real T>
struct EmbreeSceneData {
  std::vector<Vec3<T>> vertices;
  std::vector<Vec3<T>> vertex_normals;  ///< unit, same size as vertices (zero where absent)
  std::vector<EmbreeTriangle> triangles;
  std::vector<EmbreeTrianglePlane> planes;
  std::vector<EmbreeSphereData> spheres;
  std::vector<double> cdf;  ///< running sum of primitive areas, in primitive-id order
  double total_area = 0;
  double extent = 0;  ///< largest coordinate magnitude of any primitive
  unsigned triangle_geometry = RTC_INVALID_GEOMETRY_ID;
  unsigned sphere_geometry = RTC_INVALID_GEOMETRY_ID;
};

/// The first Embree error reported through rtcSetDeviceErrorFunction.
struct EmbreeErrorState {
  std::atomic<bool> raised{false};
  RTCError code = RTC_ERROR_NONE;
  std::string message;
};

inline const char* embree_error_name(RTCError code) noexcept {
  switch (code) {
    case RTC_ERROR_NONE:
      return "RTC_ERROR_NONE";
    case RTC_ERROR_UNKNOWN:
      return "RTC_ERROR_UNKNOWN";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "RTC_ERROR_INVALID_ARGUMENT";
    case RTC_ERROR_INVALID_OPERATION:
      return "RTC_ERROR_INVALID_OPERATION";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "RTC_ERROR_OUT_OF_MEMORY";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "RTC_ERROR_UNSUPPORTED_CPU";
    case RTC_ERROR_CANCELLED:
      return "RTC_ERROR_CANCELLED";
  }
  return "unknown RTCError";
}

inline void embree_record_error(void* user, RTCError code, const char* message) {
  auto* state = static_cast<EmbreeErrorState*>(user);
  if (code == RTC_ERROR_NONE || state->raised.exchange(true)) return;
  state->code = code;
  state->message = message ? message : "";
}

/// The per-query state the callbacks see: Embree's context first, so Embree's pointer to it
/// is a pointer to the whole struct. Origin and direction are the caller's, in double, not
/// Embree's float copies; Embree's ray starts `back_off` behind the origin so that it also
/// reports hits its float arithmetic would place just behind it. The callbacks accept a hit
/// only at an exact distance in (0, t_max), and never on a surface the origin (or, with
/// `skip_far_surface`, the far endpoint) lies on.
struct EmbreeQueryContext {
  RTCIntersectContext base;
  const void* data;
  Vec3<double> origin;
  Vec3<double> direction;  ///< unit
  Vec3<double> far_point;
  double t_max;
  double back_off;
  bool skip_far_surface;
};
static_assert(std::is_standard_layout_v<EmbreeQueryContext>);

/// Whether Embree's candidate hit on triangle `id` is a hit of the query: not degenerate, not
/// a surface an endpoint lies on, and at an exact distance in (0, t_max).
template <Real T>
[[nodiscard]] bool embree_accept_triangle(const EmbreeSceneData<T>& data, unsigned id,
                                          const EmbreeQueryContext& q) noexcept {
  const EmbreeTrianglePlane& plane = data.planes[id];
  if (plane.normal == Vec3<double>(0, 0, 0)) return false;
  const double s = glm::dot(plane.normal, q.origin) - plane.offset;
  if (std::abs(s) <= embree_on_surface_tolerance<T>(q.origin, plane.scale)) return false;
  if (q.skip_far_surface && std::abs(glm::dot(plane.normal, q.far_point) - plane.offset) <=
                                embree_on_surface_tolerance<T>(q.far_point, plane.scale))
    return false;
  const double t = -s / glm::dot(plane.normal, q.direction);
  return t > 0 && t < q.t_max;
}

/// A query's endpoint bands without a surface's own scale: embree_on_surface_tolerance(p, 0)
/// of its origin and, where it skips its far surface, of its far point (else 0). A surface of
/// scale k adds 2^-48 k to them, as embree_on_surface_tolerance(p, k) does, with the same result.
struct EmbreeQueryBands {
  double origin = 0;
  double far_end = 0;
};
template <Real T>
[[nodiscard]] EmbreeQueryBands embree_query_bands(const EmbreeQueryContext& q) noexcept {
  return {embree_on_surface_tolerance<T>(q.origin, 0.0), q.skip_far_surface ? embree_on_surface_tolerance<T>(q.far_point, 0.0) : 0.0};
}

/// false where the query's line passes sphere `s` farther than its radius plus twice either
/// endpoint's on-surface band: it meets the sphere nowhere and has neither endpoint on it (every
/// point of the line is at least |h| from the centre). The common miss, decided without
/// embree_sphere_distance's square roots and inline in the direct traversal; true wherever it
/// cannot rule a meeting out (non-finite input included).
[[nodiscard]] SEGPATH_FORCE_INLINE bool embree_sphere_nearby(const EmbreeSphereData& s, const EmbreeQueryContext& q,
                                                             const EmbreeQueryBands& bands) noexcept {
  const Vec3<double> oc = q.origin - s.center;
  const Vec3<double> h = oc - glm::dot(oc, q.direction) * q.direction;
  const double surface = 0x1p-48 * s.scale;
  const double band = 2 * std::max(bands.origin + surface, q.skip_far_surface ? bands.far_end + surface : 0.0);
  return !(glm::dot(h, h) > (s.radius + band) * (s.radius + band));
}

/// The nearest exact distance in (0, t_max) at which the query meets sphere `id`, not counting
/// the points its endpoints lie on: from a point on the sphere the line meets it again only
/// at the end of the chord, t = -2 b (b = (o - c).d).
template <Real T>
[[nodiscard]] std::optional<double> embree_sphere_distance(const EmbreeSceneData<T>& data,
                                                           unsigned id,
                                                           const EmbreeQueryContext& q) noexcept {
  const EmbreeSphereData& s = data.spheres[id];
  if (!embree_sphere_nearby(s, q, embree_query_bands<T>(q))) return std::nullopt;
  const Vec3<double> oc = q.origin - s.center;
  const Vec3<double>& d = q.direction;
  const double b = glm::dot(oc, d);
  const Vec3<double> h = oc - b * d;
  const bool on_origin =
      std::abs(glm::length(oc) - s.radius) <= embree_on_surface_tolerance<T>(q.origin, s.scale);
  const bool on_far =
      q.skip_far_surface && std::abs(glm::length(q.far_point - s.center) - s.radius) <=
                                embree_on_surface_tolerance<T>(q.far_point, s.scale);
  double roots[2] = {-1, -1};
  // A chord shorter than the on-surface band cannot be told from touching the sphere.
  if (on_origin && on_far) return std::nullopt;  // a chord: the open segment meets no more of it
  if (on_origin) {
    roots[0] = -2 * b;
    if (!(roots[0] > embree_on_surface_tolerance<T>(q.origin, s.scale))) return std::nullopt;
  } else if (on_far) {
    roots[0] = -2 * b - q.t_max;  // the root other than the far endpoint (sum of roots -2 b)
    if (!(roots[0] < q.t_max - embree_on_surface_tolerance<T>(q.far_point, s.scale)))
      return std::nullopt;
  } else {
    // Discriminant from the closest approach h (Haines et al., Ray Tracing Gems ch. 7).
    const double disc = s.radius * s.radius - glm::dot(h, h);
    if (!(disc >= 0)) return std::nullopt;
    const double q_root = -b - std::copysign(std::sqrt(disc), b);
    const double c = glm::dot(oc, oc) - s.radius * s.radius;
    roots[0] = q_root;
    roots[1] = q_root != 0 ? c / q_root : 0;
    if (roots[0] > roots[1]) std::swap(roots[0], roots[1]);
  }
  for (double t : roots)
    if (t > 0 && t < q.t_max) return t;
  return std::nullopt;
}

template <Real T>
void embree_triangle_filter(const RTCFilterFunctionNArguments* args) {
  const auto* q = reinterpret_cast<const EmbreeQueryContext*>(args->context);
  const auto& data = *static_cast<const EmbreeSceneData<T>*>(q->data);
  for (unsigned i = 0; i < args->N; ++i)
    if (args->valid[i] != 0 &&
        !embree_accept_triangle(data, RTCHitN_primID(args->hit, args->N, i), *q))
      args->valid[i] = 0;
}

template <Real T>
void embree_sphere_bounds(const RTCBoundsFunctionArguments* args) {
  const auto& data = *static_cast<const EmbreeSceneData<T>*>(args->geometryUserPtr);
  const auto& s = data.spheres[args->primID];
  // Room for Embree's float ray straying from the exact one near the sphere's silhouette.
  const double pad = s.radius + 0x1p-16 * std::max(s.scale, data.extent);
  auto down = [](double x) {
    return std::nextafter(float(x), -std::numeric_limits<float>::infinity());
  };
  auto up = [](double x) {
    return std::nextafter(float(x), std::numeric_limits<float>::infinity());
  };
  *args->bounds_o =
      RTCBounds{down(s.center.x - pad), down(s.center.y - pad), down(s.center.z - pad), 0,
                up(s.center.x + pad),   up(s.center.y + pad),   up(s.center.z + pad),   0};
}

template <Real T>
void embree_sphere_intersect(const RTCIntersectFunctionNArguments* args) {
  if (args->N != 1 || args->valid[0] == 0) return;
  const auto* q = reinterpret_cast<const EmbreeQueryContext*>(args->context);
  const auto& data = *static_cast<const EmbreeSceneData<T>*>(args->geometryUserPtr);
  auto* rayhit = reinterpret_cast<RTCRayHit*>(args->rayhit);
  const auto t = embree_sphere_distance(data, args->primID, *q);
  if (!t || !(float(*t + q->back_off) < rayhit->ray.tfar)) return;
  const Vec3<double> n = q->origin + *t * q->direction - data.spheres[args->primID].center;
  rayhit->ray.tfar = float(*t + q->back_off);
  rayhit->hit.Ng_x = float(n.x);
  rayhit->hit.Ng_y = float(n.y);
  rayhit->hit.Ng_z = float(n.z);
  rayhit->hit.u = 0;
  rayhit->hit.v = 0;
  rayhit->hit.primID = args->primID;
  rayhit->hit.geomID = args->geomID;
  rayhit->hit.instID[0] = args->context->instID[0];
}

template <Real T>
void embree_sphere_occluded(const RTCOccludedFunctionNArguments* args) {
  if (args->N != 1 || args->valid[0] == 0) return;
  const auto* q = reinterpret_cast<const EmbreeQueryContext*>(args->context);
  const auto& data = *static_cast<const EmbreeSceneData<T>*>(args->geometryUserPtr);
  auto* ray = reinterpret_cast<RTCRay*>(args->ray);
  if (embree_sphere_distance(data, args->primID, *q))
    ray->tfar = -std::numeric_limits<float>::infinity();
}

struct EmbreeDeviceDeleter {
  void operator()(RTCDevice device) const noexcept { rtcReleaseDevice(device); }
};
struct EmbreeSceneDeleter {
  void operator()(RTCScene scene) const noexcept { rtcReleaseScene(scene); }
};

}  // namespace detail

}  // namespace segpath
