// Opt-in Embree 3 adapter: a Manifold (SPEC 3.2) over triangle meshes and exact analytic
// spheres, traced by Embree. Include it explicitly and link Embree (CMake target `embree`).
#pragma once

#include "segpath/concepts/manifold.hpp"
#include "segpath/core/in_place_optional.hpp"
#include "segpath/core/warp.hpp"
#include "segpath/adapters/embree/brute_force.hpp"
#include "segpath/adapters/embree/exact_callbacks.hpp"

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

/// A segpath Manifold (concepts/manifold.hpp) traced by Embree 3: triangle meshes and exact
/// spheres given by an EmbreeManifold::Description.
///
/// Primitive ids: triangles first, numbered consecutively over the meshes in order (mesh 0's
/// triangles, then mesh 1's, ...), then the spheres in order: sphere k has id
/// triangle_count() + k. material_id comes from the description.
///
/// Precision: the description is kept in T and, for queries, in double. Embree traverses in
/// float and only proposes candidates: every candidate is re-tested exactly in double from
/// the caller's origin (triangles: the ray-plane distance; spheres: an exact ray-sphere test
/// in an Embree user geometry), and returned points lie on the true surface (projected onto
/// the triangle's plane, or on the exact sphere). Spheres are user geometries rather than
/// RTC_GEOMETRY_TYPE_SPHERE_POINT (which Debian's Embree 3.13 does support): Embree's own
/// sphere test runs on the float ray and cannot tell a ray that starts on the sphere from
/// one that starts next to it, nor give a point exactly on the sphere.
///
/// Self-intersection (Manifold requirements 8 and 9). An IntersectQuery carries no normal to
/// offset along, so instead a ray ignores the surfaces its origin lies on: a triangle whose
/// plane passes within the on-surface band of the origin (2 to 4 ulps of T at the origin's
/// largest coordinate, on_surface_tolerance()) and a sphere whose surface does. A ray cannot
/// meet the plane it starts in at t > 0 (except inside it), and it meets the sphere it
/// starts on only at the far end of the chord, so rays from a point on a sphere into it, or
/// from inside it, find the far side. Embree's float ray starts a little behind the origin
/// (2^-16 of the largest coordinate of the origin or the scene) so that float rounding cannot hide
/// a surface just in front of it; candidates at an exact distance <= 0 are rejected. Nothing
/// depends on a scene-scale epsilon: tiny and huge scenes behave alike. Limit: a point within the
/// band of another surface as well (within ~3 ulps of an edge) lies on both and ignores both.
/// visible() treats both endpoints this way (point endpoints too: a point light placed on a
/// surface is not hidden by it) and traces the segment in a canonical direction, so
/// visible(a, b) == visible(b, a) exactly, and agrees with intersect.
///
/// Degenerate (zero-area) triangles have zero sampling weight and are never hit. A scene
/// without positive area (no geometry, or only degenerate triangles) is legal for intersect
/// and visible, but area() is 0 and sample_area() always returns nullopt; check
/// can_sample_area() before handing it to an estimator that samples by area.
///
/// Traversal: a scene whose queries are expected to make at most brute_force_max_expected_tests()
/// primitive tests (expected_direct_tests()) is traced, by default, without Embree's traversal:
/// every primitive is tested directly with the same exact tests (adapters/embree/brute_force.hpp),
/// but for the runs of compact triangles whose box a ray misses; at that cost this is faster.
/// Hits then differ from Embree's only where Embree's float traversal decides otherwise:
/// within float precision of a triangle's edge (Embree tests float vertices and a float ray),
/// or between two surfaces whose distances agree to float precision (Embree keeps the nearer
/// in float). The Embree scene is built either way (rtc_scene()).
///
/// Thread safety: all queries are const and may run concurrently. Not copyable; movable (a
/// moved-from manifold may only be destroyed or assigned to).
template <Real T>
class EmbreeManifold {
 public:
  using Scalar = T;

