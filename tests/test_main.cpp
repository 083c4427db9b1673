// Catch2 entry point. Floating-point exceptions (invalid, divide by zero, overflow) trap in
// every test, so a NaN or Inf born anywhere in the runtime fails the test where it is made.
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>
#include <cfenv>

int main(int argc, char* argv[]) {
  feenableexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW);
  return Catch::Session().run(argc, argv);
}
