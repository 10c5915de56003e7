// Numbers in error messages (core/format.hpp), and the messages that print them.
#include <segpath/core/format.hpp>
#include <segpath/kernels/voxel.hpp>

#include <limits>
#include <stdexcept>
#include <string>

#include "support/catch.hpp"

using namespace segpath;

TEST_CASE("a number in a message reads as itself at any magnitude", "[core]") {
  CHECK(format_number(1e-9) == "1e-09");
  CHECK(format_number(0.0066) == "0.0066");
  CHECK(format_number(23912.7, 3) == "2.39e+04");
  CHECK(format_number(-0.5) == "-0.5");
  CHECK(format_number(1.0) == "1");
  CHECK(format_number(std::numeric_limits<double>::infinity()) == "inf");
  CHECK(format_number(std::numeric_limits<double>::quiet_NaN()).find("nan") != std::string::npos);
}

TEST_CASE("a tiny bad value is named in the error, not printed as 0.000000", "[core]") {
  try {
    (void)VoxelGrid<double>(-1e-9);
    FAIL("a negative cell size was accepted");
  } catch (const std::invalid_argument& e) {
    CHECK(std::string(e.what()).find("got -1e-09") != std::string::npos);
  }
}
