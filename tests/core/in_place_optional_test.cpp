// in_place_optional<X>(fields...) holds X{fields...} and, like braces, refuses to narrow.
#include <segpath/core/in_place_optional.hpp>

#include <catch2/catch.hpp>

#include <cstdint>
#include <utility>

namespace {

struct Fields {
  float a = 0;
  std::uint32_t b = 7;
  bool c = true;
};

template <class X, class... A>
concept InPlaceOptionalAccepts = requires(A&&... a) { segpath::in_place_optional<X>(std::forward<A>(a)...); };

static_assert(InPlaceOptionalAccepts<Fields, float, std::uint32_t, bool>);
static_assert(InPlaceOptionalAccepts<Fields, float>, "fields left out take their defaults, as with braces");
static_assert(!InPlaceOptionalAccepts<Fields, double>, "a double into a float field narrows");
static_assert(!InPlaceOptionalAccepts<Fields, float, int>, "an int variable into a uint32_t field narrows");
static_assert(!InPlaceOptionalAccepts<Fields, float, std::uint32_t, bool, int>, "too many fields");

}  // namespace

TEST_CASE("in_place_optional holds X{fields...}, defaults included", "[core]") {
  const std::optional<Fields> all = segpath::in_place_optional<Fields>(1.5f, std::uint32_t(3), false);
  REQUIRE(all.has_value());
  CHECK(all->a == 1.5f);
  CHECK(all->b == 3u);
  CHECK(all->c == false);
  const auto first = segpath::in_place_optional<Fields>(2.5f);
  REQUIRE(first.has_value());
  CHECK(first->a == 2.5f);
  CHECK(first->b == 7u);
  CHECK(first->c == true);
}
