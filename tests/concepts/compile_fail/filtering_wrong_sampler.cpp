// Compile-fail test: a user's technique whose `sample` returns a bare SegmentSample (not
// std::optional) given to SegmentFiltering. The class's own constraints must reject it and name
// the failed requirement, detail::HasSegmentSample. Built with SEGPATH_COMPILE_FAIL_CONTROL
// defined, `sample` returns std::optional and the file must compile.
#include <segpath/algorithms/segment_filtering.hpp>
#include <segpath/testing/sphere_interior.hpp>

#include <optional>

using Scene = segpath::testing::PhotographedSphereInterior<float>;

struct NothingSampler {
  struct Technique {};
  static constexpr bool is_dirac = false;
#ifdef SEGPATH_COMPILE_FAIL_CONTROL
  template <class R>
  std::optional<segpath::SegmentSample<float>> sample(const Scene&, const Technique&, R&) const noexcept {
    return std::nullopt;
  }
#else
  template <class R>
  segpath::SegmentSample<float> sample(const Scene&, const Technique&, R&) const noexcept {
    return {};
  }
#endif
  float pdf(const Scene&, const Technique&, const segpath::Segment<float>&) const noexcept { return 0; }
  float unoccluded_pdf(const Scene&, const Technique&, const segpath::Segment<float>&) const noexcept { return 0; }
};

int main() {
  const segpath::SegmentFiltering<Scene, NothingSampler> filtering(segpath::FilteringOptions<float>{},
                                                                   segpath::FilteringTechnique<NothingSampler>{});
  (void)filtering;
  return 0;
}
