// Shared by the renderer benchmarks: a scene wrapper that observes every ray the path tracer
// casts (counting or recording them), and one PT iteration over an image on 2 threads.
#pragma once

#include <renderer/cornell.hpp>
#include <segpath/algorithms/path_tracer.hpp>
#include <segpath/core/rng.hpp>

#include <cstdint>
#include <optional>
#include <thread>
#include <vector>

namespace bench {

using renderer::Color;
using renderer::T;

/// The emitter of a RenderScene by reference (PathTracer copies scene.emitter() once per
/// path; a view keeps the triangle tables from being copied).
class EmitterView {
 public:
  explicit EmitterView(const renderer::Emitter& e) noexcept : e_(&e) {}
  [[nodiscard]] Color radiance(const segpath::EmissionQuery<T>& q) const noexcept { return e_->radiance(q); }
  [[nodiscard]] std::optional<segpath::EmissionSample<Color>> sample_emission(
      const segpath::EmissionSampleQuery<T>& q) const noexcept {
    return e_->sample_emission(q);
  }
  [[nodiscard]] segpath::EmissionPdf<T> pdf_emission(const segpath::EmissionPdfQuery<T>& q) const noexcept {
    return e_->pdf_emission(q);
  }
  [[nodiscard]] std::optional<segpath::EmitterTowardsSample<Color>> sample_towards(
      const segpath::EmitterTowardsQuery<T>& q) const noexcept {
    return e_->sample_towards(q);
  }
  [[nodiscard]] T pdf_towards(const segpath::EmitterPdfTowardsQuery<T>& q) const noexcept {
    return e_->pdf_towards(q);
  }

 private:
  const renderer::Emitter* e_;
};

/// A RenderScene whose intersect and visible calls are first shown to `observer`
/// (observer.intersect(q), observer.visible(q)); one wrapper and observer per thread.
/// `ByView`: emitter() returns an EmitterView, else the RenderScene's emitter itself.
template <class Observer, bool ByView = true>
class ObservedScene {
 public:
  using Scalar = T;
  using Spectrum = Color;

  ObservedScene(const renderer::RenderScene& scene, Observer& observer) noexcept
      : scene_(&scene), observer_(&observer) {}

  [[nodiscard]] T area() const noexcept { return scene_->area(); }
  [[nodiscard]] std::optional<segpath::AreaSample<T>> sample_area(const segpath::AreaSampleQuery<T>& q) const noexcept {
    return scene_->sample_area(q);
  }
  [[nodiscard]] std::optional<segpath::Hit<T>> intersect(const segpath::IntersectQuery<T>& q) const noexcept {
    observer_->intersect(q);
    return scene_->intersect(q);
  }
  [[nodiscard]] bool visible(const segpath::VisibilityQuery<T>& q) const noexcept {
    observer_->visible(q);
    return scene_->visible(q);
  }
  [[nodiscard]] const segpath::MaterialSet<Color>& bsdf() const noexcept { return scene_->bsdf(); }
  [[nodiscard]] decltype(auto) emitter() const noexcept {
    if constexpr (ByView) {
      return EmitterView(scene_->emitter());
    } else {
      return static_cast<const renderer::Emitter&>(scene_->emitter());
    }
  }
  [[nodiscard]] const segpath::PinholeCamera<T>& sensor() const noexcept { return scene_->sensor(); }

 private:
  const renderer::RenderScene* scene_;
  Observer* observer_;
};

struct RayCounter {
  std::uint64_t rays = 0;
  void intersect(const segpath::IntersectQuery<T>&) noexcept { ++rays; }
  void visible(const segpath::VisibilityQuery<T>&) noexcept { ++rays; }
};

/// Adds each path's value to its pixel of a float image.
struct ImageSink {
  Color* image;
  std::uint64_t drops = 0;
  void add(std::uint32_t pixel, const Color& v) noexcept { image[pixel] += v; }
  void drop(segpath::DropReason) noexcept { ++drops; }
};

/// One PT iteration (one path per pixel, pixel p drawing from Pcg32::for_sample(1, p,
/// iteration)) on `threads` threads, rows interleaved (thread t renders rows t, t + threads,
/// ...). observers[t] is thread t's observer. Returns the number of dropped paths.
template <class Observer, bool ByView = true>
std::uint64_t pt_iteration(const renderer::RenderScene& scene,
                           const segpath::PathTracer<ObservedScene<Observer, ByView>>& pt, std::uint64_t iteration,
                           std::vector<Observer>& observers, std::vector<Color>& image) {
  const auto& camera = scene.sensor();
  const std::uint32_t width = camera.width(), height = camera.height();
  const auto threads = static_cast<std::uint32_t>(observers.size());
  std::vector<std::uint64_t> drops(threads, 0);
  auto work = [&](std::uint32_t t) {
    const ObservedScene<Observer, ByView> observed(scene, observers[t]);
    ImageSink sink{image.data()};
    for (std::uint32_t y = t; y < height; y += threads)
      for (std::uint32_t x = 0; x < width; ++x) {
        const std::uint32_t pixel = y * width + x;
        segpath::Pcg32 rng = segpath::Pcg32::for_sample(1, pixel, iteration);
        pt.estimate(observed, {pixel, iteration}, rng, sink);
      }
    drops[t] = sink.drops;
  };
  std::vector<std::thread> pool;
  for (std::uint32_t t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& thread : pool) thread.join();
  std::uint64_t total = 0;
  for (auto d : drops) total += d;
  return total;
}

}  // namespace bench
