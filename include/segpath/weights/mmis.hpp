// Marginal multiple importance sampling (N38-N42): technique families i = 1..T, family i with n_i
// drawn technique samples t_{i,j} and conditional densities p_i(s | t); the balance heuristic
// divides by sum_{i'} sum_{j'} p_{i'}(s | t_{i',j'}) over every drawn sample of every family.
// Customization points (TechniqueFamily): f.techniques(), f.pdf(s, t), optional f.density_sum(s).
#pragma once

#include <concepts>
#include <cstddef>
#include <functional>
#include <ranges>
#include <type_traits>
#include <utility>

#include "segpath/core/index_range.hpp"
#include "segpath/weights/smis.hpp"

namespace segpath {

namespace detail {
template <class F>
concept HasTechniques = requires(const F& f) {
  { f.techniques() } -> std::ranges::forward_range;
};
template <class F>
using family_technique_t =
    std::ranges::range_value_t<decltype(std::declval<const F&>().techniques())>;
template <class F, class S>
concept HasFamilyPdf = requires(const F& f, const S& s, const family_technique_t<F>& t) {
  f.pdf(s, t);
  requires Real<std::remove_cvref_t<decltype(f.pdf(s, t))>>;
};
template <class F, class S>
concept HasDensitySum = requires(const F& f, const S& s) {
  f.density_sum(s);
  requires Real<std::remove_cvref_t<decltype(f.density_sum(s))>>;
};
}  // namespace detail

/// One technique family of MMIS (N38-N42) for samples of type S. Requirements:
///  1. `f.techniques()` returns a forward range of the n_i technique samples t_{i,j} the family
///     drew (n_i may be 0);
///  2. `f.pdf(s, t)` returns p_i(s | t), a float or double, for any sample s (also one another
///     family drew) and any t of that range;
///  3. optionally `f.density_sum(s)` returns sum_j p_i(s | t_{i,j}) in closed form (e.g. n_i p_i(s)
///     for an unconditional technique drawn n_i times); used instead of the loop when present.
/// Semantics: every family's density is in the same measure, 0 where t cannot produce s, and
/// integrates over s to 1 (or to the probability that the technique succeeds).
/// A segment sampler gives a family with
/// `ConditionalFamily(techniques, [&](const auto& s, const auto& t) { return smp.pdf(scene, t, s);
/// })`.
template <class F, class S>
concept TechniqueFamily = detail::HasTechniques<F> && detail::HasFamilyPdf<F, S>;

/// The scalar type family F returns densities in.
template <class F, class S>
requires TechniqueFamily<F, S>
using family_scalar_t = std::remove_cvref_t<decltype(std::declval<const F&>().pdf(
    std::declval<const S&>(), std::declval<const detail::family_technique_t<F>&>()))>;

namespace detail {
template <class F, class S>
concept NothrowPdf = requires(const F& f, const S& s, const family_technique_t<F>& t) {
  requires noexcept(f.techniques());
  requires noexcept(f.pdf(s, t));
};
template <class F, class S>
concept NothrowDensitySum = !HasDensitySum<F, S> || requires(const F& f, const S& s) {
  requires noexcept(f.density_sum(s));
};
template <class F, class S>
concept NothrowFamily = NothrowPdf<F, S> && NothrowDensitySum<F, S>;
}  // namespace detail

/// sum_j p_i(s | t_{i,j}): one family's share of the MMIS denominator (N39, N40, N42).
/// Unusable densities (zero, negative, non-finite) count as 0.
template <class S, class F>
requires TechniqueFamily<F, S>
[[nodiscard]] constexpr auto family_density_sum(const S& s, const F& family) noexcept(
    detail::NothrowFamily<F, S>) {
  using T = family_scalar_t<F, S>;
  if constexpr (detail::HasDensitySum<F, S>) {
    return detail::usable_density(T(family.density_sum(s)));
  } else {
    T sum = 0;
    for (const auto& t : family.techniques()) sum += detail::usable_density(T(family.pdf(s, t)));
    return sum;
  }
}

/// The MMIS balance-heuristic denominator sum_{i'=1}^T sum_{j'=1}^{n_i'} p_{i'}(s | t_{i',j'})
/// (N39, N40, N42) over every drawn technique sample of every family passed. The families are
/// a compile-time list, so each family's density inlines. Pass *all* families: a family left
/// out biases the estimator.
template <class S, TechniqueFamily<S>... Fs>
[[nodiscard]] constexpr auto mmis_denominator(const S& s, const Fs&... families) noexcept(
    (detail::NothrowFamily<Fs, S> && ...)) {
  static_assert(sizeof...(Fs) > 0, "segpath::mmis_denominator: pass at least one family");
  using T = std::common_type_t<family_scalar_t<Fs, S>...>;
  return (T(0) + ... + T(family_density_sum(s, families)));
}

/// mmis_denominator over a run-time list of families of one type (e.g. one per sampler
/// configuration chosen at start-up).
template <class S, std::ranges::input_range R>
requires TechniqueFamily<std::ranges::range_value_t<R>, S>
[[nodiscard]] constexpr auto mmis_denominator_range(const S& s, const R& families) noexcept(
    detail::NothrowFamily<std::ranges::range_value_t<R>, S>) {
  using T = family_scalar_t<std::ranges::range_value_t<R>, S>;
  T sum = 0;
  for (const auto& family : families) sum += family_density_sum(s, family);
  return sum;
}

/// The MMIS weight of technique sample t_{i,j} for s: p_i(s | t_{i,j}) / denominator (the
/// balance heuristic of N42); the weights of all technique samples of all families sum to one.
/// 0 when own is unusable or the denominator is not positive, never a division by zero.
template <Real T>
[[nodiscard]] constexpr T mmis_weight(T own, T denominator) noexcept {
  return smis_weight(own, denominator);
}

/// One term of the MMIS estimators: g(s) / denominator (N42; with g = K f_r G <L> the
/// successor term of N39, with g = W G <L> the pixel term of N40). `value` is a scalar or a
/// spectrum; a zero value when the denominator is not positive and finite.
template <class V, Real T>
[[nodiscard]] constexpr V mmis_contribution(const V& value, T denominator) noexcept {
  return detail::divide_or_zero(value, denominator);
}

/// A family of conditional techniques: the drawn technique samples t_{i,j} (a view; an lvalue
/// range is referenced, not copied, and must outlive the family) and p_i(s | t) as a callable
/// pdf(s, t).
template <std::ranges::view V, class Pdf>
requires std::ranges::forward_range<const V>
class ConditionalFamily {
 public:
  using Technique = std::ranges::range_value_t<const V>;

