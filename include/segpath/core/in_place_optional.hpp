// in_place_optional<X>(fields...): a std::optional<X> built in its own storage from X's fields,
// for functions that return an optional aggregate (samples, hits, densities).
//
// Why not `return X{fields...};`: GCC 12 builds that temporary with 4- and 8-byte stores and
// copies it into the optional with 16-byte loads, which wait until the stores retire (store
// forwarding fails). In PT's next-event draw, the pinhole's rays and the generic estimator's
// BSDF samples, 2-10 % of a function's profile sat on such loads (docs/figures.md, session 33).
// `optional::emplace` on an optional already constructed is no better: GCC 12 zero-fills the
// object first (session 32).
#pragma once

#include "segpath/config.hpp"

#include <optional>
#include <utility>

namespace segpath {

/// std::optional<X>, engaged, holding X{fields...}. The fields follow brace initialisation's
/// rules (no narrowing), but as a function's arguments they are evaluated in no fixed order.
/// Compilers without C++20's parenthesised aggregate initialisation (clang < 16) get the
/// temporary and its copy.
template <class X, class... Fields>
  requires requires(Fields&&... fields) { X{std::forward<Fields>(fields)...}; }
[[nodiscard]] SEGPATH_FORCE_INLINE constexpr std::optional<X> in_place_optional(Fields&&... fields) noexcept(
    noexcept(X{std::forward<Fields>(fields)...})) {
#if defined(__cpp_aggregate_paren_init) && __cpp_aggregate_paren_init >= 201902L
  return std::optional<X>(std::in_place, std::forward<Fields>(fields)...);
#else
  return X{std::forward<Fields>(fields)...};
#endif
}

}  // namespace segpath
