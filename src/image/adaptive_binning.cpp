#include "adaptive_binning.h"

#include <algorithm>
#include <cmath>
#include "cpu_x86.h"
#if FFSEG_X86
// GCC 12's AVX-512 headers trip -Wmaybe-uninitialized on their own
// _mm512_undefined_* placeholders (GCC bug 105593).
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>
#endif

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {

constexpr uint32_t kWorkBins = kMaxBinningClusters;

uint32_t gcd32(uint32_t a, uint32_t b) {
  while (b) {
    const uint32_t t = a % b;
    a = b;
    b = t;
  }
  return a;
}

}  // namespace

uint32_t mixing_stride(uint32_t n) {
  if (n <= 2) return 1;
  uint32_t s = uint32_t(0.6180339887498949 * double(n) + 0.5);
  if (s < 1) s = 1;
  while (s < n && gcd32(s, n) != 1) ++s;
  return s < n ? s : 1;
}

namespace {

#if FFSEG_X86
// One pass of Algorithm 2's visits with at most 8 clusters held in vector
// lanes (AVX-512F): from visit t0 on, until the end or until a 9th cluster
// would open (that visit is left undone, idx still on it). Per visit the same
// decisions and arithmetic as the scalar loop in adaptive_binning: d_k =
// |p - c_k| per lane (closed lanes c = +inf), the first lane of the minimum,
// and the member sums updated in lane `best` only (masked adds, so each
// cluster's sums are formed in visiting order as before).
__attribute__((target("avx512f"))) FFSEG_NO_FMA_CONTRACT uint32_t binning_visits_avx512(
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

#endif

}  // namespace

uint32_t adaptive_binning(const CpuDispatch& cpu, const float* x, uint32_t n, const BinningSettings& s, Bin* bins,
                          uint32_t max_bins, uint32_t stride) {
  if (n == 0) return 0;
  stride %= n;
  if (stride == 0 || gcd32(stride, n) != 1) stride = 1;
  const double R = s.radius, S = s.separation;
  const uint32_t Nm = s.min_count;
  // Working clusters: centroid, and per pass the members' count, sum and sum of
  // squares of (x - centroid).
  double c[kWorkBins], sum[kWorkBins], sum2[kWorkBins], prev[kWorkBins];
  uint32_t cnt[kWorkBins];
  uint32_t K = 0, prevK = 0;
  const double tol = 1e-6 * (R > 0 ? R : 1.0);
  for (uint32_t pass = 0; pass < (s.max_passes ? s.max_passes : 1); ++pass) {
    for (uint32_t k = 0; k < K; ++k) cnt[k] = 0, sum[k] = 0, sum2[k] = 0;
    uint64_t idx = 0;
    uint32_t t = 0;
#if FFSEG_X86
    if (K <= 8 && cpu.kernel(KernelFamily::mixture) == Isa::avx512)
      t = binning_visits_avx512(x, n, stride, &idx, 0, R, S, c, cnt, sum, sum2, &K);
#else
    (void)cpu;
#endif
    for (; t < n; ++t) {
      const double p = x[idx];
      idx += stride;
      if (idx >= n) idx -= n;
      if (!std::isfinite(p)) continue;
      // Nearest cluster k to p (Algorithm 2).
      uint32_t best = 0;
      double d = INFINITY;
      for (uint32_t k = 0; k < K; ++k) {
        const double dk = std::fabs(p - c[k]);
        if (dk < d) d = dk, best = k;
      }
      if (K == 0 || d >= S) {  // no cluster, or too far from all: a new cluster with p
        if (K < kWorkBins) {
          c[K] = p, cnt[K] = 1, sum[K] = 0, sum2[K] = 0;
          ++K;
        }
      } else if (d <= R) {  // close enough: p joins cluster k
        const double e = p - c[best];
        ++cnt[best];
        sum[best] += e;
        sum2[best] += e * e;
      }  // R < d < S: left for the next pass
    }
    // Every cluster moves to its members' centroid (sum2 becomes their variance).
    uint32_t live = 0;
    for (uint32_t k = 0; k < K; ++k) {
      if (cnt[k] == 0) continue;
      const double mean = sum[k] / cnt[k];
      c[live] = c[k] + mean;
      cnt[live] = cnt[k];
      sum[live] = 0;
      sum2[live] = std::max(0.0, sum2[k] / cnt[k] - mean * mean);
      ++live;
    }
    K = live;
    // Keep the separation guarantee: centroids that drifted closer than S are
    // merged (closest pair first). Without this a single mode seeded from its
    // tail splits into two stable halves less than S apart.
    for (;;) {
      uint32_t ba = 0, bb = 0;
      double bd = INFINITY;
      for (uint32_t a = 0; a < K; ++a)
        for (uint32_t b = a + 1; b < K; ++b) {
          const double d = std::fabs(c[a] - c[b]);
          if (d < bd) bd = d, ba = a, bb = b;
        }
      if (!(bd < S)) break;
      const double na = cnt[ba], nb = cnt[bb], nt = na + nb;
      const double cm = (na * c[ba] + nb * c[bb]) / nt;
      sum2[ba] = (na * (sum2[ba] + (c[ba] - cm) * (c[ba] - cm)) + nb * (sum2[bb] + (c[bb] - cm) * (c[bb] - cm))) / nt;
      c[ba] = cm;
      cnt[ba] += cnt[bb];
      --K;
      c[bb] = c[K], cnt[bb] = cnt[K], sum2[bb] = sum2[K];
    }
    // Clusters with fewer than N_m members are removed.
    uint32_t kept = 0;
    for (uint32_t k = 0; k < K; ++k) {
      if (cnt[k] < Nm) continue;
      c[kept] = c[k], cnt[kept] = cnt[k], sum2[kept] = sum2[k];
      ++kept;
    }
    K = kept;
    bool same = K == prevK;
    for (uint32_t k = 0; same && k < K; ++k) same = std::fabs(c[k] - prev[k]) <= tol;
    for (uint32_t k = 0; k < K; ++k) prev[k] = c[k];
    prevK = K;
    if (same) break;
  }
  // The max_bins largest, sorted by centroid.
  uint32_t order[kWorkBins];
  for (uint32_t k = 0; k < K; ++k) order[k] = k;
  std::sort(order, order + K, [&](uint32_t a, uint32_t b) { return cnt[a] != cnt[b] ? cnt[a] > cnt[b] : c[a] < c[b]; });
  const uint32_t out = K < max_bins ? K : max_bins;
  std::sort(order, order + out, [&](uint32_t a, uint32_t b) { return c[a] < c[b]; });
  for (uint32_t i = 0; i < out; ++i) {
    bins[i].centroid = c[order[i]];
    bins[i].count = cnt[order[i]];
    bins[i].var = sum2[order[i]];
  }
  return K;
}

}  // namespace ffseg
