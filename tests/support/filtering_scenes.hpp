// Two small scenes that exercise every kind of pooled segment of SegmentFiltering, with the
// options the stage tests (tests/algorithms/slot_order_test.cpp, pool_release_test.cpp) run
// them at.
#pragma once

#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/testing/sphere_interior.hpp>
#include <segpath/testing/submerged_plane.hpp>

namespace segpath::testing {

/// Glass and a point light: chains through the interface, kept densities, delta light ends.
inline PointLitSubmergedPlane<double> point_lit_glass() {
  const SubmergedPlaneParameters<double> submerged{2, 0.5, 1, 1.5, 1, 0.5};
  return PointLitSubmergedPlane<double>(submerged,
                                        {{Vec2<double>(0, 0), 0}, {Vec2<double>(0.6, 0), 0.5}, {Vec2<double>(-0.3, 0.5), -0.4}});
}

/// point_lit_glass's options: paths of 4 segments, 300 light paths per camera path (the glass
/// gets its chains), voxels of 0.3, seed 7.
inline FilteringOptions<double> point_lit_glass_options(FilteringMode mode) {
  FilteringOptions<double> o;
  o.mode = mode;
  o.max_length = 4;
  o.light_path_ratio = 300;
  o.initial_cell_size = 0.3;
  o.seed = 7;
  return o;
}

/// A closed diffuse furnace seen through a pinhole of 12 x 12 pixels: camera paths from every
/// pixel, factorised clusters everywhere; run at point_lit_glass's options but paths of 5
/// segments and one light path per camera path (sphere_furnace_options).
inline PhotographedSphereInterior<double> sphere_furnace() { return PhotographedSphereInterior<double>(12); }

inline FilteringOptions<double> sphere_furnace_options(FilteringMode mode) {
  FilteringOptions<double> o = point_lit_glass_options(mode);
  o.max_length = 5;
  o.light_path_ratio = 1;
  return o;
}

}  // namespace segpath::testing
