// Uses segpath added with add_subdirectory: a Dirac junction point and the geometry term of
// a segment towards a point light, whose end carries no cosine (SPEC 1.1).
#include <segpath/concepts/concepts.hpp>
#include <segpath/core/geometry.hpp>
#include <segpath/kernels/disk.hpp>

#include <cmath>
#include <cstdio>

static_assert(segpath::Kernel<segpath::DiskKernel<double>>);

int main() {
  using segpath::SurfacePoint;
  using segpath::Vec3;
  // Surface point facing a point light 3 away at 60 degrees: G = cos 60 / 3^2 (N17).
  const double c = 0.5, s = std::sqrt(0.75);
  const segpath::Segment<double> seg{
      SurfacePoint<double>::on_surface(Vec3<double>(0, 0, 0), Vec3<double>(0, 0, 1)),
      SurfacePoint<double>::at_point(Vec3<double>(3 * s, 0, 3 * c))};
  const double g = segpath::geometry_term(seg);
  const double expected = c / 9.0;

  // Outside the disk of radius 0.1 the kernel is 0.
  const segpath::DiskKernel<double> kernel(0.1);
  const segpath::Segment<double> far_away{
      SurfacePoint<double>::on_surface(Vec3<double>(1, 0, 0), Vec3<double>(0, 0, 1)),
      SurfacePoint<double>::on_surface(Vec3<double>(1, 0, 1), Vec3<double>(0, 0, -1))};
  const segpath::Segment<double> from{
      SurfacePoint<double>::on_surface(Vec3<double>(0, 0, 1), Vec3<double>(0, 0, -1)),
      SurfacePoint<double>::on_surface(Vec3<double>(0, 0, 0), Vec3<double>(0, 0, 1))};
  const double k = kernel.eval({from, far_away});

  if (std::abs(g - expected) > 1e-12 * expected || k != 0.0) {
    std::printf("FAIL: geometry_term = %.17g (want %.17g), kernel = %.17g (want 0)\n", g,
                expected, k);
    return 1;
  }
  std::printf("segpath via add_subdirectory: G = %g\n", g);
  return 0;
}
