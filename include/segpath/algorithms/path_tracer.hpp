// Segment path tracing with next-event estimation (SPEC 1.9, first row): the sensor-start
// sampler (N29), Dirac-kernel successors (N31) and a light-end bridge (N34) at every
// surface end, the two ways of reaching a light end combined by MIS (N5).
#pragma once

#include "segpath/concepts/estimator.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/framebuffer.hpp"
#include "segpath/core/parallel.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/core/roulette.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/kernels/dirac.hpp"
#include "segpath/samplers/bridge.hpp"
#include "segpath/samplers/next_segment.hpp"
#include "segpath/samplers/sensor_start.hpp"
#include "segpath/weights/mis.hpp"

#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace segpath {

struct PathTracerOptions {
  std::size_t max_length = 10;  ///< segments per path, the sensor segment included (>= 1)
  MisHeuristic heuristic = MisHeuristic::power;
  /// Russian roulette (core/roulette.hpp) after every scattering from this path length on (0:
  /// never). Changes noise only.
  std::size_t roulette_from = 0;
  std::uint64_t seed = 0;  ///< render_iteration: pixel p of iteration i draws from Pcg32::for_sample(seed, p, i)
};

template <LightSampledScene Scn>
class PathTracer {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;

  explicit PathTracer(PathTracerOptions options = {}) : options_(options) {
    if (options.max_length < 1)
      throw std::invalid_argument("segpath::PathTracer: max_length must be >= 1, got " +
                                  std::to_string(options.max_length));
  }
  [[nodiscard]] const PathTracerOptions& options() const noexcept { return options_; }

  /// Adds one iteration's estimate to `image` (sensor-sized): one path per pixel, a task per
  /// row of image.width() pixels. Deterministic for a given seed and iteration whatever
  /// `parallel_for` does; non-finite paths are counted in `drops`.
  template <ParallelFor P = SerialFor>
  void render_iteration(const Scn& scene, std::uint64_t iteration, Framebuffer<S>& image, DropCounters& drops,
                        const P& parallel_for = {}) const {
    if (image.pixel_count() != scene.sensor().pixel_count())
      throw std::invalid_argument("segpath::PathTracer: the image has " + std::to_string(image.pixel_count()) +
                                  " pixels, the sensor " + std::to_string(scene.sensor().pixel_count()));
    const std::uint32_t width = image.width();
    std::vector<DropCounters> row_drops(image.height());
    parallel_for(std::size_t(image.height()), [&](std::size_t row) {
      PixelSink sink{S(T(0)), &row_drops[row]};
      for (std::uint32_t x = 0; x < width; ++x) {
        const std::uint32_t pixel = std::uint32_t(row) * width + x;
        Pcg32 rng = Pcg32::for_sample(options_.seed, pixel, iteration);
        sink.value = S(T(0));
        estimate(scene, EstimateQuery{pixel, iteration}, rng, sink);
        image.add(pixel, sink.value);
      }
    });
    for (const DropCounters& d : row_drops) drops += d;
  }

  /// One path for pixel q.pixel; exactly one sink.add (possibly zero) or sink.drop.
  /// Emission reached by a BSDF-sampled segment is weighted against the light bridge that
  /// could have produced the same light end, and vice versa (both in the light end's
  /// measure: area, or solid angle at infinity); Dirac light ends (point lights, the sun)
  /// only the bridge can reach.
  template <UniformSource<T> R, ContributionSink<S> Sink>
  void estimate(const Scn& scene, const EstimateQuery& q, R& rng, Sink& sink) const noexcept {
    using Sample = std::optional<SegmentSample<S>>;
    S total(T(0));
    SegmentSample<S> s;  // the path's last segment, continued in place (NextSegmentSampler::advance)
    if (auto first = first_.sample(scene, {q.pixel}, rng)) {
      s = *first;
    } else {
      sink.add(q.pixel, total);
      return;
    }
    S beta = s.weight;
    bool reached_by_bsdf = false;  // false: the sensor segment or a delta lobe (no NEE rival)
    const auto& emitter = scene.emitter();
    for (std::size_t length = 1;; ++length) {
      const S emitted = emission_factor(scene, s.segment, s.direction);
      if (!is_black(emitted)) {
        T w = T(1);
        if (reached_by_bsdf) {
          const T p_light = emitter.pdf_towards(EmitterPdfTowardsQuery<T>{s.segment.x, s.segment.y});
          w = mis_weight(s.pdf, p_light, options_.heuristic);
        }
        total += beta * emitted * w;
      }
      if (length == options_.max_length || s.segment.y.kind != PointKind::surface) break;

      // Next-event estimation: a light-end bridge from y (Dirac junction); none from a BSDF
      // with delta lobes only, whose connection is zero (HasIsDelta, concepts/bsdf.hpp).
      bool connect = true;
      if constexpr (HasIsDelta<std::remove_cvref_t<decltype(scene.bsdf())>, S>) connect = !scene.bsdf().is_delta(s.segment.y);
      if (const auto e = connect ? bridge_.sample(scene, {s.segment}, rng) : Sample{}; e && e->pdf > T(0)) {
        const BsdfQuery<T> query{s.segment.y, -s.direction, e->direction, Transport::radiance};
        const S f = scene.bsdf().eval(query);
        if (!is_black(f)) {
          T w = T(1);
          if (!e->delta) {
            const T p_bsdf = solid_angle_to_area(scene.bsdf().pdf(query), e->segment.x, e->segment.y);
            w = mis_weight(e->pdf, p_bsdf, options_.heuristic);
          }
          total += beta * f * e->weight * w;
        }
      }

      if (!next_.advance(scene, s, rng)) break;
      beta = beta * s.weight;
      reached_by_bsdf = !s.delta;
      if (options_.roulette_from != 0 && length >= options_.roulette_from) {
        const T q = continuation_probability(s.weight, s.delta);
        if (q < T(1)) {
          if (!(rng.template uniform<T>() < q)) break;
          beta = beta / q;
        }
      }
      if (is_black(beta)) break;
    }
    if (!is_finite(total)) {
      sink.drop(DropReason::non_finite);
      return;
    }
    sink.add(q.pixel, total);
  }

 private:
  /// The sink of one path: its value (0 when dropped).
  struct PixelSink {
    S value;
    DropCounters* drops;
    void add(std::uint32_t, const S& v) noexcept { value += v; }
    void drop(DropReason r) noexcept { drops->add(r); }
  };

  PathTracerOptions options_;
  SensorStartSampler<Scn> first_;
  NextSegmentSampler<Scn, DiracKernel<T>> next_{DiracKernel<T>{}};
  LightBridgeSampler<Scn, DiracKernel<T>> bridge_{DiracKernel<T>{}};
};

}  // namespace segpath
