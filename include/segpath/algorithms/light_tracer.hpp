// Light tracing (SPEC 1.9): light-start segments (N30), Dirac-kernel light-side successors
// (the mirror of N31), and at every surface end a sensor bridge (N34) to the camera. Each
// call traces one light path and splats to whichever pixels it reaches; J_p is the sum of
// its contributions to p, so an image is the sum over N paths divided by N.
#pragma once

#include "segpath/concepts/estimator.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/core/roulette.hpp"
#include "segpath/kernels/dirac.hpp"
#include "segpath/samplers/bridge.hpp"
#include "segpath/samplers/light_next.hpp"
#include "segpath/samplers/light_start.hpp"

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace segpath {

struct LightTracerOptions {
  std::size_t max_length = 10;  ///< segments per path, the sensor segment included (>= 2)
  std::size_t roulette_from = 0;  ///< Russian roulette (core/roulette.hpp) from this many light segments on (0: never)
  /// render_iteration: light path k of iteration i draws from Pcg32::for_sample(seed ^ salt, k, i),
  /// streams disjoint from PathTracer's for the same seed
  std::uint64_t seed = 0;
};

/// Light tracing on any LightSampledScene. The splat lists are scratch kept in the object and
/// reused across iterations: one render_iteration at a time per object.
template <LightSampledScene Scn>
class LightTracer {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;

  explicit LightTracer(LightTracerOptions options = {}) : options_(options) {
    if (options.max_length < 2)
      throw std::invalid_argument("segpath::LightTracer: max_length must be >= 2, got " +
                                  std::to_string(options.max_length));
  }
  [[nodiscard]] const LightTracerOptions& options() const noexcept { return options_; }

  /// Work chunks of render_iteration (fixed: never the thread count).
  static constexpr std::size_t chunk_count = 64;
  static constexpr std::uint64_t stream_salt = 0x4c54'0000'0000'0000ULL;

  /// Adds one iteration's estimate to `image` (sensor-sized): N = #pixels light paths, whose
  /// splats are summed and divided by N (N16). The paths are split into chunk_count chunks whose
  /// splats are applied in chunk order (SplatRecorder), so the image is the same whatever
  /// `parallel_for` does; non-finite splats are counted in `drops`.
  template <ParallelFor P = SerialFor>
  void render_iteration(const Scn& scene, std::uint64_t iteration, Framebuffer<S>& image, DropCounters& drops,
                        const P& parallel_for = {}) const {
    const std::uint64_t n = scene.sensor().pixel_count();
    if (image.pixel_count() != n)
      throw std::invalid_argument("segpath::LightTracer: the image has " + std::to_string(image.pixel_count()) +
                                  " pixels, the sensor " + std::to_string(n));
    splats_.clear();  // what an iteration that threw left
    parallel_for(chunk_count, [&](std::size_t chunk) {
      auto sink = splats_.sink(chunk);
      for (std::uint64_t k = n * chunk / chunk_count, end = n * (chunk + 1) / chunk_count; k < end; ++k) {
        Pcg32 rng = Pcg32::for_sample(options_.seed ^ stream_salt, k, iteration);
        estimate(scene, EstimateQuery{0, iteration * n + k}, rng, sink);
      }
    });
    Framebuffer<S> sum(image.width(), image.height());
    splats_.apply(sum, drops);
    const T inv_n = T(1) / T(n);
    for (std::uint32_t p = 0; p < sum.pixel_count(); ++p) image.add(p, sum[p] * inv_n);
  }

  /// Bytes of the splats the last iteration recorded: what grows with the light paths (the
  /// renderer's memory estimate scales them by the pixels).
  [[nodiscard]] std::size_t light_path_bytes() const noexcept { return splats_.applied_bytes(); }
  /// Bytes of the splat lists that do not grow with the light paths, at most: the unfilled rest
  /// of each chunk's last block.
  [[nodiscard]] static constexpr std::size_t fixed_scratch_bytes() noexcept {
    return chunk_count * SplatList<S>::block_size * sizeof(typename SplatList<S>::value_type);
  }

  /// One light path; q.pixel is ignored. Every camera connection is one sink.add to the
  /// pixel it lands in, or one sink.drop when it is not finite.
  template <UniformSource<T> R, ContributionSink<S> Sink>
  void estimate(const Scn& scene, const EstimateQuery&, R& rng, Sink& sink) const noexcept {
    auto start = start_.sample(scene, {}, rng);
    if (!start) return;
    S beta = start->weight;
    Segment<T> segment = start->segment;
    Vec3<T> direction = start->direction;
    for (std::size_t light_segments = 1;; ++light_segments) {
      if (segment.x.kind != PointKind::surface) break;
      // The camera connection: s_1 from the sensor to x of the current light segment.
      if (const auto c = camera_.sample(scene, {segment}, rng); c && c->pdf > T(0)) {
        const S f = scene.bsdf().eval(BsdfQuery<T>{segment.x, -c->direction, direction, Transport::radiance});
        if (!is_black(f)) {
          const auto response = scene.sensor().importance(SensorQuery<T>{c->segment.x, c->direction});
          if (response) {
            const S value = beta * f * c->weight;
            if (is_finite(value)) sink.add(response->pixel, value);
            else sink.drop(DropReason::non_finite);
          }
        }
      }
      if (light_segments + 1 >= options_.max_length) break;  // no room for another segment and the camera's
      const auto next = next_.sample(scene, {segment, direction}, rng);
      if (!next) break;
      beta = beta * next->weight;
      segment = next->segment;
      direction = next->direction;
      if (options_.roulette_from != 0 && light_segments >= options_.roulette_from) {
        const T q = continuation_probability(next->weight, next->delta);
        if (q < T(1)) {
          if (!(rng.template uniform<T>() < q)) break;
          beta = beta / q;
        }
      }
      if (is_black(beta)) break;
    }
  }

 private:
  LightTracerOptions options_;
  LightStartSampler<Scn> start_;
  LightNextSegmentSampler<Scn, DiracKernel<T>> next_{DiracKernel<T>{}};
  SensorBridgeSampler<Scn, DiracKernel<T>> camera_{DiracKernel<T>{}};
  mutable SplatRecorder<S> splats_{chunk_count};  ///< per chunk, in recording order; cleared by apply
};

}  // namespace segpath
