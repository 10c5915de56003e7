// The Bsdf concept: a material model evaluated, sampled and queried for its density at one
// surface point (the pbrt-style triple f / sample / pdf). Customization points:
//   eval(BsdfQuery), sample(BsdfSampleQuery), pdf(BsdfQuery).
#pragma once

#include "segpath/core/spectrum.hpp"
#include "segpath/core/surface_point.hpp"

#include <concepts>
#include <optional>

namespace segpath {

/// Which way a path is built. `radiance`: from the sensor, the direction towards the
/// sensor is fixed and the one towards the light is sampled. `importance`: from a light,
/// the reverse (adjoint transport).
enum class Transport : std::uint8_t { radiance, importance };

/// f_r at `point` for light arriving from `to_light` and leaving towards `to_sensor`
/// (both unit, pointing away from the point). In segment terms (N20), at y_i:
/// to_sensor = -s^_i and to_light = s^_{i+1}. `mode` says which direction a pdf query
/// treats as fixed (eval does not depend on it except for non-symmetric scattering such as
/// refraction, where it selects radiance or importance transport).
template <Real T>
struct BsdfQuery {
  const SurfacePoint<T>& point;
  Vec3<T> to_sensor;
  Vec3<T> to_light;
  Transport mode = Transport::radiance;
};

/// Sample the free direction given the fixed one: with mode radiance `fixed` is to_sensor
/// and the sample is to_light; with importance the reverse.
template <Real T>
struct BsdfSampleQuery {
  const SurfacePoint<T>& point;
  Vec3<T> fixed;
  Vec2<T> u;
  T u_lobe = 0;  ///< selects a lobe of a layered or mixed material
  Transport mode = Transport::radiance;
};

/// A sampled direction with f_r for it and the solid-angle density. For a delta lobe,
/// `value` and `pdf` are the coefficients of the same Dirac delta (pdf is the lobe
/// selection probability) and `delta` is set: eval and pdf of the same pair return 0.
template <class S>
struct BsdfSample {
  using Scalar = spectrum_scalar_t<S>;
  Vec3<Scalar> direction;
  S value{};
  Scalar pdf = 0;
  bool delta = false;
};

namespace detail {
template <class B, class S>
concept HasBsdfEval = requires(const B& b, const BsdfQuery<spectrum_scalar_t<S>>& q) {
  { b.eval(q) } -> std::convertible_to<S>;
};
template <class B, class S>
concept HasBsdfSample = requires(const B& b, const BsdfSampleQuery<spectrum_scalar_t<S>>& q) {
  { b.sample(q) } -> std::same_as<std::optional<BsdfSample<S>>>;
};
template <class B, class S>
concept HasBsdfPdf = requires(const B& b, const BsdfQuery<spectrum_scalar_t<S>>& q) {
  { b.pdf(q) } -> std::convertible_to<spectrum_scalar_t<S>>;
};
}  // namespace detail

/// A material model. Syntactic requirements, for spectrum type S:
///  1. `b.eval(BsdfQuery)` returns f_r as S;
///  2. `b.sample(BsdfSampleQuery)` returns std::optional<BsdfSample<S>>;
///  3. `b.pdf(BsdfQuery)` returns the solid-angle density of sampling the free direction.
/// Semantic requirements:
///  4. for a non-delta sample, value == eval and pdf == pdf() of the sampled pair;
///  5. integral of pdf over the sphere is 1, or the probability that sample succeeds;
///  6. eval(q).cos / pdf has mean <= 1 (energy conservation);
///  7. nothing non-finite is returned; a failed sample is nullopt.
template <class B, class S>
concept Bsdf = Spectrum<S> && detail::HasBsdfEval<B, S> && detail::HasBsdfSample<B, S> &&
               detail::HasBsdfPdf<B, S>;

/// Optional customization point: `b.lambertian_albedo(point)` returns the albedo when the BSDF
/// at `point` is Lambertian (eval = albedo / pi for both directions above the geometric
/// normal, sampled by cosine about the shading normal), nullopt otherwise. Propagation uses
/// it to factorise clusters (the MMIS sum and the transfer no longer depend on the incoming
/// segment); BSDFs without it are never factorised.
template <class B, class S>
concept HasLambertianAlbedo = requires(const B& b, const SurfacePoint<spectrum_scalar_t<S>>& p) {
  { b.lambertian_albedo(p) } -> std::same_as<std::optional<S>>;
};

/// Optional customization point: `b.is_delta(point)` is true where the BSDF at `point` has
/// delta lobes only (a mirror, smooth glass), so eval and pdf are 0 for every pair there: a
/// connection from it (next-event estimation) is zero and path tracing casts no shadow ray for
/// it. BSDFs without it are always connected.
template <class B, class S>
concept HasIsDelta = requires(const B& b, const SurfacePoint<spectrum_scalar_t<S>>& p) {
  { b.is_delta(p) } -> std::same_as<bool>;
};

/// Optional customization point: `b.scatters_from(point, w)` is false where the direction `w`
/// (unit, away from the point) lies on a side that the BSDF at `point` does not scatter: eval
/// and pdf are 0 for every pair that has `w` as either direction, in both Transport modes, and
/// sample with fixed `w` fails (a one-sided surface seen from behind, a black point). Light
/// arriving there goes nowhere, so filtering does not pool, and VCM does not store, a light
/// path's end there (the sun's and the sky's rays that hit the outside of a closed box). True
/// where unsure; BSDFs without it are taken to scatter from every side.
template <class B, class S>
concept HasScattersFrom = requires(const B& b, const SurfacePoint<spectrum_scalar_t<S>>& p,
                                   const Vec3<spectrum_scalar_t<S>>& w) {
  { b.scatters_from(p, w) } -> std::same_as<bool>;
};

/// Whether the BSDF at `point` may scatter light arriving from `w` (HasScattersFrom; true for
/// BSDFs without the customization point).
template <class S, class B>
[[nodiscard]] bool scatters_from(const B& bsdf, const SurfacePoint<spectrum_scalar_t<S>>& point,
                                 const Vec3<spectrum_scalar_t<S>>& w) noexcept {
  if constexpr (HasScattersFrom<B, S>)
    return bsdf.scatters_from(point, w);
  else
    return true;
}

}  // namespace segpath
