// EmbreeManifold's traversal for scenes whose queries make a few dozen primitive tests: every
// primitive is tested directly, in double, with the same exact tests the callbacks apply to
// Embree's candidates (exact_callbacks.hpp). At that size a closest hit and a visibility query
// together cost less than through Embree's traversal, whose per-ray set-up and indirect
// callbacks a tiny BVH does not repay (docs/figures.md). Consecutive triangles that stay within
// a small box (a light fixture, an object's mesh) are skipped by one box test where a ray
// misses that box.
#pragma once

#include "segpath/adapters/embree/exact_callbacks.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace segpath::detail {

/// Triangles are tested in chunks of this many: a chunk's distances are computed by one loop
/// without a branch or a carried dependency (which the compiler vectorises), then compared.
inline constexpr std::size_t brute_force_chunk = 32;

/// Runs of triangles are padded to a multiple of this many (AVX2's double lanes) with entries
/// that no query hits, so that a chunk has no remainder to test one by one.
inline constexpr std::size_t brute_force_lanes = 4;

/// The non-degenerate triangles of a scene as the direct tests read them: structure of arrays,
/// so that the compiler can test several triangles per instruction without a branch. Per
/// triangle: its plane, the on-surface band of its own coordinates (2^-48 of their magnitude,
/// embree_on_surface_tolerance), its first vertex and the dual basis of its edges in its plane,
/// so that the barycentrics of a point p on the plane are b1 = dot(p - v0, dual1) and
/// b2 = dot(p - v0, dual2).
struct BruteForceTriangles {
  std::vector<double> nx, ny, nz, offset, band, v0x, v0y, v0z, d1x, d1y, d1z, d2x, d2y, d2z;
  std::vector<std::uint32_t> id;

  [[nodiscard]] std::size_t size() const noexcept { return id.size(); }

  void push_back(const Vec3<double>& n, double plane_offset, double plane_band, const Vec3<double>& v0,
                 const Vec3<double>& dual1, const Vec3<double>& dual2, std::uint32_t triangle) {
    nx.push_back(n.x), ny.push_back(n.y), nz.push_back(n.z), offset.push_back(plane_offset), band.push_back(plane_band);
    v0x.push_back(v0.x), v0y.push_back(v0.y), v0z.push_back(v0.z);
    d1x.push_back(dual1.x), d1y.push_back(dual1.y), d1z.push_back(dual1.z);
    d2x.push_back(dual2.x), d2y.push_back(dual2.y), d2z.push_back(dual2.z);
    id.push_back(triangle);
  }

  /// A run of consecutive triangles [first, first + count), and, where `bounded`, a box that
  /// holds every point the direct test can accept on them: a query whose ray misses the box
  /// skips the run. Runs keep the triangles' order, so a skip changes no answer.
  struct Run {
    std::uint32_t first = 0, count = 0;
    bool bounded = false;
    Vec3<double> lower{0}, upper{0};
  };
  std::vector<Run> runs;
  /// The triangle tests a query is expected to make (brute_force_expected_tests).
  double expected_tests = 0;
};

/// Whether the ray o + t d, t in [0, t_limit], meets the box [lower, upper]; `inverse` is 1 / d
/// componentwise. Conservative where a component of d is 0 (no 0 * infinity).
[[nodiscard]] SEGPATH_FORCE_INLINE bool brute_force_ray_meets_box(const Vec3<double>& lower, const Vec3<double>& upper,
                                                                  const Vec3<double>& origin, const Vec3<double>& direction,
                                                                  const Vec3<double>& inverse, double t_limit) noexcept {
  double near = 0, far = t_limit;
  for (int a = 0; a < 3; ++a) {
    if (direction[a] == 0) {
      if (origin[a] < lower[a] || origin[a] > upper[a]) return false;
      continue;
    }
    const double t0 = (lower[a] - origin[a]) * inverse[a], t1 = (upper[a] - origin[a]) * inverse[a];
    near = std::max(near, std::min(t0, t1));
    far = std::min(far, std::max(t0, t1));
  }
  return near <= far;
}

