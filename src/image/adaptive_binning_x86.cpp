// Adaptive binning's AVX-512F pass (see adaptive_binning.cpp), built only
// for x86; adaptive_binning() calls it when the engine's dispatch picks it.
#include "adaptive_binning_x86.h"

#if FFSEG_X86
#include <cmath>

// GCC 12's AVX-512 headers trip -Wmaybe-uninitialized on their own
// _mm512_undefined_* placeholders (GCC bug 105593).
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {

// One pass of Algorithm 2's visits with at most 8 clusters held in vector
// lanes (AVX-512F): from visit t0 on, until the end or until a 9th cluster
// would open (that visit is left undone, idx still on it). Per visit the same
// decisions and arithmetic as the scalar loop in adaptive_binning: d_k =
// |p - c_k| per lane (closed lanes c = +inf), the first lane of the minimum,
// and the member sums updated in lane `best` only (masked adds, so each
// cluster's sums are formed in visiting order as before).
__attribute__((target("avx512f"))) FFSEG_NO_FMA_CONTRACT uint32_t binning_visits8(
    const float* x, uint32_t n, uint32_t stride, uint64_t* idx_io, uint32_t t0, double R, double S, double* c,
    uint32_t* cnt, double* sum, double* sum2, uint32_t* K_io) {
  uint32_t K = *K_io;
  const __mmask8 live = __mmask8((1u << K) - 1u);
  __m512d cv = _mm512_mask_loadu_pd(_mm512_set1_pd(INFINITY), live, c);
  __m512d sv = _mm512_mask_loadu_pd(_mm512_setzero_pd(), live, sum);
  __m512d s2v = _mm512_mask_loadu_pd(_mm512_setzero_pd(), live, sum2);
  int64_t cn[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  for (uint32_t k = 0; k < K; ++k) cn[k] = cnt[k];
  __m512i nv = _mm512_loadu_si512(cn);
  const __m512i one = _mm512_set1_epi64(1);
  const __m512i abs_bits = _mm512_set1_epi64(0x7fffffffffffffffLL);
  uint64_t idx = *idx_io;
  uint32_t t = t0;
  // In chunks of kChunk visits: first, with the clusters fixed, every
  // visit's nearest cluster and distance (8 visits per vector, clusters in
  // turn, a strictly smaller distance replacing: the first minimum, as the
  // lane reduction finds it); then the visits in order, the members' sums
  // as before. A visit that opens a cluster changes the nearest cluster of
  // the visits after it: their distances to the new one are compared
  // (strictly smaller wins: it has the highest index).
  constexpr uint32_t kChunk = 64;
  alignas(64) double pv[kChunk], dv_[kChunk];
  alignas(64) int64_t bv[kChunk];
  double cs[8];
  for (uint32_t k = 0; k < 8; ++k) cs[k] = k < K ? c[k] : INFINITY;
  while (t < n) {
    const uint32_t m = n - t < kChunk ? n - t : kChunk;
    uint64_t id = idx;
    for (uint32_t i = 0; i < m; ++i) {
      pv[i] = x[id];
      id += stride;
      if (id >= n) id -= n;
    }
    for (uint32_t i = m; i < kChunk; ++i) pv[i] = 0;
    for (uint32_t i = 0; i < kChunk; i += 8) {
      const __m512d pp = _mm512_load_pd(pv + i);
      __m512d dm = _mm512_set1_pd(INFINITY);
      __m512i bi = _mm512_setzero_si512();
      for (uint32_t k = 0; k < K; ++k) {
        const __m512d e = _mm512_sub_pd(pp, _mm512_set1_pd(cs[k]));
        const __m512d dk = _mm512_castsi512_pd(_mm512_and_si512(_mm512_castpd_si512(e), abs_bits));
        const __mmask8 lt = _mm512_cmp_pd_mask(dk, dm, _CMP_LT_OQ);
        dm = _mm512_mask_mov_pd(dm, lt, dk);
        bi = _mm512_mask_mov_epi64(bi, lt, _mm512_set1_epi64(int64_t(k)));
      }
      _mm512_store_pd(dv_ + i, dm);
      _mm512_store_si512(bv + i, bi);
    }
    uint32_t i = 0;
    for (; i < m; ++i, ++t) {
      const double p = pv[i];
      uint64_t next = idx + stride;
      if (next >= n) next -= n;
      if (!std::isfinite(p)) {
        idx = next;
        continue;
      }
      const double d = dv_[i];
      const uint32_t best = uint32_t(bv[i]);
      if (K == 0 || d >= S) {
        if (K == 8) break;
        const __mmask8 mk = __mmask8(1u << K);
        cv = _mm512_mask_mov_pd(cv, mk, _mm512_set1_pd(p));
        sv = _mm512_mask_mov_pd(sv, mk, _mm512_setzero_pd());
        s2v = _mm512_mask_mov_pd(s2v, mk, _mm512_setzero_pd());
        nv = _mm512_mask_mov_epi64(nv, mk, one);
        cs[K] = p;
        for (uint32_t j = i + 1; j < m; ++j) {
          const double dj = std::fabs(pv[j] - p);
          if (dj < dv_[j]) dv_[j] = dj, bv[j] = int64_t(K);
        }
        ++K;
      } else if (d <= R) {
        const __m512d ev = _mm512_sub_pd(_mm512_set1_pd(p), cv);  // p - c_k
        const __mmask8 mk = __mmask8(1u << best);
        sv = _mm512_mask_add_pd(sv, mk, sv, ev);
        s2v = _mm512_mask_add_pd(s2v, mk, s2v, _mm512_mul_pd(ev, ev));
        nv = _mm512_mask_add_epi64(nv, mk, nv, one);
      }
      idx = next;
    }
    if (i < m) break;  // a 9th cluster would open here
  }
  const __mmask8 out = __mmask8((1u << K) - 1u);
  _mm512_mask_storeu_pd(c, out, cv);
  _mm512_mask_storeu_pd(sum, out, sv);
  _mm512_mask_storeu_pd(sum2, out, s2v);
  _mm512_storeu_si512(cn, nv);
  for (uint32_t k = 0; k < K; ++k) cnt[k] = uint32_t(cn[k]);
  *K_io = K;
  *idx_io = idx;
  return t;
}

}  // namespace

uint32_t binning_visits_avx512(const float* x, uint32_t n, uint32_t stride, uint64_t* idx_io, uint32_t t0, double R,
                               double S, double* c, uint32_t* cnt, double* sum, double* sum2, uint32_t* K_io) {
  return binning_visits8(x, n, stride, idx_io, t0, R, S, c, cnt, sum, sum2, K_io);
}

}  // namespace ffseg
#endif
