// Path length counted in segments when pooled segments stand for several (SPEC 1.8): a chain
// through delta bounces (a camera chain probe -> glass -> floor, a light chain light -> glass
// -> floor) is one pooled segment of p(s) pieces. Jacobi sweeps alone count pooled segments,
// so with chains they would sum paths longer than max_length. With a budget c of segments
// left after s,
//   A^(c)(s) = L_e(s) + sum_s' T(s, s') A^(c - p(s'))(s'),   A^(c < 0) = 0,
// and the value of s over paths of at most B segments is A^(B - p(s))(s). The lag sits on the
// start s', whose value propagation gathers once per sweep anyway, so the group sums (and
// their factorisation) are unchanged; what it costs is the values of the last max p budgets.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>
#include <stdexcept>

namespace segpath::detail {

/// max p(s), 1 for no pieces (every segment one); throws for a p of 0 or a size mismatch.
inline int max_pieces(std::span<const std::uint16_t> pieces, std::size_t segments) {
  if (pieces.empty()) return 1;
  if (pieces.size() != segments) throw std::invalid_argument("segpath::propagate: pieces has one entry per segment or none");
  const std::uint16_t most = *std::max_element(pieces.begin(), pieces.end());
  if (*std::min_element(pieces.begin(), pieces.end()) == 0) throw std::invalid_argument("segpath::propagate: a segment has 0 pieces");
  return int(most);
}

}  // namespace segpath::detail
