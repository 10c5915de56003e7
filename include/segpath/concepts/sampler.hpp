// The SegmentSampler concept: draws one segment conditioned on a technique parameter t and
// evaluates the conditional density p(s | t) of *any* segment (SPEC 1.6; MMIS needs the
// density of segments the sampler did not draw, N39-N42), with and without the visibility
// factor. Customization points: Smp::Technique, Smp::is_dirac, sample(scene, t, rng),
// pdf(scene, t, s), unoccluded_pdf(scene, t, s).
#pragma once

#include "segpath/concepts/manifold.hpp"
#include "segpath/core/rng.hpp"
#include "segpath/core/segment.hpp"
#include "segpath/core/spectrum.hpp"

#include <concepts>
#include <optional>

namespace segpath {

/// A drawn segment with its conditional density and the integrand factor it carries.
/// `pdf` is in the product measure of its two endpoints (area for surface points, discrete
/// for point endpoints, solid angle at direction endpoints). `factor` is the part of (N17)
/// this segment brings: W_rho G(s_1) for a sensor-start segment, K f_r G(s') for a
/// successor, L_e G for a light-start segment, G(s) for an unconditional sampler. Where
/// the sample went through a Dirac delta (specular BSDF, Dirac kernel, pinhole), factor and
/// pdf are the coefficients of the same delta.
template <class S>
struct SegmentSample {
  using Scalar = spectrum_scalar_t<S>;
  Segment<Scalar> segment;
  Vec3<Scalar> direction{};  ///< unit s^ of `segment`, as the sampler computed it
  S factor{};
  Scalar pdf = 0;
  /// factor / pdf with the common factors cancelled analytically (for a ray-traced successor
  /// K/p_K f_r |n_x . s^| / p_w: the |n_y . s^| / d^2 shared by G and the density drops out).
  /// Sequential estimators multiply by it; it is finite whenever pdf > 0.
  S weight{};
  bool delta = false;  ///< drawn through a Dirac: a specular BSDF lobe, or a Dirac light end
};

namespace detail {
template <class Smp>
concept HasTechnique = requires { typename Smp::Technique; };
template <class Smp>
concept HasSamplerIsDirac = requires {
  { Smp::is_dirac } -> std::convertible_to<bool>;
};
template <class Smp, class Scn>
concept HasSegmentSample = requires(const Smp& smp, const Scn& scene,
                                    const typename Smp::Technique& t, Pcg32& rng) {
  { smp.sample(scene, t, rng) } ->
      std::same_as<std::optional<SegmentSample<typename Scn::Spectrum>>>;
};
template <class Smp, class Scn>
concept HasSegmentPdf = requires(const Smp& smp, const Scn& scene,
                                 const typename Smp::Technique& t,
                                 const Segment<typename Scn::Scalar>& s) {
  { smp.pdf(scene, t, s) } -> std::convertible_to<typename Scn::Scalar>;
};
template <class Smp, class Scn>
concept HasUnoccludedPdf = requires(const Smp& smp, const Scn& scene,
                                    const typename Smp::Technique& t,
                                    const Segment<typename Scn::Scalar>& s) {
  { smp.unoccluded_pdf(scene, t, s) } -> std::convertible_to<typename Scn::Scalar>;
};
}  // namespace detail

/// A segment sampler for scenes of type Scn. Syntactic requirements:
///  1. `Smp::Technique` is the technique parameter t (the conditioning data: a pixel, a
///     previous segment, a pair of subpath ends; an empty struct for unconditional ones);
///  2. `Smp::is_dirac` says whether the sampler's density has a Dirac component (then
///     pdf of a segment it did not draw itself is 0);
///  3. `smp.sample(scene, t, rng)` returns std::optional<SegmentSample<Scn::Spectrum>>;
///  4. `smp.pdf(scene, t, s)` returns p(s | t) for any segment s;
///  5. `smp.unoccluded_pdf(scene, t, s)` returns p(s | t) for any segment s as if its two
///     ends saw each other: the density with the visibility factor V(s) left out.
/// Semantic requirements:
///  6. pdf(scene, t, sample(scene, t, rng)->segment) equals the sample's pdf;
///  7. p(. | t) integrates to 1 over segments, or to the probability that sample succeeds;
///  8. a returned sample has pdf > 0 and finite endpoints; failures return nullopt;
///  9. pdf(scene, t, s) == unoccluded_pdf(scene, t, s) * V(s), V(s) = 1 if
///     scene.visible({s.x, s.y}) and 0 otherwise, for every sampler whose draws are
///     conditioned on visibility; pdf == unoccluded_pdf for one that also draws occluded
///     segments (the uniform sampler, N26). Either way the two agree on visible segments.
///     What "unoccluded" means depends on how the sampler reaches y:
///      - a *ray-traced* sampler (N27, N28, N29-N31, N33: y is the first hit along a drawn
///        direction) draws s with density unoccluded_pdf(s) given that y is the first hit
///        from x, i.e. the density of the direction draw turned into y's measure; V is the
///        first-hit indicator, which scene.visible({x, y}) reports (for a `direction` y:
///        that the ray escapes);
///      - a *connecting* sampler (N34 bridges: both ends drawn, then a visibility test)
///        draws the ends with density unoccluded_pdf(s) and rejects the pair unless V(s).
///     unoccluded_pdf never queries visibility; pdf fires at most one visibility ray, and
///     only where unoccluded_pdf is not 0 (visibility_masked below).
/// Why a second member and not a flag on pdf: callers that already know V (segment
/// filtering pools segments that were traced, so visible by construction; MMIS over
/// such pools) call unoccluded_pdf and fire no ray; every other caller keeps pdf, whose
/// signature, meaning and numbers are unchanged. A flag would change pdf's signature for
/// every model and caller, put a runtime branch in every density, and a model that ignored
/// the flag would still compile; a member is a compile-time choice that the concept check
/// names when it is missing (detail::HasUnoccludedPdf).
template <class Smp, class Scn>
concept SegmentSampler = detail::HasTechnique<Smp> && detail::HasSamplerIsDirac<Smp> &&
                         detail::HasSegmentSample<Smp, Scn> && detail::HasSegmentPdf<Smp, Scn> &&
                         detail::HasUnoccludedPdf<Smp, Scn>;

/// pdf from unoccluded_pdf (requirement 9): `unoccluded` times V(s.x, s.y), the visibility ray
/// fired only where `unoccluded` is not 0 (a zero density needs no ray).
template <class Scn, Real T>
[[nodiscard]] SEGPATH_FORCE_INLINE T visibility_masked(const Scn& scene, const Segment<T>& s, T unoccluded) noexcept {
  if (unoccluded == T(0)) return unoccluded;
  return scene.visible(VisibilityQuery<T>{s.x, s.y}) ? unoccluded : T(0);
}

}  // namespace segpath
