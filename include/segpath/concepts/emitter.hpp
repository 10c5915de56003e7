// The Emitter concept: emitted radiance L_e(s) and the samplers of light-side segment ends
// (N30) and of emitter points towards a receiver (bridge / next-event segments, N34).
// Customization points: radiance(EmissionQuery), sample_emission(EmissionSampleQuery),
//   pdf_emission(EmissionPdfQuery), sample_towards(EmitterTowardsQuery),
//   pdf_towards(EmitterPdfTowardsQuery).
#pragma once

#include "segpath/core/spectrum.hpp"
#include "segpath/core/surface_point.hpp"

#include <concepts>
#include <optional>

namespace segpath {

/// L_e at the light end y of a segment, towards the sensor end (`to_sensor` = -s^).
template <Real T>
struct EmissionQuery {
  const SurfacePoint<T>& point;
  Vec3<T> to_sensor;
};

template <Real T>
struct EmissionSampleQuery {
  Vec2<T> u_position;
  Vec2<T> u_direction;
  T u_select = 0;  ///< chooses one light among several
};

/// A light-end y_k and the direction light leaves it in (towards x_k). Densities: position
/// in area measure (discrete for `point` emitters, the selection probability folded in),
/// direction in solid angle. For `direction` emitters (distant lights, the sky) the roles
/// swap: `point` is the `direction` endpoint (its `position` holds the unit direction from
/// the scene towards the light), `pdf_position` is the solid-angle density of that direction
/// (1, a delta coefficient, for a sun), `direction` holds the ORIGIN of the emitted ray (a
/// point on a disk perpendicular to the travel direction, outside the scene's bounds) and
/// `pdf_direction` is the area density of that origin on the disk; the first hit x then has
/// area density pdf_position * pdf_direction * |n_x . d|. pdf_emission reads `direction`
/// the same way (any point on the ray).
template <class S>
struct EmissionSample {
  using Scalar = spectrum_scalar_t<S>;
  SurfacePoint<Scalar> point;
  Vec3<Scalar> direction;
  S radiance{};
  Scalar pdf_position = 0;
  Scalar pdf_direction = 0;
  /// The light end is a Dirac (a point light's position, the sun's direction): only light
  /// sampling can produce it, so MIS/MMIS give it full weight.
  bool delta = false;
};

template <Real T>
struct EmissionPdfQuery {
  const SurfacePoint<T>& point;
  Vec3<T> direction;
};

template <Real T>
struct EmissionPdf {
  T position = 0;
  T direction = 0;
};

/// Sample a light end for a given receiver (next-event estimation, light-end bridges).
template <Real T>
struct EmitterTowardsQuery {
  const SurfacePoint<T>& receiver;
  Vec2<T> u;
  T u_select = 0;
};

/// The light point, the radiance it sends to the receiver, and the density of the point
/// (area measure, discrete for `point` emitters, solid angle for `direction` emitters),
/// selection probability included.
template <class S>
struct EmitterTowardsSample {
  using Scalar = spectrum_scalar_t<S>;
  SurfacePoint<Scalar> point;
  S radiance{};
  Scalar pdf = 0;
  /// The light end is a Dirac in its measure (a point light, the sun): `pdf` is the delta's
  /// coefficient and no other technique (BSDF sampling) can produce this end, so MIS gives
  /// this sample full weight.
  bool delta = false;
};

template <Real T>
struct EmitterPdfTowardsQuery {
  const SurfacePoint<T>& receiver;
  const SurfacePoint<T>& point;
};

namespace detail {
template <class E, class S>
concept HasRadiance = requires(const E& e, const EmissionQuery<spectrum_scalar_t<S>>& q) {
  { e.radiance(q) } -> std::convertible_to<S>;
};
template <class E, class S>
concept HasSampleEmission = requires(const E& e, const EmissionSampleQuery<spectrum_scalar_t<S>>& q) {
  { e.sample_emission(q) } -> std::same_as<std::optional<EmissionSample<S>>>;
};
template <class E, class S>
concept HasPdfEmission = requires(const E& e, const EmissionPdfQuery<spectrum_scalar_t<S>>& q) {
  { e.pdf_emission(q) } -> std::same_as<EmissionPdf<spectrum_scalar_t<S>>>;
};
template <class E, class S>
concept HasSampleTowards = requires(const E& e, const EmitterTowardsQuery<spectrum_scalar_t<S>>& q) {
  { e.sample_towards(q) } -> std::same_as<std::optional<EmitterTowardsSample<S>>>;
};
template <class E, class S>
concept HasPdfTowards = requires(const E& e, const EmitterPdfTowardsQuery<spectrum_scalar_t<S>>& q) {
  { e.pdf_towards(q) } -> std::convertible_to<spectrum_scalar_t<S>>;
};
}  // namespace detail

/// Radiance emitted at segment light ends. Syntactic requirements, for spectrum S:
///  1. `e.radiance(EmissionQuery)` returns L_e as S.
/// Semantic requirements:
///  2. L_e is finite and >= 0; one-sided emitters return 0 behind their normal.
template <class E, class S>
concept Emitter = Spectrum<S> && detail::HasRadiance<E, S>;

/// An emitter that can also be sampled. Syntactic requirements (beyond Emitter):
///  1. `e.sample_emission(EmissionSampleQuery)` returns std::optional<EmissionSample<S>>;
///  2. `e.pdf_emission(EmissionPdfQuery)` returns its densities for a given end and direction;
///  3. `e.sample_towards(EmitterTowardsQuery)` returns std::optional<EmitterTowardsSample<S>>;
///  4. `e.pdf_towards(EmitterPdfTowardsQuery)` returns that sample's density.
/// Semantic requirements:
///  5. each pdf function returns exactly the density its sampler reported;
///  6. radiance of a sampled point and direction equals the sample's radiance.
template <class E, class S>
concept SampledEmitter = Emitter<E, S> && detail::HasSampleEmission<E, S> &&
                         detail::HasPdfEmission<E, S> && detail::HasSampleTowards<E, S> &&
                         detail::HasPdfTowards<E, S>;

}  // namespace segpath
