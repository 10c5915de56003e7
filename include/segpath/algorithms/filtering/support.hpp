// Stage 3 of a filtering iteration: the junction support of the pool (SPEC 1.2), voxel clusters
// (the paper's) or disks of the same area, and the kernel schedule that shrinks it per iteration
// (the PPM schedule of kernels/progressive_radius.hpp).
#pragma once

#include "segpath/algorithms/filtering/context.hpp"
#include "segpath/kernels/progressive_radius.hpp"
#include "segpath/propagation/clustering.hpp"
#include "segpath/propagation/disk_junctions.hpp"
#include "segpath/kernels/voxel.hpp"
#include "segpath/sensors/pixel_footprint.hpp"

#include <cmath>
#include <cstdint>
#include <span>
#include <stdexcept>

namespace segpath::filtering {

/// Where an end is keyed or measured: the scene's canonical position, or the position itself.
template <LightSampledScene Scn>
[[nodiscard]] auto canonical_map(const Scn& scene) noexcept {
  using T = typename Scn::Scalar;
  return [&scene](const SurfacePoint<T>& p) -> Vec3<T> {
    if constexpr (HasCanonicalPosition<Scn>) {
      return scene.canonical_position(p);
    } else {
      (void)scene;
      return p.position;
    }
  };
}

/// The voxel grid the context's paths keyed their first visits on (Context::visit_grid): the
/// clustering must use it, or a voxel could hold two technique samples of one path.
template <LightSampledScene Scn>
[[nodiscard]] const VoxelGrid<typename Scn::Scalar>& support_grid(const Context<Scn>& ctx) {
  if (!ctx.visit_grid)
    throw std::invalid_argument("segpath::filtering: the context has no voxel grid (make it with SegmentFiltering::context "
                                "on the voxel support)");
  return *ctx.visit_grid;
}

/// The disk radius the context's paths kept their technique samples apart by
/// (Context::visit_radius): the junctions must use it.
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar support_radius(const Context<Scn>& ctx) {
  if (!(ctx.visit_radius > 0))
    throw std::invalid_argument("segpath::filtering: the context has no disk radius (make it with SegmentFiltering::context "
                                "on the disk support)");
  return ctx.visit_radius;
}

/// Clusters a pool's endpoints on the context's grid (by canonical position where the scene
/// has one).
template <LightSampledScene Scn, ParallelFor P>
void cluster(const Context<Scn>& ctx, Clustering<typename Scn::Scalar>& clustering, const P& parallel_for) {
  clustering.build(support_grid(ctx), ctx.pool.segments, canonical_map(ctx.scene), parallel_for);
}

/// The disk support's junctions of a pool at the context's radius (by canonical position where
/// the scene has one).
template <LightSampledScene Scn, ParallelFor P>
void join(const Context<Scn>& ctx, DiskJunctions<typename Scn::Scalar>& junctions, const P& parallel_for) {
  using T = typename Scn::Scalar;
  junctions.build(support_radius(ctx), std::span<const Segment<T>>(ctx.pool.segments), canonical_map(ctx.scene), T(0.5),
                  parallel_for);
}

/// The voxel size of iteration 1 when the options leave it at 0, in average pixel footprints
/// (sensors/pixel_footprint.hpp): the paper's 4.
inline constexpr double cell_in_footprints = 4.0;

/// The voxel size of iteration 1 when the options leave it at 0.
template <LightSampledScene Scn>
[[nodiscard]] typename Scn::Scalar pixel_footprint_cell(const Scn& scene) {
  using T = typename Scn::Scalar;
  return T(cell_in_footprints) * pixel_footprint(scene, T(2.5e-3));
}

/// The voxel grid of an iteration: jittered from the iteration's own stream, or aligned.
template <Real T>
[[nodiscard]] VoxelGrid<T> grid(const FilteringOptions<T>& options, T cell, std::uint64_t stream) {
  return options.jitter ? VoxelGrid<T>::jittered(cell, options.seed, stream) : VoxelGrid<T>(cell);
}

/// The disk radius with the area of a voxel face: pi r^2 = h^2.
template <Real T>
[[nodiscard]] T disk_radius(T cell) noexcept {
  return cell / std::sqrt(pi<T>);
}

}  // namespace segpath::filtering
