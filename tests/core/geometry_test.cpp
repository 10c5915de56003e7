#include <segpath/core/geometry.hpp>

#include "support/catch.hpp"

using namespace segpath;

TEMPLATE_TEST_CASE("geometry term of facing surface points", "[core]", float, double) {
  using T = TestType;
  const auto x = SurfacePoint<T>::on_surface({0, 0, 0}, {0, 0, 1});
  const auto y = SurfacePoint<T>::on_surface({0, 0, 2}, {0, 0, -1});
  CHECK(geometry_term(Segment<T>{x, y}) == Approx(T(0.25)));
  CHECK(geometry_term(Segment<T>{x, x}) == T(0));
}