/// How much larger than its triangles' own box a run's box is, relative to the scene's extent
/// and coordinates: the accepted points lie within 2^-40 of an edge (brute_force_edge_slack)
/// and the distances round by ulps of double; this margin is orders of magnitude above both.
inline constexpr double brute_force_box_margin = 0x1p-24;

/// A run is bounded only while its box's surface area is at most this share of the scene's: a
/// ray through the scene meets a box about in proportion to its area, and the box test costs
/// about one triangle's.
inline constexpr double brute_force_bounded_area_share = 0.25;

/// The surface area of the box [lower, upper] (0 where it is empty).
[[nodiscard]] inline double brute_force_box_area(const Vec3<double>& lower, const Vec3<double>& upper) noexcept {
  const Vec3<double> e = glm::max(upper - lower, Vec3<double>(0));
  return 2 * (e.x * e.y + e.y * e.z + e.z * e.x);
}

/// A run's box test, in triangle tests: what one box costs a query against what one triangle
/// does (bench/renderer/embree_traversal_bench.cpp; docs/figures.md, session 41).
inline constexpr double brute_force_box_test_cost = 1.0;

/// The triangle tests a query through the runs is expected to make: every entry of an unbounded
/// run (padding included), and for a bounded run its box test plus its entries times the chance
/// that a ray through the scene meets its box, the ratio of the two boxes' surface areas (for
/// uniformly random lines through a convex region, Cauchy's formula).
[[nodiscard]] inline double brute_force_expected_tests(const std::vector<BruteForceTriangles::Run>& runs, double scene_area) noexcept {
  double tests = 0;
  for (const BruteForceTriangles::Run& run : runs) {
    if (!run.bounded) {
      tests += run.count;
      continue;
    }
    const double share = scene_area > 0 ? std::min(1.0, brute_force_box_area(run.lower, run.upper) / scene_area) : 1.0;
    tests += brute_force_box_test_cost + run.count * share;
  }
  return tests;
}