  /// One triangle mesh. Triangles index `positions`; their geometric normal follows the
  /// winding, normalize(cross(v1 - v0, v2 - v0)).
  struct Mesh {
    std::vector<Vec3<T>> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<Vec3<T>> normals;  ///< empty, or one shading normal per position (normalized here)
    std::uint32_t material_id = 0;
    std::vector<std::uint32_t>
        triangle_materials;  ///< empty, or one per triangle (overrides material_id)
  };
  /// An exact sphere; its geometric normal points outwards.
  struct Sphere {
    Vec3<T> center{};
    T radius = 1;
    std::uint32_t material_id = 0;
  };
  /// How queries find their candidates (see the class comment).
  enum class Traversal : std::uint8_t {
    automatic,    ///< brute_force up to brute_force_max_expected_tests() expected tests, else embree
    embree,       ///< Embree's BVH proposes candidates, the exact callbacks accept them
    brute_force,  ///< every primitive is tested exactly
  };
  /// The most primitive tests a query may be expected to make (expected_direct_tests()) for
  /// Traversal::automatic to trace a scene by direct tests: 40 on a CPU with AVX2, else 24
  /// (detail::brute_force_automatic_limit).
  [[nodiscard]] static std::uint32_t brute_force_max_expected_tests() noexcept { return detail::brute_force_automatic_limit(); }
  /// The limit's name before it counted expected tests instead of primitives.
  [[deprecated("renamed brute_force_max_expected_tests(): it counts expected tests, not primitives")]]
  [[nodiscard]] static std::uint32_t brute_force_max_primitives() noexcept { return brute_force_max_expected_tests(); }
  /// The runs (and expected_direct_tests()) of scenes of at most this many triangles are worked
  /// out; larger ones are traced by Embree. A run holds at most brute_force_chunk entries and
  /// costs a query at least one test, so above this count no scene comes within the limit.
  [[nodiscard]] static std::uint32_t brute_force_max_scanned_triangles() noexcept {
    return std::uint32_t(detail::brute_force_chunk) * brute_force_max_expected_tests();
  }

  struct Description {
    std::vector<Mesh> meshes;
    std::vector<Sphere> spheres;
    Traversal traversal = Traversal::automatic;
  };

  /// Builds the Embree scene. `device_config` is passed to rtcNewDevice (e.g. "threads=1").
  /// Throws std::invalid_argument for non-finite (or not float-representable) positions,
  /// out-of-range indices, malformed normal or material arrays, spheres with a non-finite
  /// centre or a radius that is not > 0 (or below 2^-16 of the centre's magnitude, which
  /// float traversal cannot resolve), and more than 2^32 - 2 primitives or vertices;
  /// std::runtime_error for any error Embree reports.
  explicit EmbreeManifold(const Description& description, const char* device_config = nullptr)
      : errors_(std::make_unique<detail::EmbreeErrorState>()),
        data_(std::make_unique<detail::EmbreeSceneData<T>>()) {
    load(description);
    build(device_config);
    const bool scanned = description.traversal == Traversal::brute_force || triangle_count() <= brute_force_max_scanned_triangles();
    expected_direct_tests_ = double(primitive_count());
    if (scanned) {
      direct_triangles_ = detail::brute_force_triangles(*data_);
      expected_direct_tests_ = double(sphere_count()) + direct_triangles_.expected_tests;
    }
    brute_force_ = description.traversal == Traversal::brute_force ||
                   (description.traversal == Traversal::automatic && scanned &&
                    expected_direct_tests_ <= double(brute_force_max_expected_tests()));
    if (!brute_force_) direct_triangles_ = {};
  }

  EmbreeManifold(const EmbreeManifold&) = delete;
  EmbreeManifold& operator=(const EmbreeManifold&) = delete;
  EmbreeManifold(EmbreeManifold&&) noexcept = default;
  EmbreeManifold& operator=(EmbreeManifold&&) noexcept = default;
  ~EmbreeManifold() = default;

