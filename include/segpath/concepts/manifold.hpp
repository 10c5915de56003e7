// The Manifold concept: the user's geometry and intersector (SPEC 3.2).
// Customization points (members of the user's type M, each taking one query struct):
//   M::Scalar, area(), sample_area(AreaSampleQuery), intersect(IntersectQuery),
//   visible(VisibilityQuery).
#pragma once

#include "segpath/config.hpp"
#include "segpath/core/ray.hpp"
#include "segpath/core/surface_point.hpp"

#include <concepts>
#include <limits>
#include <optional>

namespace segpath {

/// Draw a point of M uniformly by area from the uniforms `u` in [0, 1)^2.
template <Real T>
struct AreaSampleQuery {
  Vec2<T> u;
};

/// A point drawn by area and its area density (1 / area() for a Manifold).
template <Real T>
struct AreaSample {
  SurfacePoint<T> point;
  T pdf = 0;
};

/// The first surface hit along `ray` with distance in (0, t_max). Implementations offset
/// the origin (or ignore the surface it lies on) so a ray leaving a surface point does not
/// hit that point again.
template <Real T>
struct IntersectQuery {
  Ray<T> ray;
  T t_max = std::numeric_limits<T>::infinity();
};

template <Real T>
struct Hit {
  SurfacePoint<T> point;
  T distance = 0;
};

/// Mutual visibility V(from, to) of two endpoints (either may be a `point` endpoint, or `to`
/// a `direction` endpoint: then the query is whether the ray from `from` escapes).
template <Real T>
struct VisibilityQuery {
  const SurfacePoint<T>& from;
  const SurfacePoint<T>& to;
};

namespace detail {
template <class M>
concept HasScalar = requires { typename M::Scalar; } && Real<typename M::Scalar>;

template <class M>
concept HasArea = requires(const M& m) {
  { m.area() } -> std::convertible_to<typename M::Scalar>;
};

template <class M>
concept HasSampleArea = requires(const M& m, const AreaSampleQuery<typename M::Scalar>& q) {
  { m.sample_area(q) } -> std::same_as<std::optional<AreaSample<typename M::Scalar>>>;
};

template <class M>
concept HasIntersect = requires(const M& m, const IntersectQuery<typename M::Scalar>& q) {
  { m.intersect(q) } -> std::same_as<std::optional<Hit<typename M::Scalar>>>;
};

template <class M>
concept HasVisible = requires(const M& m, const VisibilityQuery<typename M::Scalar>& q) {
  { m.visible(q) } -> std::convertible_to<bool>;
};
}  // namespace detail

/// The scene surface M with area measure, which segment endpoints live on.
/// Syntactic requirements:
///  1. `M::Scalar` is float or double;
///  2. `m.area()` returns the total area |M|;
///  3. `m.sample_area(AreaSampleQuery)` returns std::optional<AreaSample>;
///  4. `m.intersect(IntersectQuery)` returns std::optional<Hit>;
///  5. `m.visible(VisibilityQuery)` returns something convertible to bool.
/// Semantic requirements:
///  6. area() is finite and > 0 for any manifold that is sampled by area;
///  7. sample_area draws uniformly by area: its pdf is 1 / area(); it returns nullopt only
///     for inputs it cannot map (never a point with a non-finite position);
///  8. intersect returns hits with finite position, unit geometric normal and an
///     unit shading normal; it does not report the surface the ray starts on;
///  9. visible(a, b) == visible(b, a) and is true exactly when the open segment between
///     the two endpoints meets no surface.
template <class M>
concept Manifold = detail::HasScalar<M> && detail::HasArea<M> && detail::HasSampleArea<M> &&
                   detail::HasIntersect<M> && detail::HasVisible<M>;

/// Optional customization point: `m.canonical_position(point)` maps a point to the one
/// representative of its equivalence class, for manifolds whose positions are not unique
/// (a periodic domain sampled in its universal cover). Clustering keys endpoints by it, so
/// all images of a point share a cluster. Without it, the position itself is used.
template <class M>
concept HasCanonicalPosition = requires(const M& m, const SurfacePoint<typename M::Scalar>& p) {
  { m.canonical_position(p) } -> std::convertible_to<Vec3<typename M::Scalar>>;
};

}  // namespace segpath