/// Groups `tris` into runs (BruteForceTriangles::Run) from each triangle's box (its vertices'
/// bounds, `lower[k]`, `upper[k]`) and pads each run to whole lanes:
///  - consecutive triangles whose common box stays small form a bounded run of up to
///    brute_force_chunk; a run of one is not worth its box test and is not bounded;
///  - consecutive triangles outside bounded runs form one unbounded run, which ends on a whole
///    lane by taking the first triangles of the bounded run after it (whose box still holds the
///    rest);
///  - padding entries have no plane (normal 0, offset 1): distance +infinity, which no query
///    accepts.
inline void brute_force_group_runs(BruteForceTriangles& tris, const std::vector<Vec3<double>>& lower,
                                   const std::vector<Vec3<double>>& upper) {
  using V = Vec3<double>;
  using Run = BruteForceTriangles::Run;
  const std::size_t n = tris.size();
  tris.runs.clear();
  tris.expected_tests = 0;
  if (n == 0) return;
  V scene_lo = lower[0], scene_hi = upper[0];
  for (std::size_t k = 1; k < n; ++k) scene_lo = glm::min(scene_lo, lower[k]), scene_hi = glm::max(scene_hi, upper[k]);
  const double scene_area = brute_force_box_area(scene_lo, scene_hi);
  const double limit = brute_force_bounded_area_share * scene_area;
  const V extent = scene_hi - scene_lo, largest = glm::max(glm::abs(scene_lo), glm::abs(scene_hi));
  const double margin = brute_force_box_margin * (std::max({extent.x, extent.y, extent.z}) + std::max({largest.x, largest.y, largest.z}));
  // The runs as cut: each stretch of small boxes greedily, one run per stretch of large ones.
  std::vector<Run> cut;
  for (std::size_t k = 0, end = 0; k < n; k = end) {
    Run run{std::uint32_t(k), 0, brute_force_box_area(lower[k], upper[k]) <= limit, lower[k], upper[k]};
    end = k + 1;
    if (run.bounded) {
      for (; end < n && end - k < brute_force_chunk; ++end) {
        const V l = glm::min(run.lower, lower[end]), h = glm::max(run.upper, upper[end]);
        if (brute_force_box_area(l, h) > limit) break;
        run.lower = l, run.upper = h;
      }
      run.lower -= margin;
      run.upper += margin;
    } else {
      while (end < n && brute_force_box_area(lower[end], upper[end]) > limit) ++end;
    }
    run.count = std::uint32_t(end - k);
    cut.push_back(run);
  }
  // Unbounded neighbours merged, unbounded runs aligned to whole lanes, then padded.
  std::vector<Run> runs;
  for (std::size_t r = 0; r < cut.size(); ++r) {
    Run run = cut[r];
    if (run.count == 0) continue;
    run.bounded = run.bounded && run.count >= 2;
    if (!run.bounded && !runs.empty() && !runs.back().bounded)
      runs.back().count += run.count;
    else
      runs.push_back(run);
    if (Run& last = runs.back(); !last.bounded && r + 1 < cut.size()) {
      const auto missing = std::uint32_t((brute_force_lanes - last.count % brute_force_lanes) % brute_force_lanes);
      const std::uint32_t take = std::min(missing, cut[r + 1].count);
      last.count += take;
      cut[r + 1].first += take;
      cut[r + 1].count -= take;
    }
  }
  BruteForceTriangles padded;
  for (Run run : runs) {
    const std::size_t first = padded.size();
    for (std::size_t k = run.first; k < std::size_t(run.first) + run.count; ++k)
      padded.push_back({tris.nx[k], tris.ny[k], tris.nz[k]}, tris.offset[k], tris.band[k], {tris.v0x[k], tris.v0y[k], tris.v0z[k]},
                       {tris.d1x[k], tris.d1y[k], tris.d1z[k]}, {tris.d2x[k], tris.d2y[k], tris.d2z[k]}, tris.id[k]);
    while ((padded.size() - first) % brute_force_lanes != 0) padded.push_back(V(0), 1, 0, V(0), V(0), V(0), ~std::uint32_t(0));
    run.first = std::uint32_t(first);
    run.count = std::uint32_t(padded.size() - first);
    padded.runs.push_back(run);
  }
  padded.expected_tests = brute_force_expected_tests(padded.runs, scene_area);
  tris = std::move(padded);
}

/// The direct-test data of the non-degenerate triangles of `data`, in primitive-id order.
template <Real T>
[[nodiscard]] BruteForceTriangles brute_force_triangles(const EmbreeSceneData<T>& data) {
  BruteForceTriangles out;
  std::vector<Vec3<double>> lower, upper;
  for (std::uint32_t id = 0; id < data.triangles.size(); ++id) {
    const EmbreeTrianglePlane& plane = data.planes[id];
    if (plane.normal == Vec3<double>(0, 0, 0)) continue;
    const auto& v = data.triangles[id].vertex;
    const Vec3<double> v0 = to_double(data.vertices[v[0]]);
    const Vec3<double> e1 = to_double(data.vertices[v[1]]) - v0, e2 = to_double(data.vertices[v[2]]) - v0;
    // dual1 is orthogonal to e2 and n with dot(e1, dual1) = 1; dual2 likewise.
    const Vec3<double> c1 = glm::cross(e2, plane.normal), c2 = glm::cross(plane.normal, e1);
    out.push_back(plane.normal, plane.offset, 0x1p-48 * plane.scale, v0, c1 / glm::dot(e1, c1), c2 / glm::dot(e2, c2), id);
    lower.push_back(glm::min(v0, glm::min(v0 + e1, v0 + e2)));
    upper.push_back(glm::max(v0, glm::max(v0 + e1, v0 + e2)));
  }
  brute_force_group_runs(out, lower, upper);
  return out;
}

