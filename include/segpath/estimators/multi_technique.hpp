// The multi-technique MIS estimator over whole segment paths (N36, N37): T path techniques,
// technique i drawing n_i paths of k segments with full-path density p_i; every path is weighted
// by the balance or power heuristic over all techniques. Also the PathTechnique concept and two
// ready techniques: sequential (N29, N31) and sequential with a next-event last segment (N34).
#pragma once

#include <array>
#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

#include "segpath/concepts/estimator.hpp"
#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/samplers/bridge.hpp"
#include "segpath/samplers/next_segment.hpp"
#include "segpath/samplers/sensor_start.hpp"
#include "segpath/weights/mis.hpp"

namespace segpath {

/// What a path technique is asked for: the pixel whose sensor segment starts the path, and
/// the path length k in segments.
struct PathQuery {
  std::uint32_t pixel = 0;
  std::size_t length = 0;
};

/// A drawn segment path with its full-path density p_i(s-bar) (N35): the product of the
/// per-segment conditional densities, in the product measure of all 2k endpoints. Deltas
/// shared by every technique (the Dirac kernel's junctions, a pinhole or probe) enter as
/// their coefficients. `delta` marks a path drawn through a Dirac that not every technique
/// shares (a specular BSDF lobe, a Dirac light end): its density has no evaluable
/// counterpart under the other techniques.
template <Real T, std::size_t MaxLength>
struct PathSample {
  SegmentPath<T, MaxLength> path;
  T pdf = 0;
  bool delta = false;
};

namespace detail {
template <class Tech>
concept HasPathType = requires {
  typename Tech::Path;
  { Tech::Path::capacity } -> std::convertible_to<std::size_t>;
};
template <class Tech, class Scn>
concept HasPathSample = requires(const Tech& tech, const Scn& scene, const PathQuery& q,
                                 Pcg32& rng) {
  {
    tech.sample(scene, q, rng)
    } -> std::same_as<std::optional<PathSample<typename Scn::Scalar, Tech::Path::capacity>>>;
};
template <class Tech, class Scn>
concept HasPathPdf = requires(const Tech& tech, const Scn& scene, const PathQuery& q,
                              const typename Tech::Path& path) {
  { tech.pdf(scene, q, path) } -> std::convertible_to<typename Scn::Scalar>;
};
template <class Tech, class Scn>
concept PathOfScene =
    std::same_as<typename Tech::Path, SegmentPath<typename Scn::Scalar, Tech::Path::capacity>>;

/// The first `segments` (>= 1) segments of a sensor-side sequential path: s_1 from the sensor
/// (N29), then successors (N31), with the product of their densities. `direction` receives
/// the unit direction of the last segment. nullopt when a draw fails. Every path technique
/// here starts with this prefix.
template <std::size_t MaxLength, class Scn, class First, class Next, class R>
[[nodiscard]] std::optional<PathSample<typename Scn::Scalar, MaxLength>> sample_sequential_prefix(
    const Scn& scene, const First& first_sampler, const Next& next_sampler, std::uint32_t pixel,
    std::size_t segments, R& rng, Vec3<typename Scn::Scalar>& direction) noexcept {
  std::optional<PathSample<typename Scn::Scalar, MaxLength>> out;
  const auto first = first_sampler.sample(scene, {pixel}, rng);
  if (!first) return out;
  out.emplace();
  out->path.push_back(first->segment);
  out->pdf = first->pdf;
  out->delta = first->delta;
  direction = first->direction;
  for (std::size_t i = 1; i < segments; ++i) {
    const auto next = next_sampler.sample(scene, {out->path[i - 1], direction}, rng);
    if (!next) return std::nullopt;
    out->path.push_back(next->segment);
    out->pdf *= next->pdf;
    out->delta = out->delta || next->delta;
    direction = next->direction;
  }
  return out;
}
}  // namespace detail

/// A technique that draws whole segment paths (N36). Syntactic requirements:
///  1. `Tech::Path` is SegmentPath<Scn::Scalar, capacity>: fixed storage, no allocation;
///  2. `tech.sample(scene, PathQuery, rng)` returns std::optional<PathSample<Scalar, capacity>>;
///  3. `tech.pdf(scene, PathQuery, path)` returns p_i(path) for any path.
/// Semantic requirements:
///  4. pdf of a drawn path equals the density returned with it (up to rounding), unless the
///     sample is marked `delta`;
///  5. pdf is 0 for paths the technique cannot produce (wrong length, wrong pixel, a zero
///     conditional density anywhere), and its integral over paths of the queried length is the
///     probability that sample succeeds;
///  6. a returned sample has exactly q.length segments and pdf > 0 and finite.
template <class Tech, class Scn>
concept PathTechnique = detail::HasPathType<Tech> && detail::PathOfScene<Tech, Scn> &&
    detail::HasPathSample<Tech, Scn> && detail::HasPathPdf<Tech, Scn>;

/// Sequential path technique: s_1 from the sensor-start sampler (N29) for q.pixel, s_2..s_k
/// from the next-segment sampler (N31):  p(s-bar) = p_W(s_1) prod_{i=1}^{k-1} p(s_{i+1} | s_i).
/// With the Dirac kernel this is path tracing's BSDF sampling.
template <Scene Scn, KernelOf<typename Scn::Scalar> K, std::size_t MaxLength>
requires std::same_as<typename K::Scalar, typename Scn::Scalar> &&
    (MaxLength >= 1) class SequentialPathTechnique {
 public:
  using T = typename Scn::Scalar;
  using Path = SegmentPath<T, MaxLength>;

  explicit SequentialPathTechnique(K kernel) noexcept(std::is_nothrow_move_constructible_v<K>)
      : next_(std::move(kernel)) {}

  /// Paths of 1..MaxLength segments; nullopt when a draw fails.
  template <UniformSource<T> R>
  [[nodiscard]] std::optional<PathSample<T, MaxLength>> sample(const Scn& scene, const PathQuery& q,
                                                               R& rng) const noexcept {
    if (q.length < 1 || q.length > MaxLength) return std::nullopt;
    Vec3<T> direction;
    auto out = detail::sample_sequential_prefix<MaxLength>(scene, first_, next_, q.pixel, q.length, rng, direction);
    if (!out) return out;
    if (!(out->pdf > T(0)) || !std::isfinite(out->pdf)) return std::nullopt;
    return out;
  }

  /// p_W(s_1 | q.pixel) prod p(s_{i+1} | s_i); 0 for a path of another length.
  [[nodiscard]] T pdf(const Scn& scene, const PathQuery& q, const Path& path) const noexcept {
    if (q.length < 1 || path.size() != q.length) return T(0);
    T p = first_.pdf(scene, {q.pixel}, path[0]);
    for (std::size_t i = 1; i < path.size() && p > T(0); ++i)
      p *= next_.pdf(scene, {path[i - 1]}, path[i]);
    return p;
  }

 private:
  SensorStartSampler<Scn> first_;
  NextSegmentSampler<Scn, K> next_;
};

/// Sequential path technique with a next-event last segment: s_1 from the sensor (N29),
/// s_2..s_{k-1} from the next-segment sampler (N31), s_k from the light bridge (N34):
///   p(s-bar) = p_W(s_1) prod_{i=1}^{k-2} p(s_{i+1} | s_i) p_K(x_k | s_{k-1}) p_L(y_k | x_k).
/// Paths of at least 2 segments.
template <LightSampledScene Scn, KernelOf<typename Scn::Scalar> K, std::size_t MaxLength>
requires std::same_as<typename K::Scalar, typename Scn::Scalar> &&
    (MaxLength >= 2) class LightBridgePathTechnique {
 public:
  using T = typename Scn::Scalar;
  using Path = SegmentPath<T, MaxLength>;

  explicit LightBridgePathTechnique(const K& kernel) : next_(kernel), bridge_(kernel) {}

  template <UniformSource<T> R>
  [[nodiscard]] std::optional<PathSample<T, MaxLength>> sample(const Scn& scene, const PathQuery& q,
                                                               R& rng) const noexcept {
    if (q.length < 2 || q.length > MaxLength) return std::nullopt;
    Vec3<T> direction;
    auto out = detail::sample_sequential_prefix<MaxLength>(scene, first_, next_, q.pixel, q.length - 1, rng, direction);
    if (!out) return out;
    const auto last = bridge_.sample(scene, {out->path[q.length - 2]}, rng);
    if (!last) return std::nullopt;
    out->path.push_back(last->segment);
    out->pdf *= last->pdf;
    out->delta = out->delta || last->delta;
    if (!(out->pdf > T(0)) || !std::isfinite(out->pdf)) return std::nullopt;
    return out;
  }

  [[nodiscard]] T pdf(const Scn& scene, const PathQuery& q, const Path& path) const noexcept {
    if (q.length < 2 || path.size() != q.length) return T(0);
    T p = first_.pdf(scene, {q.pixel}, path[0]);
    for (std::size_t i = 1; i + 1 < path.size() && p > T(0); ++i)
      p *= next_.pdf(scene, {path[i - 1]}, path[i]);
    if (!(p > T(0))) return T(0);
    return p * bridge_.pdf(scene, {path[path.size() - 2]}, path[path.size() - 1]);
  }

 private:
  SensorStartSampler<Scn> first_;
  NextSegmentSampler<Scn, K> next_;
  LightBridgeSampler<Scn, K> bridge_;
};

namespace detail {
template <class First, class... Rest>
struct FirstOf {
  using type = First;
};
}  // namespace detail

/// The multi-technique MIS estimator (N36) for paths of one length k:
///   <J_rho,k> = sum_{i=1}^T sum_{j=1}^{n_i} w_i(s-bar_ij) g_rho(s-bar_ij) / (n_i p_i(s-bar_ij)),
/// w_i = n_i p_i / sum_m n_m p_m (balance) or (n_i p_i)^2 / sum_m (n_m p_m)^2 (power), so that
/// sum_i w_i = 1 (N37) wherever some technique can draw the path; g_rho is path_contribution
/// (N17, visibility included) with the estimator's kernel, which must be the kernel the
/// techniques sample. The techniques are a compile-time list (std::tuple, fold expressions):
/// every density inlines, and nothing is allocated per path.
/// Limitation: a path marked `delta` (drawn through a specular lobe or a Dirac light end) cannot
/// be weighted against techniques whose pdf ignores that Dirac; it is dropped as zero_density.
template <Scene Scn, KernelOf<typename Scn::Scalar> K, PathTechnique<Scn>... Techs>
requires(sizeof...(Techs) >= 1) && std::same_as<typename K::Scalar, typename Scn::Scalar> &&
    (std::same_as<typename Techs::Path, typename detail::FirstOf<Techs...>::type::Path> &&
     ...) class MultiTechniqueEstimator {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using Path = typename detail::FirstOf<Techs...>::type::Path;
  static constexpr std::size_t technique_count = sizeof...(Techs);
  using Counts = std::array<std::size_t, technique_count>;
  using Densities = std::array<T, technique_count>;

  /// Paths of `length` segments (1 <= length <= Path::capacity); technique i draws counts[i]
  /// paths per estimate (0 disables it; at least one count must be positive).
  MultiTechniqueEstimator(K kernel, std::size_t length, const Counts& counts,
                          MisHeuristic heuristic, Techs... techniques)
      : kernel_(std::move(kernel)),
        length_(length),
        counts_(counts),
        heuristic_(heuristic),
        techniques_(std::move(techniques)...) {
    if (length < 1 || length > Path::capacity)
      throw std::invalid_argument("segpath::MultiTechniqueEstimator: path length must lie in [1, " +
                                  std::to_string(Path::capacity) + "], got " +
                                  std::to_string(length));
    std::size_t total = 0;
    for (const std::size_t n : counts) total += n;
    if (total == 0)
      throw std::invalid_argument("segpath::MultiTechniqueEstimator: all sample counts are 0");
  }

  [[nodiscard]] std::size_t length() const noexcept { return length_; }
  [[nodiscard]] const Counts& counts() const noexcept { return counts_; }
  [[nodiscard]] MisHeuristic heuristic() const noexcept { return heuristic_; }
  [[nodiscard]] const std::tuple<Techs...>& techniques() const noexcept { return techniques_; }

  /// n_i p_i(path) for every technique i, for the path as drawn for `pixel`.
  [[nodiscard]] Densities densities(const Scn& scene, std::uint32_t pixel,
                                    const Path& path) const noexcept {
    Densities out{};
    const PathQuery q{pixel, length_};
    [&]<std::size_t... I>(std::index_sequence<I...>) {
      ((out[I] = T(counts_[I]) * T(std::get<I>(techniques_).pdf(scene, q, path))), ...);
    }
    (std::make_index_sequence<technique_count>{});
    return out;
  }

  /// w_i(path) for every technique (N36, N37): the weights sum to 1 wherever one of the
  /// techniques can draw the path, and are all 0 elsewhere.
  [[nodiscard]] Densities weights(const Scn& scene, std::uint32_t pixel,
                                  const Path& path) const noexcept {
    const Densities n_p = densities(scene, pixel, path);
    Densities w{};
    for (std::size_t i = 0; i < technique_count; ++i)
      w[i] = mis_weight(n_p[i], std::span<const T>(n_p), heuristic_);
    return w;
  }

  /// One sample of (N36) for pixel q.pixel: every technique draws its n_i paths. Contributions
  /// to q.pixel are summed into one sink.add (possibly of zero); a path the sensor maps to
  /// another pixel is added there on its own. Non-finite path contributions are dropped.
  template <UniformSource<T> R, ContributionSink<S> Sink>
  void estimate(const Scn& scene, const EstimateQuery& q, R& rng, Sink& sink) const noexcept {
    S total = S(T(0));
    [&]<std::size_t... I>(std::index_sequence<I...>) {
      (estimate_technique<I>(scene, q.pixel, rng, sink, total), ...);
    }
    (std::make_index_sequence<technique_count>{});
    sink.add(q.pixel, total);
  }

 private:
  template <std::size_t I, class R, class Sink>
  void estimate_technique(const Scn& scene, std::uint32_t pixel, R& rng, Sink& sink,
                          S& total) const noexcept {
    const auto& technique = std::get<I>(techniques_);
    const PathQuery pq{pixel, length_};
    for (std::size_t j = 0; j < counts_[I]; ++j) {
      const auto drawn = technique.sample(scene, pq, rng);
      if (!drawn) continue;
      if (drawn->delta) {
        sink.drop(DropReason::zero_density);
        continue;
      }
      const auto g = path_contribution(scene, kernel_, drawn->path);
      if (!g || is_black(g->value)) continue;
      Densities n_p = densities(scene, pixel, drawn->path);
      // The drawn density is the technique's own term (N36's n_i p_i): identical to pdf() up to
      // rounding, and exactly the density the sample was drawn with.
      n_p[I] = T(counts_[I]) * drawn->pdf;
      const T w = mis_weight(n_p[I], std::span<const T>(n_p), heuristic_);
      if (w == T(0)) continue;
      const S value = g->value * (w / n_p[I]);
      if (!is_finite(value)) {
        sink.drop(DropReason::non_finite);
        continue;
      }
      if (g->pixel == pixel)
        total += value;
      else
        sink.add(g->pixel, value);
    }
  }

  K kernel_;
  std::size_t length_;
  Counts counts_;
  MisHeuristic heuristic_;
  std::tuple<Techs...> techniques_;
};

/// Builds a MultiTechniqueEstimator, deducing the technique types.
template <Scene Scn, KernelOf<typename Scn::Scalar> K, PathTechnique<Scn>... Techs>
[[nodiscard]] MultiTechniqueEstimator<Scn, K, Techs...> make_multi_technique_estimator(
    K kernel, std::size_t length, const std::array<std::size_t, sizeof...(Techs)>& counts,
    MisHeuristic heuristic, Techs... techniques) {
  return MultiTechniqueEstimator<Scn, K, Techs...>(std::move(kernel), length, counts, heuristic,
                                                   std::move(techniques)...);
}

}  // namespace segpath
