// One include for Catch2 2.13 (Debian 12) and Catch2 3. Tests write `Approx` unqualified,
// which both versions then provide.
#pragma once
#if __has_include(<catch2/catch_all.hpp>)
#  include <catch2/catch_all.hpp>
using Catch::Approx;
#else
#  include <catch2/catch.hpp>
#endif
