// Adaptive binning's x86 kernel (adaptive_binning_x86.cpp), declared where it
// is built (FFSEG_X86). The caller checks that the CPU runs AVX-512F
// (CpuDispatch, mixture family).
#pragma once
#include <cstdint>

#include "cpu_x86.h"
#if FFSEG_X86

namespace ffseg {

// One pass of Algorithm 2's visits with at most 8 bins held in vector lanes,
// from visit t0 on, until the end or until a 9th bin would open (that visit
// is left undone, *idx_io still on it); returns the next visit. Per visit the
// decisions and arithmetic of adaptive_binning's scalar loop.
uint32_t binning_visits_avx512(const float* x, uint32_t n, uint32_t stride, uint64_t* idx_io, uint32_t t0, double R,
                               double S, double* c, uint32_t* cnt, double* sum, double* sum2, uint32_t* K_io);

}  // namespace ffseg
#endif
