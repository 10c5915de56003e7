// A junction s -> s' of the path-conditioned weighting (propagation/path_conditioned.hpp): the
// r_i and e(s) rules of that header's comment reduced to coefficients fixed for the whole
// propagation, and their application to a segment's four suffix sums U_e, W_e.
#pragma once

#include "segpath/config.hpp"
#include "segpath/core/spectrum.hpp"
#include "segpath/propagation/junction_support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace segpath {

/// Per-segment side flags of the path-conditioned weighting.
inline constexpr std::uint8_t conditioned_light_born = 1;       ///< drawn by a light-side technique
inline constexpr std::uint8_t conditioned_light_technique = 2;  ///< a light predecessor draw was attempted from x
inline constexpr std::uint8_t conditioned_potential = 4;        ///< x could be a light technique point (implied by 2)
inline constexpr std::uint8_t conditioned_bridge_born = 8;       ///< drawn by a bridge (a technique of both sides)

/// The four suffix sums of a segment (path_conditioned.hpp's header comment).
template <Spectrum S>
struct ConditionedValues {
  std::array<S, 2> u{S(spectrum_scalar_t<S>(0)), S(spectrum_scalar_t<S>(0))};
  std::array<S, 2> w{S(spectrum_scalar_t<S>(0)), S(spectrum_scalar_t<S>(0))};
};

namespace detail {

/// What a junction reads of its ending segment s, gathered once per pool.
template <Real T>
struct ConditionedEnd {
  T light = 0, rest = 0;  ///< D_l(s), D(s) - D_l(s)
  std::uint32_t terms = 0;
  std::uint8_t flags = 0;
};

/// What a junction reads of an ending segment s about bridges (none: zeros): q_b(s), the term
/// one bridge target (a light technique sample) starting near y_s adds to s's bridge density
/// B(s), and for a bridge-born s the fraction q_b(s) / B(s) of its own density.
template <Real T>
struct ConditionedBridgeEnd {
  T target_term = 0, target_fraction = 0;
};

/// What a junction reads of its starting segment s', gathered once per pool.
template <Real T>
struct ConditionedStart {
  T geometry = 0, forced_weight = 0;
  std::uint32_t source = no_cluster;  ///< the ending slot s''s values are read from (no_cluster: emission only)
  std::uint16_t pieces = 1;           ///< p(s') (segment_budget.hpp)
  std::uint8_t flags = 0;
};

/// The values of a segment that ends the chain (path_conditioned.hpp's conditioned_emission)
/// kept per ending slot in 16 bytes (float) instead of four spectra.
template <Spectrum S>
struct ConditionedEmission {
  S emitted{spectrum_scalar_t<S>(0)};
  /// 1 / D(s) (NaN where D(s) > 0 fails), negated (its sign bit set) in state e = 1, D_l(s) > 0.
  spectrum_scalar_t<S> signed_inverse_density = 0;

  [[nodiscard]] ConditionedValues<S> values() const noexcept {
    using T = spectrum_scalar_t<S>;
    const T inverse_density = std::abs(signed_inverse_density);
    const S w = std::isnan(inverse_density) ? S(T(0)) : emitted * inverse_density;
    // Constant indices: a value indexed by e would keep a sweep's accumulator in memory.
    ConditionedValues<S> v;
    if (std::signbit(signed_inverse_density)) {
      v.u[1] = emitted;
      v.w[1] = w;
    } else {
      v.u[0] = emitted;
      v.w[0] = w;
    }
    return v;
  }
};

/// A junction s -> s' reduced to what a sweep needs: it adds, for e' in {0, 1},
///   c = transfer * (read_u ? U_e'(s') : W_e'(s'))   to U_state[e'](s) and c r[e'] to W_state[e'](s).
/// Everything in it is fixed for the whole propagation, so it can be built once per pair.
template <Spectrum S>
struct ConditionedJunction {
  S transfer;  ///< K f_r(s, s') G(s'), times 1 / D_lt(s') where s forces s'
  std::array<spectrum_scalar_t<S>, 2> r;  ///< the r of s in the state reached from e(s') = 0, 1
  std::uint8_t code;  ///< bit 0: s forces s' (read U); bits 1, 2: the state e(s) reached from e(s') = 0, 1
};

/// The code of a table entry whose pair is no junction (s' is s, or carries no weight):
/// conditioned_coefficients never gives it.
inline constexpr std::uint8_t no_junction = 0xff;

/// The three junctions of an ending slot of a factorised group, one per flag class of s'
/// (propagate_conditioned), in 40 bytes (float) instead of 72: their transfer is the same.
template <Spectrum S>
struct ClassJunctions {
  S transfer;
  std::array<std::array<spectrum_scalar_t<S>, 2>, 3> r;
  std::array<std::uint8_t, 3> code;

