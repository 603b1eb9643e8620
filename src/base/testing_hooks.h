// Test hooks of the base layer (engine/testing.h gathers every layer's): a
// dispatch that runs one chosen kernel, so a test can hold each kernel
// against the portable one and a benchmark can time them apart.
#pragma once
#include "cpu_dispatch.h"

namespace ffseg {

struct CpuDispatchTesting {
  // d with family f switched to kernel k; d unchanged when this CPU cannot
  // run k (CpuDispatch::supports), so a forced kernel never faults.
  static CpuDispatch with(CpuDispatch d, KernelFamily f, Isa k) {
    if (CpuDispatch::supports(f, k)) d.isa_[int(f)] = k;
    return d;
  }
};

}  // namespace ffseg
