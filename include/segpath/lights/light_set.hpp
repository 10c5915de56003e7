// A union of emitters of different types (a std::tuple, no virtual calls), one chosen
// uniformly per sample with its probability folded into every density (N30, N34).
#pragma once

#include <algorithm>
#include <cstddef>
#include <limits>
#include <optional>
#include <tuple>
#include <type_traits>
#include <utility>

#include "segpath/concepts/emitter.hpp"

namespace segpath {

namespace detail {

/// The spectrum an emitter's samples carry (the S of EmitterTowardsSample<S>).
template <class E>
using emitter_spectrum_t = std::remove_cvref_t<
    decltype(std::declval<const E&>()
                 .sample_towards(std::declval<const EmitterTowardsQuery<typename E::Scalar>&>())
                 ->radiance)>;

/// Whether E declares its light ends to be deltas (`static constexpr bool is_delta = true`,
/// e.g. DirectionalLight).
template <class E>
constexpr bool emitter_is_delta() noexcept {
  if constexpr (requires { E::is_delta; }) {
    return static_cast<bool>(E::is_delta);
  } else {
    return false;
  }
}

}  // namespace detail

/// Several emitters as one SampledEmitter; each sample picks member i = floor(n u_select)
/// with probability 1/n ("lights are chosen uniformly", cornell-boxes.md) and hands it the
/// rescaled u_select n - i, so members that select among their own parts (TriangleLights)
/// get a fresh uniform.
///
/// Ownership. Every endpoint is evaluated by one member, its owner: the first member with
/// `is_delta` whose pdf_emission(point).position > 0, else the first member whose
/// pdf_emission(point).position > 0 (point lights and directional lights own only their own
/// point, triangle lights their primitive ids, a background every direction endpoint). So a
/// DirectionalLight and a BackgroundLight can share a set: the sun's endpoint belongs to the
/// sun. Members should otherwise have disjoint supports (e.g. distinct primitive ids); an
/// endpoint claimed by two non-delta members is evaluated by the first only.
/// radiance() is the owner's radiance; pdf_towards() and pdf_emission().position are the
/// owner's densities times 1/n, and a sample from member i reports member i's densities
/// times 1/n, which are the same numbers when member i owns the point it drew.
template <class... Es>
  requires(sizeof...(Es) > 0)
class LightSet {
  using First = std::tuple_element_t<0, std::tuple<Es...>>;

 public:
  using Spectrum = detail::emitter_spectrum_t<First>;
  using Scalar = spectrum_scalar_t<Spectrum>;
  static_assert(
      (SampledEmitter<Es, Spectrum> && ...),
      "segpath::LightSet: every member must model SampledEmitter for the first member's spectrum");
  static constexpr std::size_t size = sizeof...(Es);

  explicit LightSet(Es... emitters) : emitters_(std::move(emitters)...) {}

  template <std::size_t I>
  [[nodiscard]] const auto& get() const noexcept {
    return std::get<I>(emitters_);
  }

  /// The owner's radiance, 0 where no member owns the point.
  [[nodiscard]] Spectrum radiance(const EmissionQuery<Scalar>& q) const noexcept {
    Spectrum out(Scalar(0));
    dispatch(owner(q.point), [&](const auto& e) { out = e.radiance(q); });
    return out;
  }

  [[nodiscard]] std::optional<EmissionSample<Spectrum>> sample_emission(
      const EmissionSampleQuery<Scalar>& q) const noexcept {
    std::optional<EmissionSample<Spectrum>> out;
    const auto [i, u_select] = select(q.u_select);
    dispatch(i, [&](const auto& e) {
      out = e.sample_emission(EmissionSampleQuery<Scalar>{q.u_position, q.u_direction, u_select});
      if (out) out->pdf_position *= inv_size;
    });
    return out;
  }

  [[nodiscard]] EmissionPdf<Scalar> pdf_emission(const EmissionPdfQuery<Scalar>& q) const noexcept {
    EmissionPdf<Scalar> out{};
    dispatch(owner(q.point), [&](const auto& e) {
      out = e.pdf_emission(q);
      out.position *= inv_size;
    });
    return out;
  }

  [[nodiscard]] std::optional<EmitterTowardsSample<Spectrum>> sample_towards(
      const EmitterTowardsQuery<Scalar>& q) const noexcept {
    std::optional<EmitterTowardsSample<Spectrum>> out;
    const auto [i, u_select] = select(q.u_select);
    dispatch(i, [&](const auto& e) {
      out = e.sample_towards(EmitterTowardsQuery<Scalar>{q.receiver, q.u, u_select});
      if (out) out->pdf *= inv_size;
    });
    return out;
  }

  [[nodiscard]] Scalar pdf_towards(const EmitterPdfTowardsQuery<Scalar>& q) const noexcept {
    Scalar out = 0;
    dispatch(owner(q.point), [&](const auto& e) { out = e.pdf_towards(q) * inv_size; });
    return out;
  }

  /// The index of the member that owns `p` (see the class comment), or `size` if none does.
  [[nodiscard]] std::size_t owner(const SurfacePoint<Scalar>& p) const noexcept {
    const EmissionPdfQuery<Scalar> query{p, p.normal};
    std::size_t found = size;
    const auto claims = [&](const auto& e) { return e.pdf_emission(query).position > Scalar(0); };
    [&]<std::size_t... I>(std::index_sequence<I...>) {
      // Deltas first, then everyone, in member order; || stops at the first claim.
      (void)((detail::emitter_is_delta<Es>() && claims(std::get<I>(emitters_)) &&
              ((found = I), true)) ||
             ...);
      if (found == size) (void)((claims(std::get<I>(emitters_)) && ((found = I), true)) || ...);
    }(std::index_sequence_for<Es...>{});
    return found;
  }

 private:
  static constexpr Scalar inv_size = Scalar(1) / Scalar(sizeof...(Es));

  struct Selection {
    std::size_t index;
    Scalar u_select;
  };

  /// Member floor(n u) and the rescaled remainder n u - i, kept in [0, 1).
  [[nodiscard]] static Selection select(Scalar u) noexcept {
    const Scalar scaled = u * Scalar(size);
    const std::size_t i = std::min(static_cast<std::size_t>(std::max(scaled, Scalar(0))), size - 1);
    const Scalar rest = scaled - Scalar(i);
    return {i, std::clamp(rest, Scalar(0),
                          Scalar(1) - std::numeric_limits<Scalar>::epsilon() / Scalar(2))};
  }

  /// Calls f(member i); does nothing for i >= size.
  template <class F>
  void dispatch(std::size_t i, F&& f) const noexcept {
    [&]<std::size_t... I>(std::index_sequence<I...>) {
      (void)((i == I && (f(std::get<I>(emitters_)), true)) || ...);
    }(std::index_sequence_for<Es...>{});
  }

  std::tuple<Es...> emitters_;
};

template <class... Es>
LightSet(Es...) -> LightSet<Es...>;

}  // namespace segpath
