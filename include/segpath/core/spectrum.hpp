// Spectra: an RGB triple, and the scalar types as one-channel spectra (the analytic test
// scenes use them). Estimators use only the operations the Spectrum concept names.
#pragma once

#include "segpath/core/format.hpp"
#include "segpath/core/vec.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace segpath {

template <Real T>
struct Rgb {
  T r = 0, g = 0, b = 0;

  constexpr Rgb() noexcept = default;
  constexpr explicit Rgb(T v) noexcept : r(v), g(v), b(v) {}
  constexpr Rgb(T r_, T g_, T b_) noexcept : r(r_), g(g_), b(b_) {}
  /// The same colour in another precision.
  template <Real U>
  constexpr explicit Rgb(const Rgb<U>& o) noexcept : r(T(o.r)), g(T(o.g)), b(T(o.b)) {}

  constexpr Rgb& operator+=(const Rgb& o) noexcept { r += o.r; g += o.g; b += o.b; return *this; }
  constexpr Rgb& operator*=(const Rgb& o) noexcept { r *= o.r; g *= o.g; b *= o.b; return *this; }
  constexpr Rgb& operator*=(T s) noexcept { r *= s; g *= s; b *= s; return *this; }
  constexpr Rgb& operator/=(T s) noexcept { return *this *= (T(1) / s); }
  friend constexpr Rgb operator+(Rgb a, const Rgb& b) noexcept { return a += b; }
  friend constexpr Rgb operator-(const Rgb& a, const Rgb& b) noexcept { return {a.r - b.r, a.g - b.g, a.b - b.b}; }
  friend constexpr Rgb operator*(Rgb a, const Rgb& b) noexcept { return a *= b; }
  friend constexpr Rgb operator*(Rgb a, T s) noexcept { return a *= s; }
  friend constexpr Rgb operator*(T s, Rgb a) noexcept { return a *= s; }
  friend constexpr Rgb operator/(Rgb a, T s) noexcept { return a /= s; }
  friend constexpr bool operator==(const Rgb&, const Rgb&) noexcept = default;

  [[nodiscard]] constexpr T operator[](int i) const noexcept { return i == 0 ? r : (i == 1 ? g : b); }
};

template <Real T> [[nodiscard]] constexpr T max_component(const Rgb<T>& c) noexcept { return std::max({c.r, c.g, c.b}); }
template <Real T> [[nodiscard]] constexpr T average(const Rgb<T>& c) noexcept { return (c.r + c.g + c.b) / T(3); }
template <Real T> [[nodiscard]] constexpr bool is_finite(const Rgb<T>& c) noexcept {
  return std::isfinite(c.r) && std::isfinite(c.g) && std::isfinite(c.b);
}
template <Real T> [[nodiscard]] constexpr bool is_black(const Rgb<T>& c) noexcept { return c.r == 0 && c.g == 0 && c.b == 0; }

template <Real T> [[nodiscard]] constexpr T max_component(T v) noexcept { return v; }
template <Real T> [[nodiscard]] constexpr T average(T v) noexcept { return v; }
template <Real T> [[nodiscard]] constexpr bool is_finite(T v) noexcept { return std::isfinite(v); }
template <Real T> [[nodiscard]] constexpr bool is_black(T v) noexcept { return v == 0; }

/// The scalar type of a spectrum: T for Rgb<T>, the type itself for a scalar.
template <class S> struct spectrum_scalar { using type = S; };
template <Real T> struct spectrum_scalar<Rgb<T>> { using type = T; };
template <class S> using spectrum_scalar_t = typename spectrum_scalar<S>::type;

/// The spectrum progressive images accumulate in: the same channels in double (Rgb<float> ->
/// Rgb<double>, float -> double). For your own spectrum type it is the type itself unless you
/// specialise it; it must be constructible from S (render/progressive.hpp).
template <class S> struct accumulation_spectrum { using type = S; };
template <> struct accumulation_spectrum<float> { using type = double; };
template <Real T> struct accumulation_spectrum<Rgb<T>> { using type = Rgb<double>; };
template <class S> using accumulation_spectrum_t = typename accumulation_spectrum<S>::type;

/// What estimators need of a radiance or throughput value. Rgb<T> and the floating-point
/// types model it.
///  1. a std::regular type, constructible from a scalar (0 is black), closed under +, +=,
///     * (per channel), * and / by its scalar;
///  2. max_component, average, is_finite and is_black callable unqualified: the segpath
///     overloads above, or for your own type overloads in its namespace, found by
///     argument-dependent lookup (library code calls them unqualified);
///  3. spectrum_scalar<S>::type names its scalar, float or double (specialize
///     segpath::spectrum_scalar for your own type).
template <class S>
concept Spectrum = std::regular<S> && Real<spectrum_scalar_t<S>> &&
    requires(S a, S b, spectrum_scalar_t<S> t) {
      S(t);
      { a + b } -> std::convertible_to<S>;
      { a * b } -> std::convertible_to<S>;
      { a * t } -> std::convertible_to<S>;
      { a / t } -> std::convertible_to<S>;
      { a += b };
      { max_component(a) } -> std::convertible_to<spectrum_scalar_t<S>>;
      { average(a) } -> std::convertible_to<spectrum_scalar_t<S>>;
      { is_finite(a) } -> std::convertible_to<bool>;
      { is_black(a) } -> std::convertible_to<bool>;
    };

/// The least channel of `s`: what a check that a coefficient is >= 0 in every channel reads.
template <Spectrum S>
[[nodiscard]] constexpr spectrum_scalar_t<S> min_component(const S& s) noexcept {
  return -max_component(s * spectrum_scalar_t<S>(-1));
}

/// What a message about `s`, which must be finite and >= 0 in every channel, says it got:
/// "min -0.25" (the least channel) or "a non-finite value".
template <Spectrum S>
[[nodiscard]] std::string least_channel_text(const S& s) {
  return is_finite(s) ? "min " + format_number(double(min_component(s))) : std::string("a non-finite value");
}

}  // namespace segpath
