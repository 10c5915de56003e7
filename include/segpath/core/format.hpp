// Numbers in error messages, readable at any magnitude: std::to_string(1e-9) prints "0.000000",
// which hides the very value a message is about.
#pragma once

#include <cstdio>
#include <string>

namespace segpath {

/// `x` with `digits` significant digits (printf's %g): 1e-09, 0.0066, 2.39e+04, nan, inf.
[[nodiscard]] inline std::string format_number(double x, int digits = 6) {
  char text[48];
  std::snprintf(text, sizeof text, "%.*g", digits, x);
  return text;
}

}  // namespace segpath
