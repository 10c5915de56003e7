// The sequential estimator (N35): one segment path per call, built by the sensor-start
// sampler (N29) and the next-segment sampler (N31), contributing g_rho(s-bar) / p_S(s-bar)
// for every prefix that ends on an emitter. With the Dirac kernel this is path tracing
// without next-event estimation; with a disk kernel, its segment (disconnected) form.
#pragma once

#include "segpath/concepts/estimator.hpp"
#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/samplers/next_segment.hpp"
#include "segpath/samplers/sensor_start.hpp"

#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>

namespace segpath {

/// Which path lengths (in segments) an estimator counts.
struct PathLengths {
  std::size_t min = 1;
  std::size_t max = 10;
};

template <Scene Scn, KernelOf<typename Scn::Scalar> K>
class SequentialEstimator {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;

  /// Counts paths of `lengths.min` to `lengths.max` segments (1 <= min <= max).
  explicit SequentialEstimator(K kernel, PathLengths lengths = {}) : next_(std::move(kernel)), lengths_(lengths) {
    if (lengths.min < 1 || lengths.max < lengths.min)
      throw std::invalid_argument("segpath::SequentialEstimator: need 1 <= min length <= max length, got [" +
                                  std::to_string(lengths.min) + ", " + std::to_string(lengths.max) + "]");
  }

  [[nodiscard]] const PathLengths& lengths() const noexcept { return lengths_; }

  /// One sample for pixel q.pixel: exactly one sink.add (possibly of zero) or sink.drop.
  /// (N35) incrementally: beta_k = prod_{i<=k} factor_i / pdf_i = [W G prod K f G] / p_S,
  /// and the estimate is sum_k beta_k L_e(s_k).
  template <UniformSource<T> R, ContributionSink<S> Sink>
  SEGPATH_FORCE_INLINE void estimate(const Scn& scene, const EstimateQuery& q, R& rng, Sink& sink) const noexcept {
    S total = S(T(0));
    SegmentSample<S> s;  // one sample, continued in place (NextSegmentSampler::advance)
    if (auto first = first_.sample(scene, {q.pixel}, rng)) {
      s = *first;
    } else {
      sink.add(q.pixel, total);
      return;
    }
    S beta = s.weight;
    for (std::size_t length = 1;; ++length) {
      if (length >= lengths_.min) total += beta * emission_factor(scene, s.segment, s.direction);
      if (length == lengths_.max) break;
      if (!next_.advance(scene, s, rng)) break;  // samplers return only samples with pdf > 0 (SegmentSampler, 7.)
      beta = beta * s.weight;
      if (is_black(beta)) break;
    }
    if (!is_finite(total)) {
      sink.drop(DropReason::non_finite);
      return;
    }
    sink.add(q.pixel, total);
  }

 private:
  SensorStartSampler<Scn> first_;
  NextSegmentSampler<Scn, K> next_;
  PathLengths lengths_;
};

}  // namespace segpath