/// How far outside its edges (in barycentric units) a triangle still counts as hit: far above
/// the rounding of the barycentrics in double, far below float's resolution of the vertices.
/// Two triangles in one plane (bit for bit, as the halves of an axis-aligned quad) share the
/// point p = o + t d, and their barycentrics of it carry relative rounding of ~1e-16: a ray
/// through their shared edge finds one of them. Two whose computed planes differ (a tilted or
/// bent quad) meet a ray at distances that differ by ~2^-52 (|o| + |offset|) / |cos|: a ray
/// within that of their shared edge can pass between them, a gap Embree's watertight float
/// test does not have (never observed in the tests' random rays).
inline constexpr double brute_force_edge_slack = 0x1p-40;

/// A closest hit found by direct tests: a triangle (with its barycentrics) or a sphere.
struct BruteForceHit {
  double t = 0;
  std::uint32_t index = 0;  ///< triangle id, or sphere index
  bool sphere = false;
  double b1 = 0, b2 = 0;
};

/// The exact distance in (0, t_limit) at which the query meets triangle k of `tris`, or
/// infinity: embree_accept_triangle's tests (not a surface the origin, or with FarTest the far
/// endpoint, lies on) and the triangle's own extent. Branch-free. A closest-hit query skips no
/// far surface: it leaves the far test out (FarTest false) rather than pass a band of -infinity.
template <bool FarTest>
[[nodiscard]] SEGPATH_FORCE_INLINE double brute_force_triangle_distance(const BruteForceTriangles& tris, std::size_t k,
                                                                        const EmbreeQueryContext& q, double origin_band,
                                                                        double far_band, double t_limit) noexcept {
  const double s = tris.nx[k] * q.origin.x + tris.ny[k] * q.origin.y + tris.nz[k] * q.origin.z - tris.offset[k];
  const double cosine = tris.nx[k] * q.direction.x + tris.ny[k] * q.direction.y + tris.nz[k] * q.direction.z;
  int far_clear = 1;
  if constexpr (FarTest) {
    const double far = tris.nx[k] * q.far_point.x + tris.ny[k] * q.far_point.y + tris.nz[k] * q.far_point.z - tris.offset[k];
    far_clear = int(std::abs(far) > far_band + tris.band[k]);
  }
  const double t = -s / cosine;
  const double px = q.origin.x + t * q.direction.x - tris.v0x[k];
  const double py = q.origin.y + t * q.direction.y - tris.v0y[k];
  const double pz = q.origin.z + t * q.direction.z - tris.v0z[k];
  const double b1 = px * tris.d1x[k] + py * tris.d1y[k] + pz * tris.d1z[k];
  const double b2 = px * tris.d2x[k] + py * tris.d2y[k] + pz * tris.d2z[k];
  // Bitwise, not short-circuit: every lane evaluates every test.
  const int hit = int(std::abs(s) > origin_band + tris.band[k]) & far_clear & int(t > 0) &
                  int(t < t_limit) & int(b1 >= -brute_force_edge_slack) & int(b2 >= -brute_force_edge_slack) &
                  int(b1 + b2 <= 1 + brute_force_edge_slack);
  return hit != 0 ? t : std::numeric_limits<double>::infinity();
}

/// The barycentrics of the query's point at distance t on triangle k.
[[nodiscard]] inline std::pair<double, double> brute_force_barycentrics(const BruteForceTriangles& tris, std::size_t k,
                                                                        const EmbreeQueryContext& q, double t) noexcept {
  const Vec3<double> p = q.origin + t * q.direction - Vec3<double>(tris.v0x[k], tris.v0y[k], tris.v0z[k]);
  return {glm::dot(p, Vec3<double>(tris.d1x[k], tris.d1y[k], tris.d1z[k])), glm::dot(p, Vec3<double>(tris.d2x[k], tris.d2y[k], tris.d2z[k]))};
}

