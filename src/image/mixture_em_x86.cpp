// The E-step compiled for AVX-512F (the template in mixture_e_step.h), built
// only for x86; mixture_em.cpp calls it when the engine's dispatch picks it.
#include "mixture_e_step.h"

#if FFSEG_X86
namespace ffseg {
namespace mixture_kernels {

namespace {

template <bool EXACT>
__attribute__((target("avx512f"))) FFSEG_NO_FMA_CONTRACT void e_step8(const CpuDispatch& cpu, uint32_t m, const float* x,
                                                                        uint32_t n, double shift, const double* la,
                                                                        const double* mu, const double* ih, double* Z,
                                                                        double* Zx, double* Zxx, LogLik* ll) {
  e_step_switch<EXACT>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

}  // namespace

void e_step_avx512_exact(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift, const double* la,
                         const double* mu, const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
  e_step8<true>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

void e_step_avx512_chunked(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift,
                           const double* la, const double* mu, const double* ih, double* Z, double* Zx, double* Zxx,
                           LogLik* ll) {
  e_step8<false>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

}  // namespace mixture_kernels
}  // namespace ffseg
#endif
