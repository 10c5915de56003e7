// One emitter chosen at run time among several types (std::variant, no virtual calls): a
// renderer loading scenes of different kinds keeps one scene type, so every algorithm is
// instantiated once. The switch per call is the only cost.
#pragma once

#include "segpath/concepts/emitter.hpp"

#include <optional>
#include <utility>
#include <variant>

namespace segpath {

/// Models SampledEmitter<EmitterVariant, S> when every alternative does.
template <Spectrum S, class... Es>
  requires(sizeof...(Es) > 0)
class EmitterVariant {
 public:
  using Scalar = spectrum_scalar_t<S>;

  template <class E>
    requires(std::same_as<std::remove_cvref_t<E>, Es> || ...)
  EmitterVariant(E&& emitter) : emitter_(std::forward<E>(emitter)) {}  // NOLINT: implicit by design

  [[nodiscard]] S radiance(const EmissionQuery<Scalar>& q) const noexcept {
    return std::visit([&](const auto& e) -> S { return e.radiance(q); }, emitter_);
  }
  [[nodiscard]] std::optional<EmissionSample<S>> sample_emission(const EmissionSampleQuery<Scalar>& q) const noexcept {
    return std::visit([&](const auto& e) { return e.sample_emission(q); }, emitter_);
  }
  [[nodiscard]] EmissionPdf<Scalar> pdf_emission(const EmissionPdfQuery<Scalar>& q) const noexcept {
    return std::visit([&](const auto& e) { return e.pdf_emission(q); }, emitter_);
  }
  [[nodiscard]] std::optional<EmitterTowardsSample<S>> sample_towards(const EmitterTowardsQuery<Scalar>& q) const noexcept {
    return std::visit([&](const auto& e) { return e.sample_towards(q); }, emitter_);
  }
  [[nodiscard]] Scalar pdf_towards(const EmitterPdfTowardsQuery<Scalar>& q) const noexcept {
    return std::visit([&](const auto& e) -> Scalar { return e.pdf_towards(q); }, emitter_);
  }

  [[nodiscard]] const std::variant<Es...>& get() const noexcept { return emitter_; }

 private:
  std::variant<Es...> emitter_;
};

}  // namespace segpath
