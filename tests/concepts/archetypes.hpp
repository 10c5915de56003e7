// Archetypes: for every segpath concept, a type with exactly the members the concept's
// documentation lists and trivial bodies, proving that the documented minimum is enough.
#pragma once

#include <cstdint>
#include <optional>
#include <segpath/concepts/concepts.hpp>
#include <segpath/core/spectrum.hpp>

namespace segpath::archetypes {

/// Spectrum (core/spectrum.hpp, points 1-3): a regular type built from a scalar, closed
/// under the four operations, with the four queries found by argument-dependent lookup.
template <Real T>
struct SpectrumArchetype {
  SpectrumArchetype() = default;
  constexpr explicit SpectrumArchetype(T) noexcept {}

  constexpr SpectrumArchetype& operator+=(const SpectrumArchetype&) noexcept { return *this; }
  friend constexpr SpectrumArchetype operator+(SpectrumArchetype a,
                                               const SpectrumArchetype&) noexcept {
    return a;
  }
  friend constexpr SpectrumArchetype operator*(SpectrumArchetype a,
                                               const SpectrumArchetype&) noexcept {
    return a;
  }
  friend constexpr SpectrumArchetype operator*(SpectrumArchetype a, T) noexcept { return a; }
  friend constexpr SpectrumArchetype operator/(SpectrumArchetype a, T) noexcept { return a; }
  friend constexpr bool operator==(const SpectrumArchetype&,
                                   const SpectrumArchetype&) noexcept = default;

  friend constexpr T max_component(const SpectrumArchetype&) noexcept { return T(0); }
  friend constexpr T average(const SpectrumArchetype&) noexcept { return T(0); }
  friend constexpr bool is_finite(const SpectrumArchetype&) noexcept { return true; }
  friend constexpr bool is_black(const SpectrumArchetype&) noexcept { return true; }
};

}  // namespace segpath::archetypes

namespace segpath {
template <Real T>
struct spectrum_scalar<archetypes::SpectrumArchetype<T>> {
  using type = T;
};
}  // namespace segpath

namespace segpath::archetypes {

/// Manifold, points 1-5.
template <Real T>
struct ManifoldArchetype {
  using Scalar = T;

  [[nodiscard]] T area() const noexcept { return T(1); }
  [[nodiscard]] std::optional<AreaSample<T>> sample_area(const AreaSampleQuery<T>&) const noexcept {
    return std::nullopt;
  }
  [[nodiscard]] std::optional<Hit<T>> intersect(const IntersectQuery<T>&) const noexcept {
    return std::nullopt;
  }
  [[nodiscard]] bool visible(const VisibilityQuery<T>&) const noexcept { return true; }
};

/// Bsdf, points 1-3. eval is 1 so that contributions through it are easy to predict.
template <Spectrum S>
struct BsdfArchetype {
  [[nodiscard]] S eval(const BsdfQuery<spectrum_scalar_t<S>>&) const noexcept {
    return S(spectrum_scalar_t<S>(1));
  }
  [[nodiscard]] std::optional<BsdfSample<S>> sample(
      const BsdfSampleQuery<spectrum_scalar_t<S>>&) const noexcept {
    return std::nullopt;
  }
  [[nodiscard]] spectrum_scalar_t<S> pdf(const BsdfQuery<spectrum_scalar_t<S>>&) const noexcept {
    return spectrum_scalar_t<S>(0);
  }
};

/// Emitter, point 1. Emits 1 everywhere.
template <Spectrum S>
struct EmitterArchetype {
  [[nodiscard]] S radiance(const EmissionQuery<spectrum_scalar_t<S>>&) const noexcept {
    return S(spectrum_scalar_t<S>(1));
  }
};

/// SampledEmitter: Emitter's point 1 plus points 1-4 of SampledEmitter.
template <Spectrum S>
struct SampledEmitterArchetype {
  [[nodiscard]] S radiance(const EmissionQuery<spectrum_scalar_t<S>>&) const noexcept {
    return S(spectrum_scalar_t<S>(1));
  }
  [[nodiscard]] std::optional<EmissionSample<S>> sample_emission(
      const EmissionSampleQuery<spectrum_scalar_t<S>>&) const noexcept {
    return std::nullopt;
  }
  [[nodiscard]] EmissionPdf<spectrum_scalar_t<S>> pdf_emission(
      const EmissionPdfQuery<spectrum_scalar_t<S>>&) const noexcept {
    return {};
  }
  [[nodiscard]] std::optional<EmitterTowardsSample<S>> sample_towards(
      const EmitterTowardsQuery<spectrum_scalar_t<S>>&) const noexcept {
    return std::nullopt;
  }
  [[nodiscard]] spectrum_scalar_t<S> pdf_towards(
      const EmitterPdfTowardsQuery<spectrum_scalar_t<S>>&) const noexcept {
    return spectrum_scalar_t<S>(0);
  }
};

/// Sensor, points 1-4. One pixel that sees every ray with importance 1.
template <Real T>
struct SensorArchetype {
  [[nodiscard]] std::uint32_t pixel_count() const noexcept { return 1; }
  [[nodiscard]] std::optional<SensorSample<T>> sample_ray(
      const SensorSampleQuery<T>&) const noexcept {
    return std::nullopt;
  }
  [[nodiscard]] std::optional<SensorResponse<T>> importance(const SensorQuery<T>&) const noexcept {
    return SensorResponse<T>{0, T(1)};
  }
  [[nodiscard]] SensorPdf<T> pdf(const SensorQuery<T>&) const noexcept { return {}; }
};

/// Kernel, points 1-6.
template <Real T>
struct KernelArchetype {
  using Scalar = T;
  static constexpr bool is_dirac = false;