  void set(int k, const ConditionedJunction<S>& j) noexcept { transfer = j.transfer, r[k] = j.r, code[k] = j.code; }
};

/// The junction s -> s' (transfer = K f_r(s, s') G(s')) for s' with flags fp and 1 / D_lt(s')
/// (where read forced) and q_l(s | s') = ql: the r_i and e(s) rules of the header comment.
/// With bridges the targets are the light technique samples: a target s' leaves its term out
/// of s's bridge density as it leaves it out of D_l, so G and a bridge-born s's alpha use
/// B'(s) = B(s) less s''s term, which is the same whatever side s' was born on.
template <Spectrum S>
SEGPATH_FORCE_INLINE ConditionedJunction<S> conditioned_coefficients(const ConditionedEnd<spectrum_scalar_t<S>>& end, std::uint8_t fp,
                                                                     spectrum_scalar_t<S> forced_weight, const S& transfer,
                                                                     spectrum_scalar_t<S> ql,
                                                                     const ConditionedBridgeEnd<spectrum_scalar_t<S>>& bridge = {}) noexcept {
  using T = spectrum_scalar_t<S>;
  const bool light_born = end.flags & conditioned_light_born;
  const bool bridge_excluded = (fp & conditioned_light_technique) && bridge.target_term > T(0);
  const T rest = bridge_excluded ? std::max(T(0), end.rest - bridge.target_term) : end.rest;
  const T own = bridge_excluded && (end.flags & conditioned_bridge_born) ? T(1) - bridge.target_fraction : T(1);
  const bool successor_technique = fp & conditioned_light_technique;
  if (!(fp & conditioned_potential)) ql = T(0);
  const bool excluded = successor_technique && ql > T(0);
  const std::uint32_t terms = end.terms - (excluded && end.terms > 0 ? 1u : 0u);
  const T dl = end.light;
  const T dl_other = terms > 0 ? std::max(T(0), dl - (excluded ? ql : T(0))) : T(0);
  const bool forced = light_born && terms == 0;
  const T lambda = dl_other > T(0) ? dl_other : ql;  // Lambda of the header comment
  ConditionedJunction<S> j{forced ? transfer * forced_weight : transfer, {}, std::uint8_t(forced ? 1 : 0)};
  for (int e_next = 0; e_next < 2; ++e_next) {
    const int e = (terms > 0 || (ql > T(0) && e_next == 1)) ? 1 : 0;
    const T g = rest + (e ? lambda : T(0));
    T r = T(0);
    if (light_born) {
      if (e && g > T(0) && dl > T(0)) r = lambda / (g * dl);
    } else if (g > T(0)) {
      r = own / g;  // a bridge-born s: B'(s) / (G B(s))
    }
    j.r[e_next] = r;
    j.code |= std::uint8_t(e << (1 + e_next));
  }
  return j;
}

/// Whether conditioned_coefficients reads q_l(s | s') for this end and a start with flags fp:
/// only where s' is a potential light technique, and then only if s' is a light technique
/// sample (its term leaves D_l(s)) or D_l(s) has no positive value (Lambda and e(s) fall back
/// on q_l). Elsewhere passing 0 gives the same junction, so the density need not be evaluated.
template <Real T>
[[nodiscard]] constexpr bool needs_light_pair(const ConditionedEnd<T>& end, std::uint8_t fp) noexcept {
  return (fp & conditioned_potential) && ((fp & conditioned_light_technique) || end.terms == 0 || !(end.light > T(0)));
}

/// The values of s' that a junction with `code` reads: U where s forces s' (code & 1), else W.
template <class Pair>
[[nodiscard]] SEGPATH_FORCE_INLINE const Pair& read_successor(std::uint8_t code, const Pair& u, const Pair& w) noexcept {
  return (code & 1) ? u : w;
}

/// Adds a junction to s's values `acc`, reading `v`, the values of s' of the previous iteration
/// that read_successor selects. Linear in `v`: a factorised cluster passes sums over
/// successors of one flag class.
template <Spectrum S>
SEGPATH_FORCE_INLINE void apply_junction(const S& transfer, const std::array<spectrum_scalar_t<S>, 2>& r, std::uint8_t code,
                                         const std::array<S, 2>& v, ConditionedValues<S>& acc) noexcept {
  const S c0 = transfer * v[0], c1 = transfer * v[1];
  // e(s) from e(s') = 0 is at most e(s) from e(s') = 1, so three cases; constant indices keep
  // acc in registers (an indexed acc would chain every pair through memory).
  switch (code >> 1) {
    case 0:  // both to e(s) = 0
      acc.u[0] += c0 + c1;
      acc.w[0] += c0 * r[0] + c1 * r[1];
      break;
    case 2:  // e(s') = 0 to e(s) = 0, e(s') = 1 to e(s) = 1
      acc.u[0] += c0;
      acc.w[0] += c0 * r[0];
      acc.u[1] += c1;
      acc.w[1] += c1 * r[1];
      break;
    default:  // 3: both to e(s) = 1
      acc.u[1] += c0 + c1;
      acc.w[1] += c0 * r[0] + c1 * r[1];
      break;
  }
}
/// apply_junction into W alone, for an s whose U nothing reads (propagate_conditioned keeps U
/// only where a junction can force): the same sums as the W of the full form.
template <Spectrum S>
SEGPATH_FORCE_INLINE void apply_junction(const S& transfer, const std::array<spectrum_scalar_t<S>, 2>& r, std::uint8_t code,
                                         const std::array<S, 2>& v, std::array<S, 2>& w) noexcept {
  const S c0 = transfer * v[0], c1 = transfer * v[1];
  switch (code >> 1) {
    case 0:
      w[0] += c0 * r[0] + c1 * r[1];
      break;
    case 2:
      w[0] += c0 * r[0];
      w[1] += c1 * r[1];
      break;
    default:
      w[1] += c0 * r[0] + c1 * r[1];
      break;
  }
}
/// Either form (acc: ConditionedValues, or W alone) from a built junction.
template <Spectrum S, class Acc>
SEGPATH_FORCE_INLINE void apply_junction(const ConditionedJunction<S>& j, const std::array<S, 2>& v, Acc& acc) noexcept {
  apply_junction(j.transfer, j.r, j.code, v, acc);
}

}  // namespace detail

}  // namespace segpath
