// The segment path contribution g_rho(s-bar) of (N17), factor by factor. Every estimator
// and every sampler that reports an integrand factor builds it from these functions.
#pragma once

#include "segpath/concepts/kernel.hpp"
#include "segpath/concepts/scene.hpp"
#include "segpath/core/geometry.hpp"

#include <cstddef>
#include <optional>

namespace segpath {

/// The translated segment BSDF f_r(s, s') of (N20): the BSDF at y of s, for the direction
/// back towards x (-s^) and the direction s'^ of the next segment, wherever s' starts.
template <Scene Scn>
[[nodiscard]] inline typename Scn::Spectrum segment_bsdf(const Scn& scene,
                                                         const Segment<typename Scn::Scalar>& s,
                                                         const Segment<typename Scn::Scalar>& next,
                                                         Transport mode = Transport::radiance) noexcept {
  using T = typename Scn::Scalar;
  return scene.bsdf().eval(BsdfQuery<T>{s.y, -s.direction(), next.direction(), mode});
}

/// K(s, s') f_r(s, s') G(s') of (N17) with f_r already known (e.g. from a BSDF sample,
/// which is how delta lobes enter). No visibility: the caller knows s' is unoccluded.
template <Spectrum S>
[[nodiscard]] SEGPATH_FORCE_INLINE S link_factor(spectrum_scalar_t<S> kernel_value, const S& bsdf_value,
                                                 spectrum_scalar_t<S> geometry) noexcept {
  return bsdf_value * (kernel_value * geometry);
}

/// K(s, s') f_r(s, s') G(s') of (N17), without visibility of s'.
template <Scene Scn, KernelOf<typename Scn::Scalar> K>
[[nodiscard]] inline typename Scn::Spectrum link_factor(const Scn& scene, const K& kernel,
                                                        const Segment<typename Scn::Scalar>& s,
                                                        const Segment<typename Scn::Scalar>& next) noexcept {
  using T = typename Scn::Scalar;
  const T k = kernel.eval(KernelQuery<T>{s, next});
  if (k == T(0)) return typename Scn::Spectrum(T(0));
  return link_factor(k, segment_bsdf(scene, s, next), geometry_term(next));
}

/// W_rho(s_1) G(s_1) of (N17): which pixel the first segment belongs to and its factor,
/// or nullopt when the sensor does not see along s_1. No visibility.
template <Scene Scn>
[[nodiscard]] inline std::optional<SensorResponse<typename Scn::Scalar>> sensor_factor(
    const Scn& scene, const Segment<typename Scn::Scalar>& first) noexcept {
  using T = typename Scn::Scalar;
  auto response = scene.sensor().importance(SensorQuery<T>{first.x, first.direction()});
  if (!response) return std::nullopt;
  response->importance *= geometry_term(first);
  return response;
}

/// L_e(s_k) of (N17): radiance emitted at y_k towards x_k.
template <Scene Scn>
[[nodiscard]] inline typename Scn::Spectrum emission_factor(const Scn& scene,
                                                            const Segment<typename Scn::Scalar>& last) noexcept {
  using T = typename Scn::Scalar;
  return scene.emitter().radiance(EmissionQuery<T>{last.y, -last.direction()});
}

/// L_e(s_k) for a segment whose unit direction s^ is already known.
template <Scene Scn>
[[nodiscard]] SEGPATH_FORCE_INLINE typename Scn::Spectrum emission_factor(
    const Scn& scene, const Segment<typename Scn::Scalar>& last,
    const Vec3<typename Scn::Scalar>& direction) noexcept {
  using T = typename Scn::Scalar;
  return scene.emitter().radiance(EmissionQuery<T>{last.y, -direction});
}

/// A pixel index and a value: what a full contribution evaluates to.
template <class S>
struct PixelValue {
  std::uint32_t pixel = 0;
  S value{};
};

/// g_rho(s-bar) of (N17) for a whole segment path, visibility included:
///   W(s_1) prod_i G(s_i) prod_i K(s_i, s_{i+1}) f_r(s_i, s_{i+1}) L_e(s_k).
/// Returns nullopt for an empty path or one the sensor does not see.
template <Scene Scn, KernelOf<typename Scn::Scalar> K, class Path>
[[nodiscard]] std::optional<PixelValue<typename Scn::Spectrum>> path_contribution(
    const Scn& scene, const K& kernel, const Path& path) noexcept {
  using T = typename Scn::Scalar;
  using S = typename Scn::Spectrum;
  if (path.size() == 0) return std::nullopt;
  const auto sensor = sensor_factor(scene, path[0]);
  if (!sensor) return std::nullopt;
  S value = S(sensor->importance);
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (!scene.visible(VisibilityQuery<T>{path[i].x, path[i].y})) return PixelValue<S>{sensor->pixel, S(T(0))};
    if (i + 1 < path.size()) value = value * link_factor(scene, kernel, path[i], path[i + 1]);
  }
  value = value * emission_factor(scene, path[path.size() - 1]);
  return PixelValue<S>{sensor->pixel, value};
}

}  // namespace segpath
