// exp_block's x86 kernel (exp_block_x86.cpp): FFSEG_EXP_VECTOR is defined
// where it is built (x86-64 with GCC or clang, not FFSEG_PORTABLE). The caller
// checks that the CPU runs AVX-512F + FMA (CpuDispatch, exp family).
#pragma once
#include <cstdint>

#include "cpu_x86.h"
#if FFSEG_X86 && defined(__x86_64__)
#define FFSEG_EXP_VECTOR 1

namespace ffseg {

void exp_block_avx512(double* v, uint32_t n);
void exp_block_nonzero_avx512(double* v, uint32_t n);
// Uncertified lanes set to NaN instead of std::exp (ExpBlockTesting).
void exp_block_kernel_only_avx512(double* v, uint32_t n);

}  // namespace ffseg
#endif
