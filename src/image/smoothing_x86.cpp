// The Perona-Malik sweep in 8 (AVX2) and 16 (AVX-512F) lanes (the template
// in smoothing_sweep.h), built only for x86; SmoothedRoi::diffuse calls them
// when the engine's dispatch picks them.
#include "smoothing_sweep.h"

#if FFSEG_X86
namespace ffseg {
namespace smoothing_kernels {

namespace {

__attribute__((target("avx2"))) FFSEG_NO_FMA_CONTRACT void diffuse_avx2(float* buf, float* scratch, int64_t E0,
                                                                          int64_t E1, int64_t E2, const float w[3],
                                                                          const float ik[3]) {
  diffuse_sweep<V8, V8i, 8>(buf, scratch, E0, E1, E2, w, ik);
}
__attribute__((target("avx512f"))) FFSEG_NO_FMA_CONTRACT void diffuse_avx512(float* buf, float* scratch, int64_t E0,
                                                                               int64_t E1, int64_t E2, const float w[3],
                                                                               const float ik[3]) {
  diffuse_sweep<V16, V16i, 16>(buf, scratch, E0, E1, E2, w, ik);
}

}  // namespace

void diffuse_sweep_avx2(float* buf, float* scratch, int64_t E0, int64_t E1, int64_t E2, const float w[3],
                        const float ik[3]) {
  diffuse_avx2(buf, scratch, E0, E1, E2, w, ik);
}

void diffuse_sweep_avx512(float* buf, float* scratch, int64_t E0, int64_t E1, int64_t E2, const float w[3],
                          const float ik[3]) {
  diffuse_avx512(buf, scratch, E0, E1, E2, w, ik);
}

}  // namespace smoothing_kernels
}  // namespace ffseg
#endif