  [[nodiscard]] std::uint32_t triangle_count() const noexcept {
    return std::uint32_t(data_->triangles.size());
  }
  [[nodiscard]] std::uint32_t sphere_count() const noexcept {
    return std::uint32_t(data_->spheres.size());
  }
  [[nodiscard]] std::uint32_t primitive_count() const noexcept {
    return triangle_count() + sphere_count();
  }
  /// The area of one primitive (0 for a degenerate triangle or an unknown id).
  [[nodiscard]] T primitive_area(std::uint32_t id) const noexcept {
    if (id >= data_->cdf.size()) return T(0);
    return T(data_->cdf[id] - (id == 0 ? 0.0 : data_->cdf[id - 1]));
  }
  /// Whether queries test every primitive directly (Traversal::brute_force, or automatic where
  /// expected_direct_tests() is within the limit) rather than through Embree's traversal.
  [[nodiscard]] bool brute_force() const noexcept { return brute_force_; }
  /// The primitive tests a direct query is expected to make, whatever the traversal: the
  /// spheres, the entries of the unbounded runs (padding to whole lanes included), and per
  /// bounded run its box test and its triangles times the chance that a ray meets its box
  /// (detail::brute_force_expected_tests). primitive_count() above
  /// brute_force_max_scanned_triangles() (unless Traversal::brute_force), where the runs are not
  /// worked out.
  [[nodiscard]] double expected_direct_tests() const noexcept { return expected_direct_tests_; }
  /// Whether sample_area can draw points: the total area is positive.
  [[nodiscard]] bool can_sample_area() const noexcept { return data_->total_area > 0; }
  /// The Embree scene, for renderers that trace their own rays too.
  [[nodiscard]] RTCScene rtc_scene() const noexcept { return scene_.get(); }

  // ---- Manifold ------------------------------------------------------------------------

  /// Total area |M| of all triangles and spheres.
  [[nodiscard]] T area() const noexcept { return T(data_->total_area); }

  /// A point uniformly by area (Manifold requirement 7): a primitive by binary search in the
  /// area CDF with u.x, whose remainder is re-used with u.y to place the point on it. pdf =
  /// 1 / area(). nullopt when the total area is 0 or u is outside [0, 1)^2.
  [[nodiscard]] std::optional<AreaSample<T>> sample_area(
      const AreaSampleQuery<T>& q) const noexcept {
    const auto& d = *data_;
    if (!(d.total_area > 0) || !(q.u.x >= 0 && q.u.x < 1 && q.u.y >= 0 && q.u.y < 1))
      return std::nullopt;
    const double target = double(q.u.x) * d.total_area;
    std::size_t id =
        std::size_t(std::upper_bound(d.cdf.begin(), d.cdf.end(), target) - d.cdf.begin());
    if (id == d.cdf.size()) {  // rounding at u.x -> 1: the last primitive with positive area
      id = d.cdf.size() - 1;
      while (id > 0 && d.cdf[id] == d.cdf[id - 1]) --id;
    }
    const double lo = id == 0 ? 0.0 : d.cdf[id - 1];
    const double reused = std::clamp((target - lo) / (d.cdf[id] - lo), 0.0, 1.0 - 0x1p-53);
    const Vec2<double> u(reused, double(q.u.y));
    SurfacePoint<T> p;
    if (id < d.triangles.size()) {
      const auto& tri = d.triangles[id];
      const Vec2<double> b = square_to_uniform_triangle(u);
      p.position =
          Vec3<T>(on_plane(id, detail::to_double(d.vertices[tri.vertex[0]]) * (1 - b.x - b.y) +
                                   detail::to_double(d.vertices[tri.vertex[1]]) * b.x +
                                   detail::to_double(d.vertices[tri.vertex[2]]) * b.y));
      p.normal = Vec3<T>(d.planes[id].normal);
      p.shading_normal = shading_normal(tri, p.normal, T(b.x), T(b.y));
      p.material_id = tri.material_id;
    } else {
      const auto& s = d.spheres[id - d.triangles.size()];
      const Vec3<double> n = square_to_uniform_sphere(u);
      p.position = Vec3<T>(s.center + s.radius * n);
      p.normal = p.shading_normal = Vec3<T>(n);
      p.material_id = s.material_id;
    }
    p.primitive_id = std::uint32_t(id);
    p.kind = PointKind::surface;
    return in_place_optional<AreaSample<T>>(p, T(1) / area());
  }