/// The distances of triangles [first, first + count) (count <= brute_force_chunk, a multiple
/// of brute_force_lanes) into `out`.
template <bool FarTest>
SEGPATH_FORCE_INLINE void brute_force_chunk_distances(const BruteForceTriangles& tris, std::size_t first, std::size_t count,
                                                      const EmbreeQueryContext& q, double origin_band, double far_band,
                                                      double* out) noexcept {
  for (std::size_t l = 0; l < count; l += brute_force_lanes)
    for (std::size_t m = 0; m < brute_force_lanes; ++m)
      out[l + m] = brute_force_triangle_distance<FarTest>(tris, first + l + m, q, origin_band, far_band, q.t_max);
}

/// brute_force_intersect's body, compiled once per instruction set (brute_force_intersect).
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE std::optional<BruteForceHit> brute_force_intersect_body(const EmbreeSceneData<T>& data,
                                                                                         const BruteForceTriangles& tris,
                                                                                         const EmbreeQueryContext& q) noexcept {
  const double origin_band = embree_on_surface_tolerance<T>(q.origin, 0.0);
  double best = q.t_max;
  std::size_t best_k = tris.size();
  double t[brute_force_chunk];
  const Vec3<double> inverse = 1.0 / q.direction;
  for (const BruteForceTriangles::Run& run : tris.runs) {
    // Only a distance below best can replace it.
    if (run.bounded && !brute_force_ray_meets_box(run.lower, run.upper, q.origin, q.direction, inverse, best)) continue;
    const std::size_t run_end = std::size_t(run.first) + run.count;
    for (std::size_t first = run.first; first < run_end; first += brute_force_chunk) {
      const std::size_t count = std::min(brute_force_chunk, run_end - first);
      brute_force_chunk_distances<false>(tris, first, count, q, origin_band, 0.0, t);
      for (std::size_t l = 0; l < count; ++l) {
        best_k = t[l] < best ? first + l : best_k;
        best = t[l] < best ? t[l] : best;
      }
    }
  }
  std::optional<BruteForceHit> hit;
  if (best_k < tris.size()) {
    const auto [b1, b2] = brute_force_barycentrics(tris, best_k, q, best);
    hit = BruteForceHit{best, tris.id[best_k], false, b1, b2};
  }
  const EmbreeQueryBands bands = embree_query_bands<T>(q);
  for (std::uint32_t k = 0; k < data.spheres.size(); ++k) {
    if (!embree_sphere_nearby(data.spheres[k], q, bands)) continue;
    const std::optional<double> ts = embree_sphere_distance(data, k, q);
    if (ts && *ts < best) {
      best = *ts;
      hit = BruteForceHit{*ts, k, true, 0, 0};
    }
  }
  return hit;
}

/// brute_force_occluded's body, compiled once per instruction set (brute_force_occluded).
template <Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE bool brute_force_occluded_body(const EmbreeSceneData<T>& data, const BruteForceTriangles& tris,
                                                                 const EmbreeQueryContext& q) noexcept {
  const double origin_band = embree_on_surface_tolerance<T>(q.origin, 0.0);
  const double far_band = q.skip_far_surface ? embree_on_surface_tolerance<T>(q.far_point, 0.0)
                                             : -std::numeric_limits<double>::infinity();
  double t[brute_force_chunk];
  const Vec3<double> inverse = 1.0 / q.direction;
  for (const BruteForceTriangles::Run& run : tris.runs) {
    if (run.bounded && !brute_force_ray_meets_box(run.lower, run.upper, q.origin, q.direction, inverse, q.t_max)) continue;
    const std::size_t run_end = std::size_t(run.first) + run.count;
    for (std::size_t first = run.first; first < run_end; first += brute_force_chunk) {
      const std::size_t count = std::min(brute_force_chunk, run_end - first);
      brute_force_chunk_distances<true>(tris, first, count, q, origin_band, far_band, t);
      bool blocked = false;
      for (std::size_t l = 0; l < count; ++l) blocked |= t[l] < q.t_max;
      if (blocked) return true;
    }
  }
  const EmbreeQueryBands bands = embree_query_bands<T>(q);
  for (std::uint32_t k = 0; k < data.spheres.size(); ++k)
    if (embree_sphere_nearby(data.spheres[k], q, bands) && embree_sphere_distance(data, k, q)) return true;
  return false;
}

