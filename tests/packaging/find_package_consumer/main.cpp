// Uses an installed segpath: checks a kernel models the Kernel concept and evaluates the
// geometry term and a disk kernel on a configuration with a known answer.
#include <segpath/segpath.hpp>  // the umbrella: every installed header but adapters/ and testing/
#include <segpath/concepts/concepts.hpp>
#include <segpath/core/geometry.hpp>
#include <segpath/kernels/disk.hpp>

#include <cmath>
#include <cstdio>

static_assert(segpath::Kernel<segpath::DiskKernel<double>>);
static_assert(segpath::Kernel<segpath::DiskKernel<float>>);

int main() {
  using segpath::SurfacePoint;
  using segpath::Vec3;
  // Two surface points 2 apart facing each other: G = 1 * 1 / 2^2 (N17).
  const segpath::Segment<double> s{
      SurfacePoint<double>::on_surface(Vec3<double>(0, 0, 0), Vec3<double>(0, 0, 1)),
      SurfacePoint<double>::on_surface(Vec3<double>(0, 0, 2), Vec3<double>(0, 0, -1))};
  const double g = segpath::geometry_term(s);

  // The next segment starts 0.05 from s.y on the same surface: inside a disk of radius 0.1,
  // where the kernel is 1 / (pi r^2) (N19).
  const segpath::DiskKernel<double> kernel(0.1);
  const segpath::Segment<double> next{
      SurfacePoint<double>::on_surface(Vec3<double>(0.05, 0, 2), Vec3<double>(0, 0, -1)),
      SurfacePoint<double>::on_surface(Vec3<double>(0, 1, 3), Vec3<double>(0, -1, 0))};
  const double k = kernel.eval({s, next});
  const double expected_k = 1.0 / (std::acos(-1.0) * 0.01);

  if (std::abs(g - 0.25) > 1e-12 || std::abs(k - expected_k) > 1e-9 * expected_k) {
    std::printf("FAIL: geometry_term = %.17g (want 0.25), kernel = %.17g (want %.17g)\n", g, k,
                expected_k);
    return 1;
  }
  std::printf("segpath %d.%d.%d via find_package: G = %g, K = %g\n", SEGPATH_VERSION_MAJOR,
              SEGPATH_VERSION_MINOR, SEGPATH_VERSION_PATCH, g, k);
  return 0;
}