  /// The closest hit with distance in (0, t_max) (Manifold requirement 8); surfaces the
  /// origin lies on are ignored (see the class comment). `ray.direction` should be unit (it
  /// is renormalized in double); nullopt for a non-finite ray or t_max <= 0.
  [[nodiscard]] std::optional<Hit<T>> intersect(const IntersectQuery<T>& q) const noexcept {
    if (!is_finite(q.ray.origin) || !is_finite(q.ray.direction) || !(q.t_max > T(0)))
      return std::nullopt;
    const Vec3<double> o = detail::to_double(q.ray.origin);
    const double length = glm::length(detail::to_double(q.ray.direction));
    if (!(length > 0)) return std::nullopt;
    const Vec3<double> d = detail::to_double(q.ray.direction) / length;
    detail::EmbreeQueryContext ctx = context(o, d, double(q.t_max), nullptr);
    if (brute_force_) return direct_hit(ctx, q.t_max);
    RTCRayHit rayhit;
    set_ray(rayhit.ray, ctx);
    rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rayhit.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_.get(), &ctx.base, &rayhit);
    if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;

    const auto& data = *data_;
    if (rayhit.hit.geomID == data.triangle_geometry) {
      const auto& plane = data.planes[rayhit.hit.primID];
      const double t = (plane.offset - glm::dot(plane.normal, o)) / glm::dot(plane.normal, d);  // finite: accepted
      return hit_at(false, rayhit.hit.primID, t, T(rayhit.hit.u), T(rayhit.hit.v), o, d, q.t_max);
    }
    const auto exact = detail::embree_sphere_distance(data, rayhit.hit.primID, ctx);
    if (!exact) return std::nullopt;
    return hit_at(true, rayhit.hit.primID, *exact, T(0), T(0), o, d, q.t_max);
  }

  /// V(from, to) (Manifold requirement 9): whether the open segment between the endpoints
  /// meets no surface, ignoring the surfaces either endpoint lies on. A `direction` endpoint
  /// (position = the direction) asks whether the ray from the other endpoint escapes; two
  /// direction endpoints, or non-finite input, give false.
  [[nodiscard]] bool visible(const VisibilityQuery<T>& q) const noexcept {
    const SurfacePoint<T>* a = &q.from;
    const SurfacePoint<T>* b = &q.to;
    if (a->kind == PointKind::direction) std::swap(a, b);
    if (a->kind == PointKind::direction || !is_finite(a->position) || !is_finite(b->position))
      return false;
    if (b->kind == PointKind::direction) {
      const Vec3<double> d = detail::to_double(b->position);
      const double length = glm::length(d);
      if (!(length > 0) || !std::isfinite(length)) return false;
      auto ctx = context(detail::to_double(a->position), d / length, std::numeric_limits<double>::infinity(), nullptr);
      return !occluded(ctx);
    }
    // Trace from the lexicographically smaller endpoint: the same query either way round.
    if (std::tie(b->position.x, b->position.y, b->position.z) <
        std::tie(a->position.x, a->position.y, a->position.z))
      std::swap(a, b);
    const Vec3<double> o = detail::to_double(a->position);
    const Vec3<double> far = detail::to_double(b->position);
    const double distance = glm::length(far - o);
    if (distance == 0) return true;
    if (!std::isfinite(distance)) return false;
    auto ctx = context(o, (far - o) / distance, distance, &far);
    return !occluded(ctx);
  }

  /// The on-surface band (see the class comment) for a point p and a surface whose
  /// coordinates reach `surface_scale` in magnitude.
  [[nodiscard]] static double on_surface_tolerance(const Vec3<T>& p,
                                                   double surface_scale = 0) noexcept {
    return detail::embree_on_surface_tolerance<T>(detail::to_double(p), surface_scale);
  }

 private:
  [[nodiscard]] detail::EmbreeQueryContext context(const Vec3<double>& o, const Vec3<double>& d,
                                                   double t_max,
                                                   const Vec3<double>* far) const noexcept {
    // Every field is set below; Embree's part is set up only where Embree traverses.
    detail::EmbreeQueryContext ctx;
    if (brute_force_) ctx.base = RTCIntersectContext{};
    else rtcInitIntersectContext(&ctx.base);
    ctx.data = data_.get();
    ctx.origin = o;
    ctx.direction = d;
    ctx.far_point = far ? *far : o;
    ctx.t_max = t_max;
    // Covers the float rounding of Embree's ray and hit arithmetic (2^-16 = 128+ ulps).
    ctx.back_off = 0x1p-16 * std::max(detail::max_abs(o), data_->extent);
    ctx.skip_far_surface = far != nullptr;
    return ctx;
  }

  /// Embree's float ray for a query: from back_off behind the origin to back_off past t_max.
  static void set_ray(RTCRay& ray, const detail::EmbreeQueryContext& ctx) noexcept {
    const Vec3<double> o = ctx.origin - ctx.back_off * ctx.direction;
    ray.org_x = float(o.x);
    ray.org_y = float(o.y);
    ray.org_z = float(o.z);
    ray.dir_x = float(ctx.direction.x);
    ray.dir_y = float(ctx.direction.y);
    ray.dir_z = float(ctx.direction.z);
    ray.tnear = 0;
    const double t_far = ctx.t_max + 2 * ctx.back_off;
    ray.tfar = t_far < double(std::numeric_limits<float>::max())
                   ? float(t_far)
                   : std::numeric_limits<float>::infinity();
    ray.time = 0;
    ray.mask = ~0u;
    ray.id = 0;
    ray.flags = 0;
  }

  [[nodiscard]] bool occluded(detail::EmbreeQueryContext& ctx) const noexcept {
    if (brute_force_) return detail::brute_force_occluded(*data_, direct_triangles_, ctx);
    RTCRay ray;
    set_ray(ray, ctx);
    rtcOccluded1(scene_.get(), &ctx.base, &ray);
    return ray.tfar < 0;
  }

  /// The closest hit by direct tests.
  [[nodiscard]] std::optional<Hit<T>> direct_hit(const detail::EmbreeQueryContext& ctx, T t_max) const noexcept {
    const auto found = detail::brute_force_intersect(*data_, direct_triangles_, ctx);
    if (!found) return std::nullopt;
    return hit_at(found->sphere, found->index, found->t, T(found->b1), T(found->b2), ctx.origin, ctx.direction, t_max);
  }

  /// The hit at exact distance t along o + t d on triangle `index` (barycentrics b1, b2) or on
  /// sphere `index`: its point on the true surface; nullopt unless t is in (0, t_max) in T.
  [[nodiscard]] std::optional<Hit<T>> hit_at(bool sphere, std::uint32_t index, double t, T b1, T b2, const Vec3<double>& o,
                                             const Vec3<double>& d, T t_max) const noexcept {
    const auto& data = *data_;
    Hit<T> hit;
    if (!sphere) {
      const auto& tri = data.triangles[index];
      hit.point.position = Vec3<T>(on_plane(index, o + t * d));
      hit.point.normal = Vec3<T>(data.planes[index].normal);
      hit.point.shading_normal = shading_normal(tri, hit.point.normal, b1, b2);
      hit.point.primitive_id = index;
      hit.point.material_id = tri.material_id;
    } else {
      const auto& s = data.spheres[index];
      const Vec3<double> n = glm::normalize(o + t * d - s.center);
      hit.point.position = Vec3<T>(s.center + s.radius * n);
      hit.point.normal = hit.point.shading_normal = Vec3<T>(n);
      hit.point.primitive_id = triangle_count() + index;
      hit.point.material_id = s.material_id;
    }
    hit.point.kind = PointKind::surface;
    hit.distance = T(t);
    if (!(hit.distance > T(0) && hit.distance < t_max) || !is_finite(hit.point.position)) return std::nullopt;
    return hit;
  }

  /// p moved onto the plane of triangle `id` (in double), so that it lies within the
  /// on-surface band of its triangle once rounded to T.
  [[nodiscard]] Vec3<double> on_plane(std::size_t id, const Vec3<double>& p) const noexcept {
    const auto& plane = data_->planes[id];
    return p - (glm::dot(plane.normal, p) - plane.offset) * plane.normal;
  }

  /// The interpolated per-vertex normal at barycentrics (b1, b2), else the geometric normal.
  [[nodiscard]] Vec3<T> shading_normal(const detail::EmbreeTriangle& tri, const Vec3<T>& geometric,
                                       T b1, T b2) const noexcept {
    if (!tri.smooth) return geometric;
    const auto& n = data_->vertex_normals;
    const Vec3<T> s =
        n[tri.vertex[0]] * (T(1) - b1 - b2) + n[tri.vertex[1]] * b1 + n[tri.vertex[2]] * b2;
    const T length = glm::length(s);
    return length > T(0) && std::isfinite(length) ? s / length : geometric;
  }

  [[noreturn]] static void reject(const std::string& what) {
    throw std::invalid_argument("segpath::EmbreeManifold: " + what);
  }
  static std::string text(const Vec3<T>& v) {
    std::string s(1, '(');
    s.append(std::to_string(v.x)).append(", ").append(std::to_string(v.y)).append(", ");
    return s.append(std::to_string(v.z)).append(")");
  }
  /// Finite in T and representable as a float (Embree's precision).
  static bool representable(const Vec3<T>& v) {
    const Vec3<double> w = detail::to_double(v);
    return is_finite(w) && detail::max_abs(w) <= double(std::numeric_limits<float>::max());
  }

  void load(const Description& description) {
    auto& d = *data_;
    std::size_t vertex_count = 0, triangle_count = 0;
    for (const Mesh& mesh : description.meshes) {
      vertex_count += mesh.positions.size();
      triangle_count += mesh.triangles.size();
    }
    if (vertex_count >= invalid_id || triangle_count + description.spheres.size() >= invalid_id)
      reject("too many vertices or primitives (" + std::to_string(vertex_count) + " vertices, " +
             std::to_string(triangle_count + description.spheres.size()) +
             " primitives; at most 2^32 - 2)");
    d.vertices.reserve(vertex_count);
    d.vertex_normals.reserve(vertex_count);
    d.triangles.reserve(triangle_count);
    d.planes.reserve(triangle_count);
    d.cdf.reserve(triangle_count + description.spheres.size());

    for (std::size_t m = 0; m < description.meshes.size(); ++m) {
      const Mesh& mesh = description.meshes[m];
      const std::string where = "mesh " + std::to_string(m);
      const bool smooth = !mesh.normals.empty();
      if (smooth && mesh.normals.size() != mesh.positions.size())
        reject(where + " has " + std::to_string(mesh.normals.size()) + " normals for " +
               std::to_string(mesh.positions.size()) +
               " positions (give none or one per position)");
      if (!mesh.triangle_materials.empty() &&
          mesh.triangle_materials.size() != mesh.triangles.size())
        reject(where + " has " + std::to_string(mesh.triangle_materials.size()) +
               " triangle materials for " + std::to_string(mesh.triangles.size()) +
               " triangles (give none or one per triangle)");
      const auto base = std::uint32_t(d.vertices.size());
      for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        if (!representable(mesh.positions[i]))
          reject(where + ", vertex " + std::to_string(i) +
                 " is not finite in float: " + text(mesh.positions[i]));
        d.vertices.push_back(mesh.positions[i]);
        Vec3<T> n(0);
        if (smooth) {
          const T length = glm::length(mesh.normals[i]);
          if (!(length > T(0)) || !std::isfinite(length) || !is_finite(mesh.normals[i]))
            reject(where + ", normal " + std::to_string(i) +
                   " is zero or not finite: " + text(mesh.normals[i]));
          n = mesh.normals[i] / length;
        }
        d.vertex_normals.push_back(n);
      }
      for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        detail::EmbreeTriangle tri;
        for (int k = 0; k < 3; ++k) {
          const std::uint32_t index = mesh.triangles[t][std::size_t(k)];
          if (index >= mesh.positions.size())
            reject(where + ", triangle " + std::to_string(t) + ": index " + std::to_string(index) +
                   " out of range (the mesh has " + std::to_string(mesh.positions.size()) +
                   " positions)");
          tri.vertex[std::size_t(k)] = base + index;
        }
        tri.material_id =
            mesh.triangle_materials.empty() ? mesh.material_id : mesh.triangle_materials[t];
        tri.smooth = smooth;
        const Vec3<double> v0 = detail::to_double(d.vertices[tri.vertex[0]]);
        const Vec3<double> v1 = detail::to_double(d.vertices[tri.vertex[1]]);
        const Vec3<double> v2 = detail::to_double(d.vertices[tri.vertex[2]]);
        const Vec3<double> c = glm::cross(v1 - v0, v2 - v0);
        const double twice_area = glm::length(c);
        detail::EmbreeTrianglePlane plane;
        double area = 0;
        if (twice_area > 0 && std::isfinite(twice_area)) {
          plane.normal = c / twice_area;
          plane.offset = glm::dot(plane.normal, v0);
          plane.scale = std::max({detail::max_abs(v0), detail::max_abs(v1), detail::max_abs(v2)});
          d.extent = std::max(d.extent, plane.scale);
          area = 0.5 * twice_area;
        }
        d.triangles.push_back(tri);
        d.planes.push_back(plane);
        d.cdf.push_back(d.total_area += area);
      }
    }
    for (std::size_t k = 0; k < description.spheres.size(); ++k) {
      const Sphere& s = description.spheres[k];
      const std::string where = "sphere " + std::to_string(k);
      if (!representable(s.center)) reject(where + " has a non-finite centre " + text(s.center));
      const double r = double(s.radius);
      const Vec3<double> c = detail::to_double(s.center);
      if (!(r > 0) || !std::isfinite(r) || !representable(s.center + Vec3<T>(s.radius)))
        reject(where + " has radius " + std::to_string(r) + " (must be finite and > 0)");
      if (!(r > 0x1p-16 * detail::max_abs(c)))
        reject(where + " has radius " + std::to_string(r) +
               ", too small for float traversal at centre " + text(s.center) +
               " (must exceed 2^-16 of the largest centre coordinate)");
      d.spheres.push_back({c, r, detail::max_abs(c) + r, s.material_id});
      d.extent = std::max(d.extent, detail::max_abs(c) + r);
      d.cdf.push_back(d.total_area += 4 * pi<double> * r * r);
    }
  }

  void check(const char* call) const {
    if (errors_->raised.load())
      throw std::runtime_error(std::string("segpath::EmbreeManifold: ") + call + " failed with " +
                               detail::embree_error_name(errors_->code) + ": " + errors_->message);
  }

  void build(const char* device_config) {
    device_.reset(rtcNewDevice(device_config));
    if (!device_)
      throw std::runtime_error(std::string("segpath::EmbreeManifold: rtcNewDevice(\"") +
                               (device_config ? device_config : "") + "\") failed with " +
                               detail::embree_error_name(rtcGetDeviceError(nullptr)));
    rtcSetDeviceErrorFunction(device_.get(), detail::embree_record_error, errors_.get());
    auto& d = *data_;
    if (!d.triangles.empty() &&
        (rtcGetDeviceProperty(device_.get(), RTC_DEVICE_PROPERTY_TRIANGLE_GEOMETRY_SUPPORTED) ==
             0 ||
         rtcGetDeviceProperty(device_.get(), RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED) == 0))
      throw std::runtime_error(
          "segpath::EmbreeManifold: this Embree build lacks triangle geometry or filter functions");
    if (!d.spheres.empty() &&
        rtcGetDeviceProperty(device_.get(), RTC_DEVICE_PROPERTY_USER_GEOMETRY_SUPPORTED) == 0)
      throw std::runtime_error(
          "segpath::EmbreeManifold: this Embree build lacks user geometry (needed for spheres)");
    scene_.reset(rtcNewScene(device_.get()));
    check("rtcNewScene");
    rtcSetSceneFlags(scene_.get(), RTC_SCENE_FLAG_ROBUST);  // watertight triangle test

    // One triangle geometry for all meshes, so Embree's primID is the primitive id.
    if (!d.triangles.empty()) {
      RTCGeometry g = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
      check("rtcNewGeometry(RTC_GEOMETRY_TYPE_TRIANGLE)");
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), d.vertices.size()));
      auto* i = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
          g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), d.triangles.size()));
      if (!v || !i) {
        rtcReleaseGeometry(g);
        check("rtcSetNewGeometryBuffer");
        throw std::runtime_error(
            "segpath::EmbreeManifold: rtcSetNewGeometryBuffer returned no buffer");
      }
      for (std::size_t k = 0; k < d.vertices.size(); ++k)
        for (int c = 0; c < 3; ++c) v[3 * k + std::size_t(c)] = float(d.vertices[k][c]);
      for (std::size_t k = 0; k < d.triangles.size(); ++k)
        for (std::size_t c = 0; c < 3; ++c) i[3 * k + c] = d.triangles[k].vertex[c];
      rtcSetGeometryUserData(g, data_.get());
      rtcSetGeometryIntersectFilterFunction(g, detail::embree_triangle_filter<T>);
      rtcSetGeometryOccludedFilterFunction(g, detail::embree_triangle_filter<T>);
      rtcCommitGeometry(g);
      d.triangle_geometry = rtcAttachGeometry(scene_.get(), g);
      rtcReleaseGeometry(g);
      check("building the triangle geometry");
    }
    if (!d.spheres.empty()) {
      RTCGeometry g = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_USER);
      check("rtcNewGeometry(RTC_GEOMETRY_TYPE_USER)");
      rtcSetGeometryUserPrimitiveCount(g, unsigned(d.spheres.size()));
      rtcSetGeometryUserData(g, data_.get());
      rtcSetGeometryBoundsFunction(g, detail::embree_sphere_bounds<T>, nullptr);
      rtcSetGeometryIntersectFunction(g, detail::embree_sphere_intersect<T>);
      rtcSetGeometryOccludedFunction(g, detail::embree_sphere_occluded<T>);
      rtcCommitGeometry(g);
      d.sphere_geometry = rtcAttachGeometry(scene_.get(), g);
      rtcReleaseGeometry(g);
      check("building the sphere geometry");
    }
    rtcCommitScene(scene_.get());
    check("rtcCommitScene");
  }

  // Declaration order is destruction order in reverse: the scene goes before the device,
  // the device before the error state and data it points to.
  std::unique_ptr<detail::EmbreeErrorState> errors_;
  std::unique_ptr<detail::EmbreeSceneData<T>> data_;
  std::unique_ptr<RTCDeviceTy, detail::EmbreeDeviceDeleter> device_;
  std::unique_ptr<RTCSceneTy, detail::EmbreeSceneDeleter> scene_;
  /// The non-degenerate triangles' direct-test data where brute_force_, else empty.
  detail::BruteForceTriangles direct_triangles_;
  double expected_direct_tests_ = 0;
  bool brute_force_ = false;
};

}  // namespace segpath
