// Toy technique families on [0, 1] for the CMIS, SMIS and MMIS tests (SPEC 2, toy integrals):
// a continuous family of triangular densities whose mode is the technique t, with closed-form
// marginals, and integrands with closed-form integrals.
#pragma once

#include <cmath>
#include <numbers>
#include <segpath/core/rng.hpp>
#include <segpath/core/vec.hpp>

namespace weights_test {

using segpath::Real;

/// p(x | t): the triangular density on [0, 1] with mode t in [0, 1].
template <Real T>
[[nodiscard]] T triangle_pdf(T x, T t) noexcept {
  if (!(x > T(0) && x < T(1))) return T(0);
  return x < t ? T(2) * x / t : T(2) * (T(1) - x) / (T(1) - t);
}

/// X ~ p(x | t) by inverting the CDF x^2 / t (x < t), 1 - (1 - x)^2 / (1 - t) (x >= t).
template <Real T>
[[nodiscard]] T sample_triangle(T t, T u) noexcept {
  return u < t ? std::sqrt(u * t) : T(1) - std::sqrt((T(1) - u) * (T(1) - t));
}

/// The density p(t) over the technique space [0, 1]: uniform, or linear 2t.
enum class TechniquePrior { uniform, linear };

template <Real T>
[[nodiscard]] T technique_pdf(TechniquePrior d, T t) noexcept {
  if (!(t >= T(0) && t <= T(1))) return T(0);
  return d == TechniquePrior::uniform ? T(1) : T(2) * t;
}

template <Real T>
[[nodiscard]] T sample_technique(TechniquePrior d, T u) noexcept {
  return d == TechniquePrior::uniform ? u : std::sqrt(u);
}

/// The marginal p(x) = int_0^1 p(t) p(x | t) dt (N7): -2 [x ln x + (1 - x) ln(1 - x)] for the
/// uniform p(t), -4 (1 - x) ln(1 - x) for p(t) = 2t.
template <Real T>
[[nodiscard]] T triangle_marginal(TechniquePrior d, T x) noexcept {
  if (!(x > T(0) && x < T(1))) return T(0);
  const T a = (T(1) - x) * std::log1p(-x);
  return d == TechniquePrior::uniform ? T(-2) * (x * std::log(x) + a) : T(-4) * a;
}

/// A wrong marginal for the uniform p(t): int_0^{1/2} p(x | t) dt, as if half of the technique
/// space were missing from the denominator.
template <Real T>
[[nodiscard]] T triangle_half_marginal(T x) noexcept {
  if (!(x > T(0) && x < T(1))) return T(0);
  const T ln2 = std::numbers::ln2_v<T>;
  if (x > T(0.5)) return T(2) * (T(1) - x) * ln2;
  return T(-2) * (T(1) - x) * std::log1p(-x) - T(2) * x * (std::log(T(2) * x));
}

/// A bumpy integrand that vanishes at both ends (so f^2 / p stays integrable for the
/// triangular family): f(x) = x (1 - x) (1 + cos 4 pi x), int_0^1 f = 1/6 - 1/(8 pi^2).
template <Real T>
[[nodiscard]] T bumpy(T x) noexcept {
  return x * (T(1) - x) * (T(1) + std::cos(T(4) * std::numbers::pi_v<T> * x));
}
inline constexpr double bumpy_integral =
    1.0 / 6.0 - 1.0 / (8.0 * std::numbers::pi * std::numbers::pi);

template <Real T>
[[nodiscard]] T square(T x) noexcept {
  return x * x;
}

}  // namespace weights_test
