#include "exp_block.h"

#include <cmath>

#include "exp_block_x86.h"
#include "image_testing.h"

namespace ffseg {

void exp_block(const CpuDispatch& cpu, double* v, uint32_t n) {
#ifdef FFSEG_EXP_VECTOR
  if (cpu.kernel(KernelFamily::exp) == Isa::avx512) {
    exp_block_avx512(v, n);
    return;
  }
#else
  (void)cpu;
#endif
  for (uint32_t t = 0; t < n; ++t) v[t] = std::exp(v[t]);
}

void exp_block_nonzero(const CpuDispatch& cpu, double* v, uint32_t n) {
#ifdef FFSEG_EXP_VECTOR
  if (cpu.kernel(KernelFamily::exp) == Isa::avx512) {
    exp_block_nonzero_avx512(v, n);
    return;
  }
#else
  (void)cpu;
#endif
  for (uint32_t t = 0; t < n; ++t) v[t] = v[t] == 0 ? 1.0 : std::exp(v[t]);
}

void ExpBlockTesting::kernel_only(double* v, uint32_t n) {
#ifdef FFSEG_EXP_VECTOR
  if (CpuDispatch::supports(KernelFamily::exp, Isa::avx512)) {
    exp_block_kernel_only_avx512(v, n);
    return;
  }
#endif
  for (uint32_t t = 0; t < n; ++t) v[t] = NAN;
}

}  // namespace ffseg
