// Continuous multiple importance sampling (N6-N8): a technique t ~ p(t) from a continuous space,
// then X ~ p(X | t); the balance weight density divides the joint density by the marginal p(X).
#pragma once

#include <concepts>
#include <functional>
#include <type_traits>

#include "segpath/weights/smis.hpp"

namespace segpath {

/// A density over techniques: `pdf(t)` returns p(t) as a float or double.
template <class F, class Tech>
concept TechniqueDensity = std::invocable<F&, const Tech&> &&
    Real<std::remove_cvref_t<std::invoke_result_t<F&, const Tech&>>>;

/// A marginal density: `marginal(x)` returns p(x) = int_T p(t) p(x | t) dt (N7) as a float or
/// double, in closed form or by the caller's own quadrature.
template <class F, class X>
concept MarginalDensity =
    std::invocable<F&, const X&> && Real<std::remove_cvref_t<std::invoke_result_t<F&, const X&>>>;

/// The balance weight density w(t, X) = p(t) p(X | t) / p(X) (N8) from the joint density
/// p(t) p(X | t) and the marginal p(X) (N7); int_T w(t, X) dt = 1. 0 when the joint density is
/// unusable (zero, negative, non-finite) or the marginal is not positive and finite.
template <Real T>
[[nodiscard]] constexpr T cmis_weight(T joint_pdf, T marginal_pdf) noexcept {
  const T numerator = detail::usable_density(joint_pdf);
  if (numerator == T(0)) return T(0);
  return detail::divide_or_zero(numerator, marginal_pdf);
}

/// w(t, x) (N8) from callables: technique_pdf(t) = p(t), conditional_pdf(x, t) = p(x | t),
/// marginal(x) = p(x). The marginal is evaluated only where the joint density is nonzero.
template <class Tech, class X, class TechPdf, class CondPdf, class Marginal>
requires TechniqueDensity<TechPdf, Tech> && ConditionalDensity<CondPdf, X, Tech> &&
    MarginalDensity<Marginal, X>
[[nodiscard]] constexpr auto cmis_weight(
    const Tech& t, const X& x, TechPdf&& technique_pdf, CondPdf&& conditional_pdf,
    Marginal&& marginal) noexcept(std::is_nothrow_invocable_v<TechPdf&, const Tech&>&&
                                      std::is_nothrow_invocable_v<CondPdf&, const X&, const Tech&>&&
                                          std::is_nothrow_invocable_v<Marginal&, const X&>) {
  using T = std::common_type_t<std::remove_cvref_t<std::invoke_result_t<TechPdf&, const Tech&>>,
                               density_scalar_t<CondPdf, X, Tech>,
                               std::remove_cvref_t<std::invoke_result_t<Marginal&, const X&>>>;
  const T joint = detail::usable_density(T(std::invoke(technique_pdf, t))) *
                  detail::usable_density(T(std::invoke(conditional_pdf, x, t)));
  if (joint == T(0)) return T(0);
  return cmis_weight(joint, T(std::invoke(marginal, x)));
}

/// The one-sample CMIS estimator (N6) for any weight density w(t, X) with int_T w dt = 1:
/// w f(X) / (p(t) p(X | t)). `value` = f(X) is a scalar or a spectrum; a zero value when the
/// joint density is not positive and finite.
template <class V, Real T>
[[nodiscard]] constexpr V cmis_estimate(const V& value, T weight, T joint_pdf) noexcept {
  return detail::divide_or_zero(V(value * weight), joint_pdf);
}

/// The one-sample CMIS estimator with the balance weight (N6 with N8): the joint density
/// cancels and what remains is f(X) / p(X), whichever t drew X. A zero value when the
/// marginal is not positive and finite.
template <class V, Real T>
[[nodiscard]] constexpr V cmis_balance_estimate(const V& value, T marginal_pdf) noexcept {
  return detail::divide_or_zero(value, marginal_pdf);
}

/// f(x) / p(x) (N6 with N8) from callables f(x) and marginal(x).
template <class X, class F, class Marginal>
requires std::invocable<F&, const X&> && MarginalDensity<Marginal, X>
[[nodiscard]] constexpr auto cmis_balance_estimate(const X& x, F&& f, Marginal&& marginal) noexcept(
    std::is_nothrow_invocable_v<F&, const X&>&& std::is_nothrow_invocable_v<Marginal&, const X&>) {
  using V = std::remove_cvref_t<std::invoke_result_t<F&, const X&>>;
  return cmis_balance_estimate(V(std::invoke(f, x)), std::invoke(marginal, x));
}

}  // namespace segpath
