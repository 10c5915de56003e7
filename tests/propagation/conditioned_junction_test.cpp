// The junction of the path-conditioned weighting (propagation/conditioned_junction.hpp): what
// its coefficients do not depend on, which the propagation relies on to skip work.
#include <segpath/propagation/conditioned_junction.hpp>

#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "support/catch.hpp"

using namespace segpath;

TEST_CASE("where needs_light_pair is false, a junction is the same bit for bit whatever q_l, also at degenerate D_l",
          "[propagation]") {
  using T = float;
  using S = Rgb<float>;
  const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
  const std::vector<T> lights = {0.f, -0.f, 0.5f, 2.f, 1e-40f, inf, nan, -1.f};
  const std::vector<T> rests = {0.f, 1.f, inf};
  const std::vector<T> qls = {0.f, 0.25f, 3.f, 1e30f};
  std::size_t skipped = 0, differ = 0;
  for (const T light : lights)
    for (const T rest : rests)
      for (const std::uint32_t terms : {0u, 1u, 2u})
        for (const std::uint8_t end_flags : {std::uint8_t(0), conditioned_light_born})
          for (std::uint8_t fp = 0; fp < 8; ++fp) {
            const detail::ConditionedEnd<T> end{light, rest, terms, end_flags};
            if (detail::needs_light_pair(end, fp)) continue;
            ++skipped;
            const detail::ConditionedJunction<S> without = detail::conditioned_coefficients(end, fp, T(0.5), S(2.f), T(0));
            for (const T ql : qls) {
              const detail::ConditionedJunction<S> with = detail::conditioned_coefficients(end, fp, T(0.5), S(2.f), ql);
              differ += std::memcmp(&without.transfer, &with.transfer, sizeof with.transfer) != 0 ||
                                std::memcmp(&without.r, &with.r, sizeof with.r) != 0 || without.code != with.code
                            ? 1
                            : 0;
            }
          }
  CHECK(skipped > 100);
  CHECK(differ == 0);
}

TEST_CASE("only a light-born end forces its start: every other junction reads W", "[propagation]") {
  // propagate_conditioned reads W alone in the rows of an ending segment that is not light-born.
  using T = float;
  using S = Rgb<float>;
  const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
  std::size_t forced = 0, other = 0;
  for (const T light : {0.f, 0.5f, inf, nan})
    for (const T rest : {0.f, 1.f})
      for (const std::uint32_t terms : {0u, 1u, 2u})
        for (const std::uint8_t end_flags : {std::uint8_t(0), conditioned_light_born, conditioned_potential,
                                             std::uint8_t(conditioned_light_born | conditioned_light_technique | conditioned_potential)})
          for (std::uint8_t fp = 0; fp < 8; ++fp)
            for (const T ql : {0.f, 0.25f}) {
              const detail::ConditionedEnd<T> end{light, rest, terms, end_flags};
              const bool reads_u = detail::conditioned_coefficients(end, fp, T(0.5), S(2.f), ql).code & 1;
              if (end_flags & conditioned_light_born) forced += reads_u ? 1 : 0;
              else other += reads_u ? 1 : 0;
            }
  CHECK(forced > 0);  // the case exists
  CHECK(other == 0);
}

TEST_CASE("a bridge target successor leaves its term out of G and of a bridge-born end's weight", "[propagation]") {
  // B(s) = 4 (four targets near y_s, q_b = 1 each) in D(s) - D_l(s) = 5 = 1 + 4: with the
  // successor a target (a light technique sample), G = 5 - q_b = 4, and a bridge-born s is
  // weighted B'(s) / (G B(s)) = (1 - 1/4) / 4.
  using T = double;
  using S = double;
  const detail::ConditionedBridgeEnd<T> bridge{1.0, 0.25};
  const std::uint8_t target = conditioned_light_technique | conditioned_potential | conditioned_light_born;
  for (const std::uint8_t extra : {std::uint8_t(0), conditioned_potential}) {
    const detail::ConditionedEnd<T> bridge_born{0.0, 5.0, 0, conditioned_bridge_born};
    const detail::ConditionedEnd<T> camera_born{0.0, 5.0, 0, 0};
    CHECK(detail::conditioned_coefficients<S>(bridge_born, target, 0.0, 2.0, 0.0, bridge).r[0] == Approx(0.75 / 4.0));
    CHECK(detail::conditioned_coefficients<S>(bridge_born, extra, 0.0, 2.0, 0.0, bridge).r[0] == Approx(1.0 / 5.0));
    CHECK(detail::conditioned_coefficients<S>(camera_born, target, 0.0, 2.0, 0.0, bridge).r[0] == Approx(1.0 / 4.0));
    CHECK(detail::conditioned_coefficients<S>(camera_born, extra, 0.0, 2.0, 0.0, bridge).r[0] == Approx(1.0 / 5.0));
    // Without bridges (no target term) a light technique successor changes nothing here.
    CHECK(detail::conditioned_coefficients<S>(bridge_born, target, 0.0, 2.0, 0.0).r[0] == Approx(1.0 / 5.0));
    // With a light side: G = rest - q_b + Lambda in the state e(s) = 1 (D_l' = 2 > 0).
    const detail::ConditionedEnd<T> lit{2.0, 5.0, 1, conditioned_bridge_born};
    CHECK(detail::conditioned_coefficients<S>(lit, target, 0.0, 2.0, 0.0, bridge).r[1] == Approx(0.75 / 6.0));
  }
}
