// Test hooks of the image layer (engine/testing.h gathers every layer's).
#pragma once
#include <cstdint>

namespace ffseg {

struct ExpBlockTesting {
  // exp_block's vector kernel alone on v, when this CPU runs it: lanes it
  // cannot certify are set to NaN (left to std::exp in exp_block), so a test
  // can count them. Every value is NaN without the kernel.
  static void kernel_only(double* v, uint32_t n);
};

}  // namespace ffseg