#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) && !defined(__AVX2__)
// Where a translation unit is compiled for less than AVX2 (no -march: SSE2's 2 double lanes),
// the query bodies are also compiled for AVX2 (4 lanes, and no multiply-add: the same
// operations, the same numbers), and each query runs that variant where the CPU has AVX2. The
// choice is per translation unit: units that include this header must agree on -mavx2 (or
// -march), or the linker may keep an AVX2 build of brute_force_intersect for all of them.
#  define SEGPATH_BRUTE_FORCE_DISPATCH 1
/// 1 where the CPU has AVX2, else 0. Tests lower it to run both variants; nothing else writes it.
/// (Zero-initialised before its initialiser runs: a query from another static initialiser
/// runs the build's own variant.)
inline int brute_force_isa = [] {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") ? 1 : 0;
}();
template <Real T>
[[gnu::target("avx2"), gnu::noinline]] std::optional<BruteForceHit> brute_force_intersect_avx2(
    const EmbreeSceneData<T>& data, const BruteForceTriangles& tris, const EmbreeQueryContext& q) noexcept {
  return brute_force_intersect_body(data, tris, q);
}
template <Real T>
[[gnu::target("avx2"), gnu::noinline]] bool brute_force_occluded_avx2(const EmbreeSceneData<T>& data,
                                                                      const BruteForceTriangles& tris,
                                                                      const EmbreeQueryContext& q) noexcept {
  return brute_force_occluded_body(data, tris, q);
}
#endif

/// The most tests a query may be expected to make (brute_force_expected_tests, the spheres
/// added) for EmbreeManifold's automatic traversal to trace a scene by direct tests: about where
/// a closest hit plus a visibility query cost the same as through Embree's traversal
/// (bench/renderer/embree_traversal_bench.cpp, docs/figures.md), 40 with AVX2's 4 double lanes,
/// 24 with 2.
[[nodiscard]] inline std::uint32_t brute_force_automatic_limit() noexcept {
#if defined(__AVX2__)
  return 40;
#elif defined(SEGPATH_BRUTE_FORCE_DISPATCH)
  return brute_force_isa == 1 ? 40 : 24;
#else
  return 24;
#endif
}

/// The closest hit of the query among all primitives, by direct tests.
template <Real T>
[[nodiscard]] std::optional<BruteForceHit> brute_force_intersect(const EmbreeSceneData<T>& data, const BruteForceTriangles& tris,
                                                                 const EmbreeQueryContext& q) noexcept {
#ifdef SEGPATH_BRUTE_FORCE_DISPATCH
  if (brute_force_isa == 1) return brute_force_intersect_avx2(data, tris, q);
#endif
  return brute_force_intersect_body(data, tris, q);
}

/// Whether any primitive blocks the query (its open segment, or its ray when t_max is infinite).
template <Real T>
[[nodiscard]] bool brute_force_occluded(const EmbreeSceneData<T>& data, const BruteForceTriangles& tris,
                                        const EmbreeQueryContext& q) noexcept {
#ifdef SEGPATH_BRUTE_FORCE_DISPATCH
  if (brute_force_isa == 1) return brute_force_occluded_avx2(data, tris, q);
#endif
  return brute_force_occluded_body(data, tris, q);
}

}  // namespace segpath::detail
