#pragma once
// The test runner traps floating-point exceptions; a test that feeds NaN on purpose turns
// the traps off for its own scope (an ordered comparison with NaN raises "invalid").
#include <cfenv>

namespace ffd::test {

class FpTrapsOff {
 public:
  FpTrapsOff() : saved_(fegetexcept()) { fedisableexcept(FE_ALL_EXCEPT); }
  ~FpTrapsOff() {
    feclearexcept(FE_ALL_EXCEPT);
    feenableexcept(saved_);
  }
  FpTrapsOff(const FpTrapsOff&) = delete;
  FpTrapsOff& operator=(const FpTrapsOff&) = delete;

 private:
  int saved_;
};

}  // namespace ffd::test
