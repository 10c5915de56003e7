// The voxel kernel (kernels/voxel.hpp): voxel keys and the clipped-plane area 1 / K.
#include <segpath/core/rng.hpp>
#include <segpath/kernels/voxel.hpp>

#include <cmath>

#include "support/catch.hpp"

using namespace segpath;

TEMPLATE_TEST_CASE("plane clipped to a box: known areas", "[kernels]", float, double) {
  using T = TestType;
  const Vec3<T> lo(0), hi(1);
  const double eps = std::is_same_v<T, float> ? 1e-5 : 1e-12;
  // Axis-aligned plane: the full face.
  CHECK(plane_box_area<T>({T(0.3), T(0.4), T(0.25)}, {0, 0, 1}, lo, hi) == Approx(1.0).epsilon(eps));
  // x + y = 1: a sqrt(2) x 1 rectangle.
  CHECK(plane_box_area<T>({T(0.5), T(0.5), 0}, {1, 1, 0}, lo, hi) == Approx(std::sqrt(2.0)).epsilon(eps));
  // x + y + z = 1.5 through the centre: a regular hexagon of side sqrt(1/2), area (3 sqrt(3) / 2) side^2.
  CHECK(plane_box_area<T>({T(0.5), T(0.5), T(0.5)}, {1, 1, 1}, lo, hi) == Approx(3.0 * std::sqrt(3.0) / 4.0).epsilon(eps));
  // x + y + z = 0.5: a triangle with legs 0.5, area sqrt(3)/2 * 0.5^2.
  CHECK(plane_box_area<T>({T(0.5), 0, 0}, {1, 1, 1}, lo, hi) == Approx(std::sqrt(3.0) / 8.0).epsilon(eps));
  // Missing the box, degenerate normal.
  CHECK(plane_box_area<T>({0, 0, 2}, {0, 0, 1}, lo, hi) == T(0));
  CHECK(plane_box_area<T>({T(0.5), T(0.5), T(0.5)}, {0, 0, 0}, lo, hi) == T(0));
}

TEST_CASE("plane clipped to a box agrees with a slab-volume estimate for random planes", "[kernels]") {
  // Area = lim volume of {|n.(x - p)| < e} / (2 e); on a 160^3 grid of cell centres with e of a
  // few cells this is accurate to about 1 %.
  Pcg32 rng(5, 5);
  const int n = 160;
  for (int trial = 0; trial < 6; ++trial) {
    const glm::dvec3 normal = glm::normalize(glm::dvec3(rng.uniform<double>() - 0.5, rng.uniform<double>() - 0.5,
                                                        rng.uniform<double>() - 0.5));
    const glm::dvec3 p(0.3 + 0.4 * rng.uniform<double>(), 0.3 + 0.4 * rng.uniform<double>(), 0.3 + 0.4 * rng.uniform<double>());
    const double e = 4.0 / n;
    std::uint64_t inside = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) {
          const glm::dvec3 x((i + 0.5) / n, (j + 0.5) / n, (k + 0.5) / n);
          if (std::abs(glm::dot(normal, x - p)) < e) ++inside;
        }
    const double slab_estimate = double(inside) / (double(n) * n * n) / (2 * e);
    CHECK(plane_box_area(p, normal, glm::dvec3(0), glm::dvec3(1)) == Approx(slab_estimate).epsilon(0.03));
  }
}

TEMPLATE_TEST_CASE("voxel grid keys and validation", "[kernels]", float, double) {
  using T = TestType;
  CHECK_THROWS_AS(VoxelGrid<T>(T(0)), std::invalid_argument);
  CHECK_THROWS_AS(VoxelGrid<T>(T(-1)), std::invalid_argument);
  CHECK_THROWS_AS(VoxelGrid<T>(std::numeric_limits<T>::infinity()), std::invalid_argument);
  CHECK_THROWS_AS(VoxelGrid<T>(T(1), Vec3<T>(T(1), 0, 0)), std::invalid_argument);
  const VoxelGrid<T> grid(T(0.5), Vec3<T>(T(0.5), 0, 0));  // shifted by 0.25 in x
  const auto a = grid.key(SurfacePoint<T>::on_surface({T(0.3), T(0.1), T(0.1)}, {0, 0, 1}));
  const auto b = grid.key(SurfacePoint<T>::on_surface({T(0.7), T(0.4), T(0.4)}, {0, 0, 1}));
  const auto c = grid.key(SurfacePoint<T>::on_surface({T(0.7), T(0.4), T(0.4)}, {0, 0, -1}));
  const auto d = grid.key(SurfacePoint<T>::on_surface({T(0.8), T(0.4), T(0.4)}, {0, 0, 1}));
  REQUIRE(a.valid);
  CHECK(a.key == b.key);          // same cell [0.25, 0.75) x [0, 0.5) x [0, 0.5), same normal
  CHECK_FALSE(b.key == c.key);    // opposite normals never share a cluster
  CHECK_FALSE(b.key == d.key);    // next cell
  CHECK_FALSE(grid.key(SurfacePoint<T>::at_point({0, 0, 0})).valid);
  CHECK_FALSE(grid.key(SurfacePoint<T>::on_surface({std::numeric_limits<T>::quiet_NaN(), 0, 0}, {0, 0, 1})).valid);
  // The same iteration always gets the same jitter.
  CHECK(VoxelGrid<T>::jittered(T(1), 3, 7).offset() == VoxelGrid<T>::jittered(T(1), 3, 7).offset());
  CHECK_FALSE(VoxelGrid<T>::jittered(T(1), 3, 7).offset() == VoxelGrid<T>::jittered(T(1), 3, 8).offset());
}

