// Test kit for SegmentFiltering: recomputes every pooled segment's MMIS denominator D(s) (N39)
// by enumerating all pooled segments as candidate technique samples, written out from the
// techniques' definitions rather than from the clusters the algorithm iterates over.
#pragma once

#include <segpath/algorithms/segment_filtering.hpp>

#include <cstdint>
#include <map>
#include <type_traits>
#include <utility>
#include <vector>

#include "support/catch.hpp"

namespace segpath::testing {

/// The voxel kernel recomputed from its definition (SPEC 1.2), not read from the clustering:
/// two ends join when their (canonical) positions and normals share a key of `grid`, with
/// K = 1 / (area of the plane through the mean position and mean normal of every pooled end
/// with that key, clipped to the voxel). Call it as kernel(end, start) for check_denominators.
template <class Pool, class Grid, class Canonical>
auto voxel_kernel_oracle(const Pool& pool, const Grid& grid, const Canonical& canonical) {
  struct Sums {
    glm::dvec3 position{0}, normal{0};
    double count = 0;
  };
  using Point = std::remove_cvref_t<decltype(pool.segments[0].x)>;
  auto key_of = [grid, canonical](const Point& p) {  // copies: the oracle outlives its arguments
    Point q = p;
    q.position = canonical(p);
    return grid.key(q);
  };
  std::map<VoxelKey, Sums> voxels;
  for (std::size_t i = 0; i < pool.size(); ++i)
    for (const Point* p : {&pool.segments[i].x, &pool.segments[i].y}) {
      const auto k = key_of(*p);
      if (!k.valid) continue;
      Sums& v = voxels[k.key];
      v.position += glm::dvec3(canonical(*p));
      v.normal += glm::dvec3(p->normal);
      v.count += 1;
    }
  std::map<VoxelKey, double> kernel;
  for (const auto& [key, v] : voxels) {
    const auto box = grid.bounds(key);
    const double area = plane_box_area(glm::dvec3(v.position / v.count), v.normal, glm::dvec3(box[0]), glm::dvec3(box[1]));
    kernel[key] = area > 0 ? 1 / area : 0.0;
  }
  return [&pool, key_of, kernel = std::move(kernel)](std::uint32_t end, std::uint32_t start) {
    const auto a = key_of(pool.segments[end].y), b = key_of(pool.segments[start].x);
    if (!a.valid || !b.valid || !(a.key == b.key)) return 0.0;
    return kernel.at(a.key);
  };
}

/// Whether pooled segment s is a kept chain (only the light start draws it: a light start's own
/// chain to a light end off the surfaces, a point light, the sun or PhF's sky; the draw's
/// density is kept), judged from how it was drawn and where it ends, not from the pool's kept
/// flag; and whether it is a straight segment to a Dirac light (the light sampler's word).
template <class Pool>
std::pair<bool, bool> kept_or_dirac(const Pool& pool, std::uint32_t s) {
  const auto f = pool.flags[s];
  const bool chain = (f & filtering::chain_segment) != 0;
  const bool kept = chain && (f & filtering::light_start) && pool.segments[s].y.kind != PointKind::surface;
  const bool dirac_end = !chain && (f & filtering::delta_light);
  return {kept, dirac_end};
}

/// N_L of pass `pass` of an iteration (FilteringOptions::pixel_passes), dealt out here: the
/// iteration's light paths per pixel (none for MVF) x #pixels, rounded, dealt one by one to the
/// passes in turn.
template <class Filter, class Scn>
double light_paths_of_pass(const Filter& filter, const Scn& scene, std::uint32_t pass) {
  const std::uint32_t passes = filter.options().pixel_passes;
  const auto total = std::llround(filtering::technique_set(filter.options()).light_paths_per_pixel *
                                  double(scene.sensor().pixel_count()));
  std::uint64_t dealt = 0;
  for (long long i = 0; i < total; ++i) dealt += i % passes == pass ? 1 : 0;
  return double(dealt);
}

/// `kernel(end, start)` is the kernel value joining the end y_t of one pooled segment to the
/// start x_s of another (0 outside the support); a segment is never its own technique sample.
/// Checks D(s) for every segment within 1e-12 relative (double; float scenes: 1e-4, the sums run
/// in another order) and returns {segments checked, segments with more than one technique sample}.
/// `extra(s)` is sum_u N_u p_u(s) of the user's techniques (FilteringTechnique), written out
/// by the caller; none by default. `pass`: the pool is that pass of FilteringOptions::pixel_passes.
template <class Filter, class Scn, class Kernel, class Extra = double (*)(std::uint32_t)>
std::pair<std::size_t, std::size_t> check_denominators(const Filter& filter, const Scn& scene, const typename Filter::Pool& pool,
                                                       const Kernel& kernel,
                                                       const Extra& extra = [](std::uint32_t) { return 0.0; },
                                                       std::uint32_t pass = 0) {
  using T = typename Scn::Scalar;
  const double tolerance = std::is_same_v<T, double> ? 1e-12 : 1e-4;
  const auto& bsdf = scene.bsdf();
  const double n_light = light_paths_of_pass(filter, scene, pass);
  const bool next_event = filtering::technique_set(filter.options()).next_event;
  std::vector<std::uint32_t> targets;
  for (std::uint32_t u = 0; u < pool.size(); ++u)  // the light technique samples
    if ((pool.flags[u] & filtering::light_technique) && !(pool.flags[u] & filtering::camera_born) &&
        pool.segments[u].x.kind == PointKind::surface)
      targets.push_back(u);
  CHECK(pool.bridge_targets == (filtering::technique_set(filter.options()).bridges ? targets.size() : 0));
  std::size_t checked = 0, with_techniques = 0;
  for (std::uint32_t s = 0; s < pool.size(); ++s) {
    const auto& seg = pool.segments[s];
    const auto f = pool.flags[s];
    const bool chain = (f & filtering::chain_segment) != 0;
    const bool on_surface = seg.x.kind == PointKind::surface;
    const auto [kept, dirac_end] = kept_or_dirac(pool, s);
    const bool plain = !chain && !dirac_end && on_surface;
    // What a light technique can draw: any segment from a surface point, through delta
    // reflections and transmissions (a chain), to a non-Dirac end.
    const bool light_drawable = !kept && !dirac_end && on_surface;
    // Area x solid angle at y to the segment's measure: area at x, or for a chain area x solid
    // angle at x (etendue: cos_y dA_y dw_y = cos_x dA_x dw_x).
    const double to_segment_measure =
        chain ? double(std::abs(glm::dot(seg.x.normal, pool.first_direction[s]))) / double(std::abs(glm::dot(seg.y.normal, pool.last_direction[s])))
        : seg.y.kind == PointKind::direction ? double(std::abs(glm::dot(seg.x.normal, pool.last_direction[s])))  // no 1 / d^2 at infinity
                                             : double(solid_angle_to_area(T(1), seg.y, seg.x));
    double d = 0, camera_points = 0;
    int techniques = 0;
    for (std::uint32_t t = 0; t < pool.size(); ++t) {
      if (t == s) continue;  // a segment is not its own technique sample
      // A camera technique sample: a continued segment whose end's support holds x_s.
      if (pool.flags[t] & filtering::camera_technique) {
        const double k = kernel(t, s);
        camera_points += k;
        if (k > 0 && !kept && !dirac_end) {
          const double measure = chain ? 1.0 : double(solid_angle_to_area(T(1), seg.x, seg.y));
          // The camera roulette's coin is part of the draw (FilteringOptions::camera_continuation;
          // automatic: 0.7 for BDPF, 1 for MVF); past max_length the tail's (c_c below 1, else 1/2).
          const double c_o = filter.options().camera_continuation >= 0 ? double(filter.options().camera_continuation)
                             : filter.options().mode == FilteringMode::bdpf ? 0.7
                                                                               : 1.0;
          const double c_c = (pool.flags[t] & filtering::camera_tail) ? (c_o < 1 ? c_o : 0.5) : c_o;
          d += c_c * k * measure *
               double(bsdf.pdf(BsdfQuery<T>{pool.segments[t].y, -pool.last_direction[t], pool.first_direction[s], Transport::radiance}));
          ++techniques;
        }
      }
      // A light technique sample: a continued light segment whose start lies in y_s's support.
      if ((pool.flags[t] & filtering::light_technique) && light_drawable) {
        const double k = kernel(s, t);
        if (k > 0) {
          d += filtering::technique_set(filter.options()).light_continuation * k * to_segment_measure *
               double(bsdf.pdf(BsdfQuery<T>{pool.segments[t].x, -pool.last_direction[s], pool.first_direction[t], Transport::importance}));
          ++techniques;
        }
      }
    }
    // A bridge: any camera technique point to any of the M targets, uniform kernel draws at both ends.
    if (filtering::technique_set(filter.options()).bridges && plain && seg.y.kind == PointKind::surface && !targets.empty()) {
      double bridge_light = 0;
      for (const std::uint32_t u : targets) bridge_light += u != s ? kernel(s, u) : 0.0;
      d += camera_points * bridge_light / double(targets.size());
      techniques += camera_points * bridge_light > 0;
    }
    // A next-event segment: from any camera technique point, the light end by light sampling.
    if (next_event && on_surface && !chain && camera_points > 0) {
      const double p = double(scene.emitter().pdf_towards(EmitterPdfTowardsQuery<T>{seg.x, seg.y}));
      d += camera_points * p;
      techniques += p > 0;
    }
    if (f & filtering::sensor_segment) {
      const auto p = scene.sensor().pdf(SensorQuery<T>{seg.x, pool.first_direction[s]});
      d += double(p.position) * double(p.direction) * (chain ? 1.0 : double(solid_angle_to_area(T(1), seg.x, seg.y)));
    }
    // A light start: plain segments and light-born chains (from area lights only).
    if (on_surface && (!chain || (light_drawable && seg.y.kind == PointKind::surface))) {
      // The direction it leaves in; a distant end's emitter reads a point of the ray instead.
      const Vec3<T> leaving = seg.y.kind == PointKind::direction ? seg.x.position : -pool.last_direction[s];
      const auto e = scene.emitter().pdf_emission(EmissionPdfQuery<T>{seg.y, leaving});
      d += n_light * double(e.position) * double(e.direction) * to_segment_measure;
    }
    // The user's techniques: straight segments only.
    if (!chain && !dirac_end) {
      const double p = extra(s);
      d += p;
      techniques += p > 0;
    }
    // A Dirac light's chain (point light or sun through delta bounces): only the light start
    // draws it, with a density a local computation cannot give (a curved mirror's Jacobian), so
    // every other technique must give it 0 and the draw's N_L p is kept.
    CHECK(filtering::kept_chain(pool, s) == kept);
    if (kept) {
      CHECK(d == 0.0);
      CHECK(pool.density[s] > 0);
      ++checked;
      continue;
    }
    CHECK(double(pool.density[s]) == Approx(d).epsilon(tolerance).margin(1e-300));
    ++checked;
    if (techniques > 1) ++with_techniques;
  }
  return {checked, with_techniques};
}

/// The light side of every denominator for the path-conditioned weighting (SegmentFiltering::
/// LightSide), recomputed by enumeration: D_l(s) = light start + every light technique sample
/// whose start lies in y_s's support (its draw includes the roulette's c), its number of
/// positive terms, and D_lt(s), which equals D_l(s): light paths have no depth limit, so every
/// light-born segment's draw would itself try a predecessor. Same tolerances and `pass` as above.
template <class Filter, class Scn, class Side, class Kernel>
void check_light_side(const Filter& filter, const Scn& scene, const typename Filter::Pool& pool, const Side& side,
                      const Kernel& kernel, std::uint32_t pass = 0) {
  using T = typename Scn::Scalar;
  const double tolerance = std::is_same_v<T, double> ? 1e-12 : 1e-4;
  const auto& bsdf = scene.bsdf();
  const double n_light = light_paths_of_pass(filter, scene, pass);
  const double continuation = filtering::technique_set(filter.options()).light_continuation;
  for (std::uint32_t s = 0; s < pool.size(); ++s) {
    const auto& seg = pool.segments[s];
    const auto f = pool.flags[s];
    const bool chain = (f & filtering::chain_segment) != 0;
    const bool on_surface = seg.x.kind == PointKind::surface;
    const auto [kept, dirac_end] = kept_or_dirac(pool, s);
    const bool light_drawable = !kept && !dirac_end && on_surface;
    const double to_segment_measure =
        chain ? double(std::abs(glm::dot(seg.x.normal, pool.first_direction[s]))) / double(std::abs(glm::dot(seg.y.normal, pool.last_direction[s])))
        : seg.y.kind == PointKind::direction ? double(std::abs(glm::dot(seg.x.normal, pool.last_direction[s])))  // no 1 / d^2 at infinity
                                             : double(solid_angle_to_area(T(1), seg.y, seg.x));
    double dl = 0;
    std::uint32_t terms = 0;
    if (on_surface && (!chain || (light_drawable && seg.y.kind == PointKind::surface))) {
      // The direction it leaves in; a distant end's emitter reads a point of the ray instead.
      const Vec3<T> leaving = seg.y.kind == PointKind::direction ? seg.x.position : -pool.last_direction[s];
      const auto e = scene.emitter().pdf_emission(EmissionPdfQuery<T>{seg.y, leaving});
      const double start = n_light * double(e.position) * double(e.direction) * to_segment_measure;
      if (start > 0) {
        dl += start;
        ++terms;
      }
    }
    if (kept) dl += double(pool.density[s]), ++terms;  // the light start's, kept
    if (light_drawable)
      for (std::uint32_t u = 0; u < pool.size(); ++u) {
        if (!(pool.flags[u] & filtering::light_technique) || u == s) continue;
        const double q = continuation * kernel(s, u) * to_segment_measure *
                         double(bsdf.pdf(BsdfQuery<T>{pool.segments[u].x, -pool.last_direction[s], pool.first_direction[u], Transport::importance}));
        if (!(q > 0)) continue;
        dl += q;
        ++terms;
      }
    CHECK(double(side.density[s]) == Approx(dl).epsilon(tolerance).margin(1e-300));
    CHECK(side.terms[s] == terms);
  }
}

}  // namespace segpath::testing
