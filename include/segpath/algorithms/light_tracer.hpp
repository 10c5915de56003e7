// Light tracing (SPEC 1.9): light-start segments (N30), Dirac-kernel light-side successors
// (the mirror of N31), and at every surface end a sensor bridge (N34) to the camera. Each
// call traces one light path and splats to whichever pixels it reaches; J_p is the sum of
// its contributions to p, so an image is the sum over N paths divided by N.
#pragma once

#include "segpath/concepts/estimator.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/roulette.hpp"
#include "segpath/kernels/dirac.hpp"
#include "segpath/samplers/bridge.hpp"
#include "segpath/samplers/light_next.hpp"
#include "segpath/samplers/light_start.hpp"

#include <algorithm>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace segpath {

struct LightTracerOptions {
  std::size_t max_length = 10;  ///< segments per path, the sensor segment included (>= 2)
  std::size_t roulette_from = 0;  ///< Russian roulette (core/roulette.hpp) from this many light segments on (0: never)
};

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
};

}  // namespace segpath
