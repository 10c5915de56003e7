// Compile-fail test: a type without `intersect` used where a Manifold is required. The
// compiler must reject it and name the failed requirement, detail::HasIntersect. Built with
// SEGPATH_COMPILE_FAIL_CONTROL defined, the type is complete and the file must compile
// (so the failure comes from the missing member, not from a broken include).
#include <optional>
#include <segpath/concepts/manifold.hpp>

namespace {

struct Geometry {
  using Scalar = float;
  float area() const noexcept { return 1.0f; }
  std::optional<segpath::AreaSample<float>> sample_area(
      const segpath::AreaSampleQuery<float>&) const noexcept {
    return std::nullopt;
  }
#ifdef SEGPATH_COMPILE_FAIL_CONTROL
  std::optional<segpath::Hit<float>> intersect(
      const segpath::IntersectQuery<float>&) const noexcept {
    return std::nullopt;
  }
#endif
  bool visible(const segpath::VisibilityQuery<float>&) const noexcept { return true; }
};

template <segpath::Manifold M>
typename M::Scalar total_area(const M& manifold) noexcept {
  return manifold.area();
}

}  // namespace

int main() { return total_area(Geometry{}) > 0.0f ? 0 : 1; }