  template <class R>
  constexpr ConditionalFamily(R&& techniques, Pdf pdf)
      : techniques_(std::views::all(std::forward<R>(techniques))), pdf_(std::move(pdf)) {}

  [[nodiscard]] constexpr const V& techniques() const noexcept { return techniques_; }

  template <class S>
  requires ConditionalDensity<const Pdf, S, Technique>
  [[nodiscard]] constexpr auto pdf(const S& s, const Technique& t) const
      noexcept(std::is_nothrow_invocable_v<const Pdf&, const S&, const Technique&>) {
    return std::invoke(pdf_, s, t);
  }

 private:
  V techniques_;
  Pdf pdf_;
};

template <class R, class Pdf>
ConditionalFamily(R&&, Pdf) -> ConditionalFamily<std::views::all_t<R>, Pdf>;

/// An unconditional technique (density p_i(s), no technique parameter) drawn `count` times:
/// its technique samples are the indices 0..count-1 and its share of the denominator is
/// count * p_i(s) (the n_i p_i of the discrete balance heuristic, N5).
template <class Pdf>
class UnconditionalFamily {
 public:
  constexpr UnconditionalFamily(std::size_t count, Pdf pdf) : count_(count), pdf_(std::move(pdf)) {}

  [[nodiscard]] constexpr auto techniques() const noexcept {
    return IndexRange<std::size_t>(0, count_);
  }
  [[nodiscard]] constexpr std::size_t count() const noexcept { return count_; }

  template <class S>
  requires std::invocable<const Pdf&, const S&> &&
      Real<std::remove_cvref_t<std::invoke_result_t<const Pdf&, const S&>>>
  [[nodiscard]] constexpr auto pdf(const S& s, std::size_t /*index*/) const
      noexcept(std::is_nothrow_invocable_v<const Pdf&, const S&>) {
    return std::invoke(pdf_, s);
  }

  template <class S>
  requires std::invocable<const Pdf&, const S&> &&
      Real<std::remove_cvref_t<std::invoke_result_t<const Pdf&, const S&>>>
  [[nodiscard]] constexpr auto density_sum(const S& s) const
      noexcept(std::is_nothrow_invocable_v<const Pdf&, const S&>) {
    using T = std::remove_cvref_t<std::invoke_result_t<const Pdf&, const S&>>;
    return T(count_) * detail::usable_density(T(std::invoke(pdf_, s)));
  }

 private:
  std::size_t count_;
  Pdf pdf_;
};

}  // namespace segpath
