// The Russian roulette's continuation probability (core/roulette.hpp).
#include <segpath/core/roulette.hpp>

#include "support/catch.hpp"

using namespace segpath;

TEST_CASE("the roulette continues with the scattering weight's largest component, at most 1", "[core]") {
  CHECK(continuation_probability(Rgb<float>(0.3f, 0.8f, 0.1f), false) == 0.8f);
  CHECK(continuation_probability(Rgb<double>(0.2, 1.4, 0.2), false) == 1.0);
  CHECK(continuation_probability(0.5, false) == 0.5);
  // A delta lobe always continues; a black weight never does.
  CHECK(continuation_probability(Rgb<float>(0.3f, 0.3f, 0.3f), true) == 1.0f);
  CHECK(continuation_probability(Rgb<float>(0.0f), false) == 0.0f);
  CHECK(continuation_probability(-0.25, false) == 0.0);
}
