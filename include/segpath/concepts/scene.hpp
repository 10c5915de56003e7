// The Scene concept: a Manifold plus the radiometry estimators need: a material model
// (bsdf()), emission (emitter()) and a sensor (sensor()).
// Customization points: S::Spectrum, bsdf(), emitter(), sensor(), and those of Manifold.
#pragma once

#include "segpath/concepts/bsdf.hpp"
#include "segpath/concepts/emitter.hpp"
#include "segpath/concepts/manifold.hpp"
#include "segpath/concepts/sensor.hpp"

#include <type_traits>

namespace segpath {

namespace detail {
template <class S>
concept HasSpectrum = requires { typename S::Spectrum; } && Spectrum<typename S::Spectrum> &&
                      std::same_as<spectrum_scalar_t<typename S::Spectrum>, typename S::Scalar>;
template <class S>
concept HasSceneBsdf = requires(const S& s) { s.bsdf(); } &&
    Bsdf<std::remove_cvref_t<decltype(std::declval<const S&>().bsdf())>, typename S::Spectrum>;
template <class S>
concept HasSceneEmitter = requires(const S& s) { s.emitter(); } &&
    Emitter<std::remove_cvref_t<decltype(std::declval<const S&>().emitter())>, typename S::Spectrum>;
template <class S>
concept HasSceneSensor = requires(const S& s) { s.sensor(); } &&
    Sensor<std::remove_cvref_t<decltype(std::declval<const S&>().sensor())>, typename S::Scalar>;
template <class S>
concept HasSampledEmitter = requires(const S& s) { s.emitter(); } &&
    SampledEmitter<std::remove_cvref_t<decltype(std::declval<const S&>().emitter())>,
                   typename S::Spectrum>;
}  // namespace detail

/// A scene segpath can render. Syntactic requirements:
///  1. S models Manifold;
///  2. `S::Spectrum` models Spectrum with scalar S::Scalar;
///  3. `s.bsdf()` returns a Bsdf for S::Spectrum (it dispatches on the point's material id);
///  4. `s.emitter()` returns an Emitter for S::Spectrum (L_e at points of M);
///  5. `s.sensor()` returns a Sensor.
/// Semantic requirements: those of each concept; the bsdf, emitter and sensor stay valid
/// while the scene lives.
template <class S>
concept Scene = Manifold<S> && detail::HasSpectrum<S> && detail::HasSceneBsdf<S> &&
                detail::HasSceneEmitter<S> && detail::HasSceneSensor<S>;

/// A Scene whose emitter can be sampled (light tracing, next-event estimation, bridges).
template <class S>
concept LightSampledScene = Scene<S> && detail::HasSampledEmitter<S>;

template <Scene S> using scene_scalar_t = typename S::Scalar;
template <Scene S> using scene_spectrum_t = typename S::Spectrum;

}  // namespace segpath
