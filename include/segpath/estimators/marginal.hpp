// Marginal segment path sampling (N41, N42): MMIS applied to whole segment paths. Families of
// technique samples t_{i,j} with conditional path densities p_i(s-bar | t); every drawn path is
// divided by the sum of its densities under all drawn technique samples of all families.
// Generic form (marginal_estimate) and one concrete instance (MarginalPathEstimator).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <functional>
#include <optional>
#include <ranges>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "segpath/concepts/estimator.hpp"
#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/integrand/contribution.hpp"
#include "segpath/estimators/multi_technique.hpp"
#include "segpath/samplers/light_start.hpp"
#include "segpath/weights/mmis.hpp"

namespace segpath {

/// The balance-heuristic MMIS estimator over whole paths (N42):
///   <J_rho,k>_BH = sum_{i,j} g(s-bar_ij) / sum_{i'} sum_{j'} p_{i'}(s-bar_ij | t_{i'j'}).
/// `paths` pools the paths every family drew (which family drew a path does not enter the
/// estimate); `families` are all technique families (weights/mmis.hpp), each holding *all* its
/// drawn technique samples, also those whose path draw failed. g(path) returns a scalar or a
/// spectrum. O(#paths x #technique samples) density evaluations, no allocation.
template <std::ranges::forward_range Paths, class G, class... Fs>
requires(sizeof...(Fs) >= 1) && (TechniqueFamily<Fs, std::ranges::range_value_t<Paths>> && ...) &&
    std::invocable<G&, const std::ranges::range_value_t<
                           Paths>&> [[nodiscard]] auto marginal_estimate(const Paths& paths, G&& g,
                                                                         const Fs&... families) {
  using V = std::remove_cvref_t<std::invoke_result_t<G&, const std::ranges::range_value_t<Paths>&>>;
  V sum{};
  for (const auto& path : paths)
    sum += mmis_contribution(V(std::invoke(g, path)), mmis_denominator(path, families...));
  return sum;
}

/// A conditional path technique whose parameter t is a light-start segment l (N30) that is not
/// part of the path it generates. For paths of k >= 2 segments: s_1 from the sensor (N29),
/// s_2..s_{k-1} by the next-segment sampler (N31) with the path kernel K, and the last segment
/// s_k = (x_k, y_k) with x_k from K around y_{k-1} and y_k from the merge kernel M around the
/// light end y of l, rejected unless V(x_k, y_k):
///   p(s-bar | l) = p_W(s_1) prod_{i=1}^{k-2} p(s_{i+1} | s_i) p_K(x_k | s_{k-1}) p_M(y_k | l.y).
/// Its marginal over l is a kernel-smoothed emission density, so light samples are reused as in
/// photon mapping, but weighted by MMIS instead of being accepted as a biased merge. M's pdf must
/// be the exact density of its samples on the scene's surface (DiskKernel: planar emitters).
template <LightSampledScene Scn, KernelOf<typename Scn::Scalar> K, KernelOf<typename Scn::Scalar> M, std::size_t MaxLength>
requires std::same_as<typename K::Scalar, typename Scn::Scalar> &&
    std::same_as<typename M::Scalar, typename Scn::Scalar> &&
    (MaxLength >= 2) class LightMergePathTechnique {
 public:
  using T = typename Scn::Scalar;
  using Path = SegmentPath<T, MaxLength>;

  LightMergePathTechnique(const K& kernel, M merge)
      : kernel_(kernel), next_(kernel), merge_(std::move(merge)) {}

  [[nodiscard]] const M& merge_kernel() const noexcept { return merge_; }

  /// Draws a path of q.length segments given the light segment `light`.
  template <UniformSource<T> R>
  [[nodiscard]] std::optional<PathSample<T, MaxLength>> sample(const Scn& scene, const PathQuery& q,
                                                               const Segment<T>& light,
                                                               R& rng) const noexcept {
    if (q.length < 2 || q.length > MaxLength) return std::nullopt;
    Vec3<T> direction;
    auto out = detail::sample_sequential_prefix<MaxLength>(scene, first_, next_, q.pixel, q.length - 1, rng, direction);
    if (!out) return out;
    const Segment<T>& previous = out->path[q.length - 2];
    const Vec2<T> u_junction = uniform2<T>(rng);
    const Vec2<T> u_merge = uniform2<T>(rng);
    if (previous.y.kind != PointKind::surface) return std::nullopt;
    SurfacePoint<T> x = previous.y;
    T p_x = T(1);
    if constexpr (!K::is_dirac) {
      const auto junction = kernel_.sample(KernelSampleQuery<T>{previous, u_junction});
      if (!junction || !(junction->pdf > T(0))) return std::nullopt;
      x = junction->point;
      p_x = junction->pdf;
    } else {
      (void)u_junction;
    }
    const auto y = merge_.sample(KernelSampleQuery<T>{light, u_merge});
    if (!y || !(y->pdf > T(0))) return std::nullopt;
    const Segment<T> last{x, y->point};
    if (!(last.length_squared() > T(0)) || !scene.visible(VisibilityQuery<T>{last.x, last.y}))
      return std::nullopt;
    out->path.push_back(last);
    out->pdf *= p_x * y->pdf;
    if (!(out->pdf > T(0)) || !std::isfinite(out->pdf)) return std::nullopt;
    return out;
  }

  /// p(path | light) for any path; 0 for a path of another length.
  [[nodiscard]] T pdf(const Scn& scene, const PathQuery& q, const Path& path,
                      const Segment<T>& light) const noexcept {
    if (q.length < 2 || path.size() != q.length) return T(0);
    const Segment<T>& last = path[path.size() - 1];
    const T p_y = merge_.pdf(KernelQuery<T>{light, Segment<T>{last.y, last.y}});
    if (!(p_y > T(0))) return T(0);
    T p = first_.pdf(scene, {q.pixel}, path[0]);
    for (std::size_t i = 1; i + 1 < path.size() && p > T(0); ++i)
      p *= next_.pdf(scene, {path[i - 1]}, path[i]);
    if (!(p > T(0))) return T(0);
    const T p_x = kernel_.pdf(KernelQuery<T>{path[path.size() - 2], last});
    if (!(p_x > T(0)) || !(last.length_squared() > T(0))) return T(0);
    if (!scene.visible(VisibilityQuery<T>{last.x, last.y})) return T(0);
    return p * p_x * p_y;
  }

 private:
  K kernel_;
  SensorStartSampler<Scn> first_;
  NextSegmentSampler<Scn, K> next_;
  M merge_;
};

/// A concrete marginal segment path estimator (N42) for paths of k segments with two families:
///  1. sequential: SequentialPathTechnique drawn n_s times, unconditional (its share of every
///     denominator is n_s p_seq(s-bar));
///  2. light merge: n_l technique samples l_j from the light-start sampler (N30), each
///     generating one path by LightMergePathTechnique (its share: sum_j p(s-bar | l_j)).
/// Every path of either family is divided by n_s p_seq(s-bar) + sum_j p(s-bar | l_j), over all
/// drawn l_j: unbiased wherever the sequential family can draw the path (n_s >= 1). Technique
/// samples live in fixed storage of MaxLightSamples: nothing is allocated per estimate.
template <LightSampledScene Scn, KernelOf<typename Scn::Scalar> K, KernelOf<typename Scn::Scalar> M, std::size_t MaxLength,
          std::size_t MaxLightSamples = 16>
requires std::same_as<typename K::Scalar, typename Scn::Scalar> &&
    (MaxLength >= 2) class MarginalPathEstimator {
 public:
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  using Path = SegmentPath<T, MaxLength>;

  /// Paths of `length` segments (2 <= length <= MaxLength); n_s >= 1 sequential paths and
  /// n_l <= MaxLightSamples light technique samples per estimate.
  MarginalPathEstimator(const K& kernel, M merge, std::size_t length, std::size_t sequential_count,
                        std::size_t light_count)
      : kernel_(kernel),
        sequential_(kernel),
        merge_(kernel, std::move(merge)),
        length_(length),
        sequential_count_(sequential_count),
        light_count_(light_count) {
    if (length < 2 || length > MaxLength)
      throw std::invalid_argument("segpath::MarginalPathEstimator: path length must lie in [2, " +
                                  std::to_string(MaxLength) + "], got " + std::to_string(length));
    if (sequential_count < 1)
      throw std::invalid_argument(
          "segpath::MarginalPathEstimator: sequential count must be >= 1, got 0");
    if (light_count > MaxLightSamples)
      throw std::invalid_argument("segpath::MarginalPathEstimator: light count must be <= " +
                                  std::to_string(MaxLightSamples) + ", got " +
                                  std::to_string(light_count));
  }

  [[nodiscard]] std::size_t length() const noexcept { return length_; }
  [[nodiscard]] const SequentialPathTechnique<Scn, K, MaxLength>& sequential() const noexcept {
    return sequential_;
  }
  [[nodiscard]] const LightMergePathTechnique<Scn, K, M, MaxLength>& merge() const noexcept {
    return merge_;
  }

  /// The two families for pixel `pixel` and the drawn light segments `lights`, as
  /// weights/mmis.hpp TechniqueFamily objects over paths (they reference *this, scene, lights).
  [[nodiscard]] auto sequential_family(const Scn& scene, std::uint32_t pixel) const noexcept {
    return UnconditionalFamily(sequential_count_, [this, &scene, q = PathQuery{pixel, length_}](
                                                      const Path& path) noexcept {
      return sequential_.pdf(scene, q, path);
    });
  }
  [[nodiscard]] auto merge_family(const Scn& scene, std::uint32_t pixel,
                                  std::span<const Segment<T>> lights) const noexcept {
    return ConditionalFamily(lights, [this, &scene, q = PathQuery{pixel, length_}](
                                         const Path& path, const Segment<T>& light) noexcept {
      return merge_.pdf(scene, q, path, light);
    });
  }

  /// One sample of (N42) for pixel q.pixel: one sink.add of the sum over all drawn paths, or
  /// sink.drop for a non-finite sum or a path drawn through an unshared Dirac.
  template <UniformSource<T> R, ContributionSink<S> Sink>
  void estimate(const Scn& scene, const EstimateQuery& q, R& rng, Sink& sink) const noexcept {
    std::array<Segment<T>, MaxLightSamples> lights{};
    std::size_t drawn_lights = 0;
    for (std::size_t j = 0; j < light_count_; ++j) {
      const auto l = light_start_.sample(scene, {}, rng);
      // A failed draw is a technique sample that produces no path and has density 0 everywhere.
      if (l && !l->delta) lights[drawn_lights++] = l->segment;
    }
    const std::span<const Segment<T>> pool(lights.data(), drawn_lights);
    const auto seq_family = sequential_family(scene, q.pixel);
    const auto light_family = merge_family(scene, q.pixel, pool);
    const PathQuery pq{q.pixel, length_};
    S total = S(T(0));
    bool delta = false;
    auto add_path = [&](const std::optional<PathSample<T, MaxLength>>& drawn) {
      if (!drawn) return;
      if (drawn->delta) {
        delta = true;
        return;
      }
      const auto g = path_contribution(scene, kernel_, drawn->path);
      if (!g || g->pixel != q.pixel || is_black(g->value)) return;
      total += mmis_contribution(g->value, mmis_denominator(drawn->path, seq_family, light_family));
    };
    for (std::size_t j = 0; j < sequential_count_; ++j)
      add_path(sequential_.sample(scene, pq, rng));
    for (const Segment<T>& light : pool) add_path(merge_.sample(scene, pq, light, rng));
    if (delta) {
      sink.drop(DropReason::zero_density);
      return;
    }
    if (!is_finite(total)) {
      sink.drop(DropReason::non_finite);
      return;
    }
    sink.add(q.pixel, total);
  }

 private:
  K kernel_;
  LightStartSampler<Scn> light_start_;
  SequentialPathTechnique<Scn, K, MaxLength> sequential_;
  LightMergePathTechnique<Scn, K, M, MaxLength> merge_;
  std::size_t length_;
  std::size_t sequential_count_;
  std::size_t light_count_;
};

}  // namespace segpath
