// One round of diffuse_all (diffusion.cpp) in SSE2, built only for x86.
#include "diffusion_x86.h"

#if FFSEG_X86 && defined(__SSE2__)
#include <cstddef>
#include <emmintrin.h>

namespace ffseg {

uint32_t diffuse_round_sse2(uint32_t nv, const uint32_t* nbr, const double* src, double* dst) {
  // Two vertices at a time, their six values in three lanes pairs: the same
  // additions and divisions per value (division by 5 dominated the loop).
  uint32_t v = 0;
  const __m128d zero = _mm_setzero_pd(), five = _mm_set1_pd(5.0);
  for (; v + 1 < nv; v += 2) {
    const uint32_t* na = nbr + 4 * size_t(v);
    const double* p = src + 3 * size_t(v);
    __m128d s0 = _mm_add_pd(zero, _mm_loadu_pd(p));      // x, y of v
    __m128d s1 = _mm_add_pd(zero, _mm_loadu_pd(p + 2));  // z of v, x of v + 1
    __m128d s2 = _mm_add_pd(zero, _mm_loadu_pd(p + 4));  // y, z of v + 1
    for (int k = 0; k < 4; ++k) {
      const double* qa = src + 3 * size_t(na[k]);
      const double* qb = src + 3 * size_t(na[4 + k]);
      s0 = _mm_add_pd(s0, _mm_loadu_pd(qa));
      s1 = _mm_add_pd(s1, _mm_loadh_pd(_mm_load_sd(qa + 2), qb));
      s2 = _mm_add_pd(s2, _mm_loadu_pd(qb + 1));
    }
    double* q = dst + 3 * size_t(v);
    _mm_storeu_pd(q, _mm_div_pd(s0, five));
    _mm_storeu_pd(q + 2, _mm_div_pd(s1, five));
    _mm_storeu_pd(q + 4, _mm_div_pd(s2, five));
  }
  return v;
}

}  // namespace ffseg
#endif
