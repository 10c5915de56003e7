// The Estimator concept: turns sampled segments into pixel contributions, delivered to a
// ContributionSink (an image, a per-thread accumulator, a test's recorder).
// Customization points: estimate(scene, EstimateQuery, rng, sink); the sink's add and drop.
#pragma once

#include "segpath/core/drop.hpp"
#include "segpath/core/rng.hpp"

#include <concepts>
#include <cstdint>

namespace segpath {

/// Which pixel the estimate is for, and which sample of it (estimators that splat to
/// arbitrary pixels, such as light tracing, use only sample_index).
struct EstimateQuery {
  std::uint32_t pixel = 0;
  std::uint64_t sample_index = 0;
};

/// Receives contributions: add(pixel, value) for a finite contribution, drop(reason) for a
/// sample the estimator discarded. Sinks are per thread; merge them in a fixed order.
template <class K, class S>
concept ContributionSink = requires(K& sink, std::uint32_t pixel, const S& value, DropReason r) {
  sink.add(pixel, value);
  sink.drop(r);
};

namespace detail {
/// The least a sink offers: used to check estimators against the concept.
template <class S>
struct SinkArchetype {
  void add(std::uint32_t, const S&) noexcept {}
  void drop(DropReason) noexcept {}
};
}  // namespace detail

/// An estimator for scenes of type Scn. Syntactic requirements:
///  1. `e.estimate(scene, EstimateQuery, rng, sink)` accepts any ContributionSink of
///     Scn::Spectrum (checked with a minimal sink).
/// Semantic requirements:
///  2. the expected sum of contributions to pixel p over one call is J_p (N16), or, for a
///     consistent estimator, converges to it as the kernel shrinks;
///  3. only finite values reach sink.add; everything else is sink.drop with a reason;
///  4. the result depends only on the scene, the query and the random stream.
template <class E, class Scn>
concept Estimator = requires(const E& e, const Scn& scene, const EstimateQuery& q, Pcg32& rng,
                             detail::SinkArchetype<typename Scn::Spectrum>& sink) {
  e.estimate(scene, q, rng, sink);
};

}  // namespace segpath
