// Stochastic multiple importance sampling (N9-N13): draw technique samples t_j ~ p(t) and one
// X_i ~ p(X | t_i) each, and replace the marginal p(X) of continuous MIS by sum_j p(X | t_j).
#pragma once

#include <cmath>
#include <concepts>
#include <cstddef>
#include <functional>
#include <iterator>
#include <ranges>
#include <type_traits>

#include "segpath/weights/mis.hpp"

namespace segpath {

/// A conditional density p(X | t): `pdf(x, t)` returns a float or double for any sample x and
/// any technique parameter t (also for samples that t did not draw, and 0 where t cannot
/// produce x). All densities combined in one denominator must use the same measure.
template <class F, class X, class Tech>
concept ConditionalDensity = std::invocable<F&, const X&, const Tech&> &&
    Real<std::remove_cvref_t<std::invoke_result_t<F&, const X&, const Tech&>>>;

/// The scalar type a conditional density returns.
template <class F, class X, class Tech>
using density_scalar_t = std::remove_cvref_t<std::invoke_result_t<F&, const X&, const Tech&>>;

namespace detail {
/// A density as it enters a balance-heuristic sum: zero, negative and non-finite values
/// (numerical failure) count as 0, as in mis_term.
template <Real T>
[[nodiscard]] constexpr T usable_density(T p) noexcept {
  return mis_term(p, MisHeuristic::balance);
}

/// value / denominator, or a zero value when the denominator is not a positive finite number.
template <class V, Real T>
[[nodiscard]] constexpr V divide_or_zero(const V& value, T denominator) noexcept {
  if (!(denominator > T(0)) || !std::isfinite(denominator)) return V{};
  return V(value * (T(1) / denominator));
}
}  // namespace detail

/// sum_{j=1}^n p(x | t_j) over the drawn technique samples `techniques` (the denominator of
/// N12 and N13; n times the estimate of the marginal p(x), N10). Unusable densities count as 0.
template <class X, std::ranges::forward_range R, class PdfFn>
requires ConditionalDensity<PdfFn, X, std::ranges::range_value_t<R>>
[[nodiscard]] constexpr auto
smis_denominator(const X& x, const R& techniques, PdfFn&& pdf) noexcept(
    std::is_nothrow_invocable_v<PdfFn&, const X&, const std::ranges::range_value_t<R>&>) {
  using T = density_scalar_t<PdfFn, X, std::ranges::range_value_t<R>>;
  T sum = 0;
  for (const auto& t : techniques) sum += detail::usable_density(T(std::invoke(pdf, x, t)));
  return sum;
}

/// The SMIS weight (N13) from its parts: own = p(x | t_i), denominator = sum_j p(x | t_j)
/// (which must include own). 0 when own is unusable or the denominator is not positive,
/// never a division by zero.
template <Real T>
[[nodiscard]] constexpr T smis_weight(T own, T denominator) noexcept {
  const T numerator = detail::usable_density(own);
  if (numerator == T(0)) return T(0);
  return detail::divide_or_zero(numerator, denominator);
}

/// w_i(x) = p(x | t_i) / sum_j p(x | t_j) (N13): the discrete balance heuristic among the drawn
/// techniques. The weights of all i sum to one wherever some t_j can produce x.
template <class X, std::ranges::random_access_range R, class PdfFn>
requires ConditionalDensity<PdfFn, X, std::ranges::range_value_t<R>>
[[nodiscard]] constexpr auto smis_weight(
    std::size_t i, const X& x, const R& techniques,
    PdfFn&& pdf) noexcept(noexcept(smis_denominator(x, techniques, pdf))) {
  using T = density_scalar_t<PdfFn, X, std::ranges::range_value_t<R>>;
  const auto& t_i =
      std::ranges::begin(techniques)[static_cast<std::ranges::range_difference_t<R>>(i)];
  const T own = detail::usable_density(T(std::invoke(pdf, x, t_i)));
  if (own == T(0)) return T(0);
  return smis_weight(own, smis_denominator(x, techniques, pdf));
}

/// One term of the SMIS estimator (N12): f(X_i) / sum_j p(X_i | t_j). `value` may be a scalar
/// or a spectrum; a non-positive or non-finite denominator gives a zero value.
template <class V, Real T>
[[nodiscard]] constexpr V smis_contribution(const V& value, T denominator) noexcept {
  return detail::divide_or_zero(value, denominator);
}

/// The SMIS estimate (N12), sum_i f(X_i) / sum_j p(X_i | t_j), in O(n^2) density evaluations
/// and no allocation. `samples` holds the X_i that were drawn successfully; `techniques` all
/// drawn t_j, also those whose sample failed (they still belong in every denominator).
/// f(x) returns a scalar or a spectrum.
template <std::ranges::forward_range RX, std::ranges::forward_range RT, class F, class PdfFn>
requires ConditionalDensity<PdfFn, std::ranges::range_value_t<RX>,
                            std::ranges::range_value_t<RT>> && std::invocable < F&,
    const std::ranges::range_value_t<RX>
& > [[nodiscard]] constexpr auto smis_estimate(const RX& samples, const RT& techniques, F&& f,
                                               PdfFn&& pdf) {
  using V = std::remove_cvref_t<std::invoke_result_t<F&, const std::ranges::range_value_t<RX>&>>;
  V sum{};
  for (const auto& x : samples)
    sum += smis_contribution(V(std::invoke(f, x)), smis_denominator(x, techniques, pdf));
  return sum;
}

}  // namespace segpath
