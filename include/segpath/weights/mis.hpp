// Multiple importance sampling over a discrete set of techniques (N3-N5, N36, N37):
// technique i drew n_i samples with density p_i; the balance heuristic weights a sample X by
// w_i(X) = n_i p_i(X) / sum_k n_k p_k(X) (N5), the power heuristic by (n_i p_i)^b / sum (n_k p_k)^b.
#pragma once

#include "segpath/core/vec.hpp"

#include <cmath>
#include <cstddef>
#include <span>

namespace segpath {

enum class MisHeuristic : std::uint8_t { balance, power };

/// The heuristic's effective density: n p for balance, (n p)^2 for the power heuristic with
/// exponent 2 (Veach's recommendation). Zero and non-finite densities count as 0.
template <Real T>
[[nodiscard]] constexpr T mis_term(T count_times_pdf, MisHeuristic h) noexcept {
  if (!(count_times_pdf > T(0)) || !std::isfinite(count_times_pdf)) return T(0);
  return h == MisHeuristic::balance ? count_times_pdf : count_times_pdf * count_times_pdf;
}

/// w_i (N5, or its power form) of the technique whose n_i p_i(X) is `own`, among techniques
/// with n_k p_k(X) in `all` (which must include `own`). Returns 0 when own is 0, and never
/// divides by zero: a sample no technique could have drawn gets weight 0.
template <Real T>
[[nodiscard]] constexpr T mis_weight(T own, std::span<const T> all, MisHeuristic h = MisHeuristic::balance) noexcept {
  const T numerator = mis_term(own, h);
  if (numerator == T(0)) return T(0);
  T denominator = T(0);
  for (const T p : all) denominator += mis_term(p, h);
  return denominator > T(0) ? numerator / denominator : T(0);
}

/// The two-technique case (e.g. BSDF sampling against next-event estimation):
/// w = term(a) / (term(a) + term(b)).
template <Real T>
[[nodiscard]] constexpr T mis_weight(T own, T other, MisHeuristic h = MisHeuristic::balance) noexcept {
  const T a = mis_term(own, h);
  if (a == T(0)) return T(0);
  return a / (a + mis_term(other, h));
}

}  // namespace segpath