  [[nodiscard]] T eval(const KernelQuery<T>&) const noexcept { return T(0); }
  [[nodiscard]] std::optional<KernelSample<T>> sample(const KernelSampleQuery<T>&) const noexcept {
    return std::nullopt;
  }
  [[nodiscard]] T pdf(const KernelQuery<T>&) const noexcept { return T(0); }
  [[nodiscard]] T support_radius(const KernelSupportQuery<T>&) const noexcept { return T(0); }
};

/// Scene, points 1-5: the Manifold archetype plus a spectrum, a BSDF, an emitter (sampled
/// by default, so the scene also models LightSampledScene) and a sensor.
template <Real T, Spectrum S = T, class E = SampledEmitterArchetype<S>>
struct SceneArchetype : ManifoldArchetype<T> {
  using Spectrum = S;

  [[nodiscard]] BsdfArchetype<S> bsdf() const noexcept { return {}; }
  [[nodiscard]] E emitter() const noexcept { return {}; }
  [[nodiscard]] SensorArchetype<T> sensor() const noexcept { return {}; }
};

/// SegmentSampler, points 1-5, for any Scene.
struct SegmentSamplerArchetype {
  struct Technique {};
  static constexpr bool is_dirac = false;

  template <Scene Scn>
  [[nodiscard]] std::optional<SegmentSample<scene_spectrum_t<Scn>>> sample(const Scn&,
                                                                           const Technique&,
                                                                           Pcg32&) const noexcept {
    return std::nullopt;
  }
  template <Scene Scn>
  [[nodiscard]] scene_scalar_t<Scn> pdf(const Scn&, const Technique&,
                                        const Segment<scene_scalar_t<Scn>>&) const noexcept {
    return scene_scalar_t<Scn>(0);
  }
  template <Scene Scn>
  [[nodiscard]] scene_scalar_t<Scn> unoccluded_pdf(const Scn&, const Technique&,
                                                   const Segment<scene_scalar_t<Scn>>&) const noexcept {
    return scene_scalar_t<Scn>(0);
  }
};

/// ContributionSink: add and drop.
template <class S>
struct ContributionSinkArchetype {
  void add(std::uint32_t, const S&) noexcept {}
  void drop(DropReason) noexcept {}
};

/// Estimator, point 1: accepts any ContributionSink of the scene's spectrum. It adds one
/// black contribution to the queried pixel.
struct EstimatorArchetype {
  template <Scene Scn, ContributionSink<scene_spectrum_t<Scn>> Sink>
  void estimate(const Scn&, const EstimateQuery& q, Pcg32&, Sink& sink) const noexcept {
    sink.add(q.pixel, scene_spectrum_t<Scn>(scene_scalar_t<Scn>(0)));
  }
};

}  // namespace segpath::archetypes

// Each archetype models its concept, for float and double and for every spectrum type.
namespace segpath::archetypes::checks {

template <Real T, class S>
constexpr bool models_all() {
  static_assert(Spectrum<S>);
  static_assert(Manifold<ManifoldArchetype<T>>);
  static_assert(Bsdf<BsdfArchetype<S>, S>);
  static_assert(Emitter<EmitterArchetype<S>, S>);
  static_assert(Emitter<SampledEmitterArchetype<S>, S>);
  static_assert(SampledEmitter<SampledEmitterArchetype<S>, S>);
  static_assert(Sensor<SensorArchetype<T>, T>);
  static_assert(Kernel<KernelArchetype<T>>);
  static_assert(Scene<SceneArchetype<T, S>>);
  static_assert(LightSampledScene<SceneArchetype<T, S>>);
  static_assert(Scene<SceneArchetype<T, S, EmitterArchetype<S>>>);
  static_assert(SegmentSampler<SegmentSamplerArchetype, SceneArchetype<T, S>>);
  static_assert(ContributionSink<ContributionSinkArchetype<S>, S>);
  static_assert(ContributionSink<detail::SinkArchetype<S>, S>);
  static_assert(Estimator<EstimatorArchetype, SceneArchetype<T, S>>);
  return true;
}

static_assert(Spectrum<SpectrumArchetype<float>> && Spectrum<SpectrumArchetype<double>>);
static_assert(models_all<float, float>());
static_assert(models_all<float, Rgb<float>>());
static_assert(models_all<float, SpectrumArchetype<float>>());
static_assert(models_all<double, double>());
static_assert(models_all<double, Rgb<double>>());
static_assert(models_all<double, SpectrumArchetype<double>>());

}  // namespace segpath::archetypes::checks
