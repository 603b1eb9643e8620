#include "intensity_model.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include "cpu_x86.h"
#if FFSEG_X86
// GCC 12's AVX-512 headers trip -Wmaybe-uninitialized on their own
// _mm512_undefined_* placeholders (GCC bug 105593).
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>
#endif

#include "exp_block.h"
#include "smoothing.h"

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {

constexpr uint32_t kWorkBins = IntensityModel::kMaxBins;

// a f(v) without the constant 1 / sqrt(2 pi): a component's weighted density.
double weighted_density(const Gaussian1& g, double v) {
  const double d = v - g.mean;
  return g.weight / std::sqrt(g.var) * std::exp(-0.5 * d * d / g.var);
}

// The component of c[0..m) with the highest weighted density at v (the first
// of equals); *sum (if given) receives the densities' sum, in index order.
uint32_t most_probable(const Gaussian1* c, uint32_t m, double v, double* sum = nullptr) {
  uint32_t best = 0;
  double bd = -1, s = 0;
  for (uint32_t i = 0; i < m; ++i) {
    const double f = weighted_density(c[i], v);
    s += f;
    if (f > bd) bd = f, best = i;
  }
  if (sum) *sum = s;
  return best;
}

uint32_t gcd32(uint32_t a, uint32_t b) {
  while (b) {
    const uint32_t t = a % b;
    a = b;
    b = t;
  }
  return a;
}

void say(char* msg, size_t n, const char* text) {
  if (msg && n) std::snprintf(msg, n, "%s", text);
}

// E-step over all samples (eq. 5.2.4) with the responsibilities' sums for the
// M-step; M components as a compile-time count so the per-sample arrays live
// in registers. Per sample and component the operations and their order are
// those of the plain loop, so the sums are bit-identical for every M.
//
// The log-likelihood only decides when EM stops. EXACT: summed as
// mx + log(s) per sample, in sample order (the reference). Otherwise the
// per-sample log is replaced by one log per kLogChunk samples of the product of
// their s (s in [1, M], so a chunk's product stays below 2^192): ll->sum gets
// sum mx + sum log(product), ll->abs_mx sum |mx|, ll->log_s the sum of the
// chunk logs. em_fit bounds the difference to the exact sum with these and
// falls back to an EXACT pass when the stopping decision is not certain.
constexpr uint32_t kLogChunk = 64;

struct LogLik {
  double sum = 0;     // sum over samples of mx + log(s) (exact or by chunks)
  double abs_mx = 0;  // sum |mx| (chunked mode only)
  double log_s = 0;   // sum log(s) (chunked mode only)
};

// Eight doubles; the kernels below are instantiated for the baseline target
// (GCC splits them into SSE2 pairs) and for AVX-512F. Helpers taking these
// are always inlined into the kernel, so no call crosses the ABI difference
// GCC warns about.
#pragma GCC diagnostic ignored "-Wpsabi"
typedef double D8 __attribute__((vector_size(64)));
typedef int64_t I8 __attribute__((vector_size(64)));

__attribute__((always_inline)) inline D8 splat8(double v) { return D8{v, v, v, v, v, v, v, v}; }
__attribute__((always_inline)) inline D8 load8(const double* p) {
  D8 r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
__attribute__((always_inline)) inline void store8(double* p, D8 v) { std::memcpy(p, &v, sizeof v); }

// E-step in blocks of kBlock samples: the finite samples are gathered (shifted
// to double), then per 8 samples the exponents l_i - max_i l_i (vector), the
// exps (exp_block), s = sum_i exp in component order, z_i = exp_i / s,
// z_i x, z_i x x (vector), and last the sums and the log-likelihood in sample
// order (scalar). Per sample these are the operations of the plain loop
//   d = x - mu_i; l_i = la_i - d d ih_i; mx = max; e_i = exp(l_i - mx);
//   s = sum e_i; ll += mx + log(s); z = e_i (1 / s); Z_i += z; Zx_i += z x; Zxx_i += z x x,
// each in IEEE double without contraction, so the sums are bit-identical.
template <uint32_t M, bool EXACT>
__attribute__((always_inline)) inline void e_step_body(const float* x, uint32_t n, double shift, const double* la,
                                                       const double* mu, const double* ih, double* Z, double* Zx,
                                                       double* Zxx, LogLik* ll_io) {
  constexpr uint32_t kBlock = 64;  // 3 x 8 x 64 doubles of stack for M = 8
  alignas(64) double xv[kBlock], mxv[kBlock], sv[kBlock];
  alignas(64) double ev[M][kBlock], zx[M][kBlock], zxx[M][kBlock];
  double z0[M], z1[M], z2[M];
  for (uint32_t i = 0; i < M; ++i) z0[i] = Z[i], z1[i] = Zx[i], z2[i] = Zxx[i];
  double ll = 0, smx = 0, amx = 0, lsum = 0, prod = 1;
  uint32_t in_chunk = 0;
  for (uint32_t j0 = 0; j0 < n; j0 += kBlock) {
    const uint32_t j1 = n - j0 < kBlock ? n : j0 + kBlock;
    uint32_t nb = 0;
    for (uint32_t j = j0; j < j1; ++j)
      if (std::isfinite(x[j])) xv[nb++] = double(x[j]) - shift;
    if (nb == 0) continue;
    const uint32_t nv = (nb + 7) & ~7u;
    for (uint32_t b = nb; b < nv; ++b) xv[b] = 0;  // padding lanes, never summed
    for (uint32_t b = 0; b < nv; b += 8) {
      const D8 xj = load8(xv + b);
      D8 l[M], mx = splat8(-INFINITY);
#pragma GCC unroll 8
      for (uint32_t i = 0; i < M; ++i) {
        const D8 d = xj - splat8(mu[i]);
        l[i] = splat8(la[i]) - d * d * splat8(ih[i]);
        mx = l[i] > mx ? l[i] : mx;
      }
#pragma GCC unroll 8
      for (uint32_t i = 0; i < M; ++i) store8(ev[i] + b, l[i] - mx);
      store8(mxv + b, mx);
    }
    // std::exp of every exponent; the largest term's is exp(0) = 1, packed out.
    // One call over the rows (kBlock apart); the gaps of a short last block
    // are zeroed first (packed out too), the padding lanes' values are finite.
    for (uint32_t i = 0; i + 1 < M; ++i)
      for (uint32_t b = nv; b < kBlock; ++b) ev[i][b] = 0;
    exp_block_nonzero(ev[0], (M - 1) * kBlock + nv);
    for (uint32_t i = 0; i < M; ++i)
      for (uint32_t b = nb; b < nv; ++b) ev[i][b] = 1;  // padding lanes: s stays finite
    for (uint32_t b = 0; b < nv; b += 8) {
      const D8 xj = load8(xv + b);
      D8 e[M], s = splat8(0.0);
#pragma GCC unroll 8
      for (uint32_t i = 0; i < M; ++i) {
        e[i] = load8(ev[i] + b);
        s += e[i];
      }
      store8(sv + b, s);
      const D8 inv = splat8(1.0) / s;
#pragma GCC unroll 8
      for (uint32_t i = 0; i < M; ++i) {
        const D8 z = e[i] * inv;  // z_ij, eq. 5.2.4
        const D8 zxj = z * xj;
        store8(ev[i] + b, z);
        store8(zx[i] + b, zxj);
        store8(zxx[i] + b, zxj * xj);
      }
    }
    for (uint32_t b = 0; b < nb; ++b) {
      const double mx = mxv[b], sb = sv[b];
      if (EXACT) {
        ll += mx + std::log(sb);
      } else {
        smx += mx;
        amx += std::fabs(mx);
        prod *= sb;
        if (++in_chunk == kLogChunk) {
          lsum += std::log(prod);
          prod = 1;
          in_chunk = 0;
        }
      }
#pragma GCC unroll 8
      for (uint32_t i = 0; i < M; ++i) {
        z0[i] += ev[i][b];
        z1[i] += zx[i][b];
        z2[i] += zxx[i][b];
      }
    }
  }
  for (uint32_t i = 0; i < M; ++i) Z[i] = z0[i], Zx[i] = z1[i], Zxx[i] = z2[i];
  if (EXACT) {
    ll_io->sum = ll;
  } else {
    if (in_chunk) lsum += std::log(prod);
    ll_io->sum = smx + lsum;
    ll_io->abs_mx = amx;
    ll_io->log_s = lsum;
  }
}

template <bool EXACT>
__attribute__((always_inline)) inline void e_step_switch(uint32_t m, const float* x, uint32_t n, double shift,
                                                         const double* la, const double* mu, const double* ih,
                                                         double* Z, double* Zx, double* Zxx, LogLik* ll) {
  static_assert(IntensityModel::kMaxComponents == 8, "one e_step instance per component count");
  switch (m) {
    case 1: e_step_body<1, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 2: e_step_body<2, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 3: e_step_body<3, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 4: e_step_body<4, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 5: e_step_body<5, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 6: e_step_body<6, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 7: e_step_body<7, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    default: e_step_body<8, EXACT>(x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
  }
}

template <bool EXACT>
void e_step_base(uint32_t m, const float* x, uint32_t n, double shift, const double* la, const double* mu,
                 const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
  e_step_switch<EXACT>(m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

#if FFSEG_X86
template <bool EXACT>
__attribute__((target("avx512f"))) FFSEG_NO_FMA_CONTRACT void e_step_avx512(
    uint32_t m, const float* x, uint32_t n, double shift, const double* la, const double* mu, const double* ih,
    double* Z, double* Zx, double* Zxx, LogLik* ll) {
  e_step_switch<EXACT>(m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}
#endif

template <bool EXACT>
void e_step_m(uint32_t m, const float* x, uint32_t n, double shift, const double* la, const double* mu,
              const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
#if FFSEG_X86
  static const bool wide = __builtin_cpu_supports("avx512f");
  if (wide) {
    e_step_avx512<EXACT>(m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
    return;
  }
#endif
  e_step_base<EXACT>(m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

void e_step_dispatch(bool exact, uint32_t m, const float* x, uint32_t n, double shift, const double* la,
                     const double* mu, const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
  if (exact) e_step_m<true>(m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
  else e_step_m<false>(m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

// The exact mean log-likelihood (the reference sum) at parameters la, mu, ih.
double exact_ll(uint32_t m, const float* x, uint32_t n, uint32_t nf, double shift, const double* la, const double* mu,
                const double* ih, double half_log_2pi) {
  double Z[IntensityModel::kMaxComponents] = {}, Zx[IntensityModel::kMaxComponents] = {},
         Zxx[IntensityModel::kMaxComponents] = {};
  LogLik L;
  e_step_dispatch(true, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, &L);
  return L.sum / nf - half_log_2pi;
}

// Bound on |exact - chunked| mean log-likelihood. Per sample the reference
// rounds log(s) (glibc: < 1 ulp) and mx + log(s); the recursive sum of n terms
// errs by at most (n - 1) u sum |t_j|. The chunked sum rounds each product
// (kLogChunk - 1 relative errors of u, log(1 + k u) <= k u per chunk), the
// chunk logs and the two sums. Both are below (2 n + 16) u (sum |mx| + sum
// log s + n); a factor 4 covers the chunked log_s standing in for the true
// sum of log s and second-order terms. Then / nf and - log(2 pi) / 2 round
// once each.
double ll_error_bound(const LogLik& L, uint32_t n, uint32_t nf, double ll) {
  const double u = 1.1102230246251565e-16;  // 2^-53
  const double sum_abs = L.abs_mx + std::fabs(L.log_s) + double(n);
  return 4.0 * (2.0 * double(n) + 16.0) * u * sum_abs / double(nf) + 8.0 * u * (std::fabs(ll) + 1.0);
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

bool binning_vectorised() {
  static const bool v = __builtin_cpu_supports("avx512f");
  return v;
}
#endif

}  // namespace

uint32_t adaptive_binning(const float* x, uint32_t n, const BinningSettings& s, Bin* bins, uint32_t max_bins,
                          uint32_t stride) {
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
    if (K <= 8 && binning_vectorised())
      t = binning_visits_avx512(x, n, stride, &idx, 0, R, S, c, cnt, sum, sum2, &K);
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

namespace {

// M-step (eq. 5.2.5-5.2.7; 5.2.7 is the variance) from the E-step's sums
// over nf samples, variances floored at vmin; a component that lost its
// samples (Z < 1e-4 nf) is dropped and the weights renormalised (*m
// shrinks). False, parameters untouched, when every component would go.
bool m_step(const double* Z, const double* Zx, const double* Zxx, double nf, double vmin, double* a, double* mu,
            double* v, uint32_t* m) {
  uint32_t k = 0;
  for (uint32_t i = 0; i < *m; ++i) k += !(Z[i] < 1e-4 * nf);
  if (k == 0) return false;
  k = 0;
  for (uint32_t i = 0; i < *m; ++i) {
    if (Z[i] < 1e-4 * nf) continue;
    a[k] = Z[i] / nf;
    mu[k] = Zx[i] / Z[i];
    v[k] = std::max(Zxx[i] / Z[i] - mu[k] * mu[k], vmin);
    ++k;
  }
  if (k < *m) {
    double t = 0;
    for (uint32_t i = 0; i < k; ++i) t += a[i];
    for (uint32_t i = 0; i < k; ++i) a[i] /= t;
    *m = k;
  }
  return true;
}

// em_fit; exact_result: also report the exact (reference) log-likelihood,
// which may cost one more pass (the engine does not read it).
EmResult em_fit_impl(const float* x, uint32_t n, Gaussian1* comp, uint32_t* m_io, uint32_t max_iterations,
                     double var_floor, double tol, bool exact_result) {
  EmResult r;
  uint32_t m = *m_io;
  if (n == 0 || m == 0) return r;
  // Work about the sample mean (conditioning of the second moments).
  double shift = 0, lo = INFINITY, hi = -INFINITY;
  uint32_t nf = 0;  // finite samples; the others are skipped
  for (uint32_t j = 0; j < n; ++j) {
    if (!std::isfinite(x[j])) continue;
    ++nf;
    shift += x[j];
    lo = std::min(lo, double(x[j]));
    hi = std::max(hi, double(x[j]));
  }
  if (nf == 0) return r;
  shift /= nf;
  const double scale = hi > lo ? hi - lo : std::max(1.0, std::fabs(shift));
  const double vmin = std::max(var_floor, 1e-12 * scale * scale);
  double a[IntensityModel::kMaxComponents], mu[IntensityModel::kMaxComponents], v[IntensityModel::kMaxComponents];
  for (uint32_t i = 0; i < m; ++i) {
    a[i] = comp[i].weight > 0 ? comp[i].weight : 1.0 / m;
    mu[i] = comp[i].mean - shift;
    v[i] = std::max(comp[i].var, vmin);
  }
  const double half_log_2pi = 0.5 * std::log(6.283185307179586);
  // ll: exact (the reference sum) when ll_exact, else chunked with error
  // bound ll_err (see ll_error_bound). The stopping test ll - ll_prev < tol is
  // decided on the chunked values when the bounds make it certain, else both
  // sides are recomputed exactly (the previous E-step's parameters are kept
  // for that), so EM takes exactly the reference's iterations.
  const uint32_t M = IntensityModel::kMaxComponents;
  double ll_prev = -INFINITY, prev_err = 0;
  bool prev_exact = true;
  double pla[M], pmu[M], pih[M];  // parameters of the previous E-step
  uint32_t pm = 0, cm = 0;
  double la[M], ih[M], emu[M];
  double ll = 0;
  bool ll_exact = false;
  // Which log-likelihood the reference reports: none, the last E-step's
  // (cur), or the one before the last loop exit (prev, kept in pla/pmu/pih).
  enum { kReportNone, kReportCur, kReportPrev } report = kReportNone;
  uint32_t it = 0;
  while (it < max_iterations) {
    ++it;
    double Z[M] = {}, Zx[M] = {}, Zxx[M] = {};
    for (uint32_t i = 0; i < m; ++i) {
      la[i] = std::log(a[i]) - 0.5 * std::log(v[i]);
      ih[i] = 0.5 / v[i];
      emu[i] = mu[i];
    }
    const uint32_t em = m;
    cm = em;
    LogLik L;
    e_step_dispatch(false, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, &L);
    ll = L.sum / nf - half_log_2pi;
    ll_exact = false;
    const double ll_err = ll_error_bound(L, n, nf, ll);
    if (!m_step(Z, Zx, Zxx, nf, vmin, a, mu, v, &m)) {
      // cannot happen (the weights sum to n); keep the last parameters
      report = it > 1 ? kReportPrev : kReportNone;
      break;
    }
    bool stop = false;
    if (it > 1) {
      const double margin = ll_err + prev_err;
      const double diff = ll - ll_prev;
      if (diff < tol - margin) {
        stop = true;
      } else if (!(diff >= tol + margin)) {  // not certain (or NaN): decide on exact values
        if (!prev_exact) ll_prev = exact_ll(pm, x, n, nf, shift, pla, pmu, pih, half_log_2pi);
        ll = exact_ll(em, x, n, nf, shift, la, emu, ih, half_log_2pi);
        ll_exact = true;
        stop = ll - ll_prev < tol;
      }
    }
    if (stop) {
      report = kReportCur;
      break;
    }
    report = kReportPrev;  // the loop may end here: this iteration's values move to prev
    ll_prev = ll;
    prev_err = ll_exact ? 0 : ll_err;
    prev_exact = ll_exact;
    for (uint32_t i = 0; i < em; ++i) pla[i] = la[i], pmu[i] = emu[i], pih[i] = ih[i];
    pm = em;
  }
  if (report == kReportCur) {
    r.log_likelihood = ll_exact || !exact_result ? ll : exact_ll(cm, x, n, nf, shift, la, emu, ih, half_log_2pi);
  } else if (report == kReportPrev) {
    r.log_likelihood = prev_exact || !exact_result ? ll_prev : exact_ll(pm, x, n, nf, shift, pla, pmu, pih, half_log_2pi);
  }
  r.iterations = it;
  for (uint32_t i = 0; i < m; ++i) {
    comp[i].weight = a[i];
    comp[i].mean = mu[i] + shift;
    comp[i].var = v[i];
  }
  *m_io = m;
  return r;
}

}  // namespace

namespace {

// EM over weighted points (IntensityModel::compress): point j stands for
// w[j] samples with mean v[j] (shifted by the caller) and sum of squares
// ss[j] about v[j]. The same iteration as em_fit_impl, each point's
// responsibilities taken at its mean: Z_i += w z_i, Zx_i += w z_i v,
// Zxx_i += z_i (w v^2 + ss), so every component's first and second moments
// are exact where a point's samples share its responsibilities. Same start,
// variance floor, dropping rule and stopping test (plain sums).
void em_fit_weighted(const double* v, const double* w, const double* ss, uint32_t np, Gaussian1* comp,
                     uint32_t* m_io, uint32_t max_iterations, double var_floor, double tol) {
  uint32_t m = *m_io;
  if (np == 0 || m == 0) return;
  double nf = 0, lo = INFINITY, hi = -INFINITY;
  for (uint32_t j = 0; j < np; ++j) {
    nf += w[j];
    lo = std::min(lo, v[j]);
    hi = std::max(hi, v[j]);
  }
  if (!(nf > 0)) return;
  const double scale = hi > lo ? hi - lo : 1.0;
  const double vmin = std::max(var_floor, 1e-12 * scale * scale);
  constexpr uint32_t M = IntensityModel::kMaxComponents;
  double a[M], mu[M], var[M];
  for (uint32_t i = 0; i < m; ++i) {
    a[i] = comp[i].weight > 0 ? comp[i].weight : 1.0 / m;
    mu[i] = comp[i].mean;
    var[i] = std::max(comp[i].var, vmin);
  }
  constexpr uint32_t kBlock = 64;
  double ev[M * kBlock], mx[kBlock];
  double ll_prev = -INFINITY;
  for (uint32_t it = 1; it <= max_iterations; ++it) {
    double la[M], ih[M], Z[M] = {}, Zx[M] = {}, Zxx[M] = {};
    for (uint32_t i = 0; i < m; ++i) {
      la[i] = std::log(a[i]) - 0.5 * std::log(var[i]);
      ih[i] = 0.5 / var[i];
    }
    double ll = 0;
    for (uint32_t j0 = 0; j0 < np; j0 += kBlock) {
      const uint32_t nb = np - j0 < kBlock ? np - j0 : kBlock;
      for (uint32_t b = 0; b < nb; ++b) {
        const double x = v[j0 + b];
        double top = -INFINITY;
        for (uint32_t i = 0; i < m; ++i) {
          const double d = x - mu[i];
          const double l = la[i] - d * d * ih[i];
          ev[i * kBlock + b] = l;
          top = l > top ? l : top;
        }
        mx[b] = top;
        for (uint32_t i = 0; i < m; ++i) ev[i * kBlock + b] -= top;
      }
      for (uint32_t i = 0; i < m; ++i) exp_block(ev + i * kBlock, nb);
      for (uint32_t b = 0; b < nb; ++b) {
        const uint32_t j = j0 + b;
        double sum = 0;
        for (uint32_t i = 0; i < m; ++i) sum += ev[i * kBlock + b];
        ll += w[j] * (mx[b] + std::log(sum));
        const double inv = 1.0 / sum, x = v[j], wx = w[j] * x, second = wx * x + ss[j];
        for (uint32_t i = 0; i < m; ++i) {
          const double z = ev[i * kBlock + b] * inv;
          Z[i] += w[j] * z;
          Zx[i] += z * wx;
          Zxx[i] += z * second;
        }
      }
    }
    ll /= nf;
    if (!m_step(Z, Zx, Zxx, nf, vmin, a, mu, var, &m)) break;
    if (it > 1 && ll - ll_prev < tol) break;
    ll_prev = ll;
  }
  for (uint32_t i = 0; i < m; ++i) {
    comp[i].weight = a[i];
    comp[i].mean = mu[i];
    comp[i].var = var[i];
  }
  *m_io = m;
}

}  // namespace

uint32_t IntensityModel::compress(const float* x, uint32_t n, double shift, double width, double* v, double* w,
                                  double* ss) {
  double lo = INFINITY, hi = -INFINITY;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) {
      lo = std::min(lo, double(x[j]));
      hi = std::max(hi, double(x[j]));
    }
  if (!(lo <= hi)) return 0;
  double h = width;
  if (!(h > 0) || !std::isfinite(h) || (hi - lo) / h >= double(kCompressBins - 1)) h = (hi - lo) / (kCompressBins - 1);
  const uint32_t nb = h > 0 ? uint32_t((hi - lo) / h) + 1 : 1;
  for (uint32_t b = 0; b < nb; ++b) v[b] = w[b] = ss[b] = 0;
  for (uint32_t j = 0; j < n; ++j) {
    if (!std::isfinite(x[j])) continue;
    uint32_t b = h > 0 ? uint32_t((double(x[j]) - lo) / h) : 0;
    if (b >= nb) b = nb - 1;
    const double d = double(x[j]) - shift;
    w[b] += 1;
    v[b] += d;
    ss[b] += d * d;
  }
  // Non-empty bins, in order: mean and sum of squares about it.
  uint32_t k = 0;
  for (uint32_t b = 0; b < nb; ++b) {
    if (w[b] == 0) continue;
    const double mean = v[b] / w[b];
    const double q = ss[b] - w[b] * mean * mean;
    v[k] = mean;
    w[k] = w[b];
    ss[k] = q > 0 ? q : 0;
    ++k;
  }
  return k;
}

uint32_t em_fit_compressed(const float* x, uint32_t n, Gaussian1* comp, uint32_t* m, uint32_t max_iterations,
                           double var_floor, double width, double* hist, double tol) {
  double mean = 0;
  uint32_t nf = 0;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) mean += x[j], ++nf;
  if (nf == 0 || *m == 0) return 0;
  mean /= nf;
  double* hv = hist;
  double* hw = hist + IntensityModel::kCompressBins;
  double* hs = hist + 2 * size_t(IntensityModel::kCompressBins);
  const uint32_t np = IntensityModel::compress(x, n, mean, width, hv, hw, hs);
  for (uint32_t i = 0; i < *m; ++i) comp[i].mean -= mean;
  em_fit_weighted(hv, hw, hs, np, comp, m, max_iterations, var_floor, tol);
  for (uint32_t i = 0; i < *m; ++i) comp[i].mean += mean;
  return np;
}

EmResult em_fit(const float* x, uint32_t n, Gaussian1* comp, uint32_t* m_io, uint32_t max_iterations,
                double var_floor, double tol) {
  return em_fit_impl(x, n, comp, m_io, max_iterations, var_floor, tol, true);
}

void IntensityModel::carve(Arena& a, uint32_t max_samples) {
  cap_ = max_samples;
  samples_ = a.alloc<float>(max_samples);
  hist_ = a.alloc<double>(size_t(3) * kCompressBins);
  lut_ = a.alloc<float>(kLutMax);
  reset();
}

ModelStatus IntensityModel::fit(const SmoothedRoi& roi, const double c[3], double r, const IntensityModelSettings& s,
                                const LutSpec& lut, char* msg, size_t msg_len) {
  reset();
  if (samples_ == nullptr || cap_ == 0) {
    say(msg, msg_len, "intensity model: sample memory was not carved");
    return ModelStatus::not_carved;
  }
  if (!(std::isfinite(c[0]) && std::isfinite(c[1]) && std::isfinite(c[2]) && std::isfinite(r) && r > 0)) {
    say(msg, msg_len, "intensity model: the sphere is not finite");
    return ModelStatus::bad_settings;
  }
  if (!roi.valid()) {
    say(msg, msg_len, "intensity model: no smoothed region");
    return ModelStatus::no_samples;
  }
  // Index box of the ball, intersected with the stored region.
  double pc[3];
  roi.world_to_index(c, pc);
  int64_t lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    double dir[3] = {0, 0, 0}, row[3];
    // |row a of the inverse affine| = index units per mm along a.
    for (int b = 0; b < 3; ++b) {
      dir[0] = dir[1] = dir[2] = 0;
      dir[b] = 1;
      double p[3];
      roi.world_dir_to_index(dir, p);
      row[b] = p[a];
    }
    const double g = r * std::sqrt(row[0] * row[0] + row[1] * row[1] + row[2] * row[2]);
    const double l = std::ceil(pc[a] - g), h = std::floor(pc[a] + g) + 1;
    lo[a] = l < double(roi.data_lo()[a]) ? roi.data_lo()[a] : int64_t(l);
    hi[a] = h > double(roi.data_hi()[a]) ? roi.data_hi()[a] : int64_t(h);
    if (lo[a] >= hi[a]) {
      say(msg, msg_len, "intensity model: the sphere does not meet the smoothed region");
      return ModelStatus::no_samples;
    }
  }
  const double r2 = r * r;
  auto inside = [&](int64_t i, int64_t j, int64_t k) {
    const double p[3] = {double(i), double(j), double(k)};
    double w[3];
    roi.index_to_world(p, w);
    const double d0 = w[0] - c[0], d1 = w[1] - c[1], d2 = w[2] - c[2];
    return d0 * d0 + d1 * d1 + d2 * d2 <= r2;
  };
  uint64_t count = 0;
  for (int64_t k = lo[2]; k < hi[2]; ++k)
    for (int64_t j = lo[1]; j < hi[1]; ++j)
      for (int64_t i = lo[0]; i < hi[0]; ++i) count += inside(i, j, k);
  if (count == 0) {
    say(msg, msg_len, "intensity model: no voxel centre inside the sphere");
    return ModelStatus::no_samples;
  }
  // Uniform stride over the inside voxels in scan order: voxel m is taken when
  // floor((m + 1) q) > floor(m q), q = cap / count.
  const double q = count <= cap_ ? 1.0 : double(cap_) / double(count);
  uint32_t n = 0;
  uint64_t m = 0;
  for (int64_t k = lo[2]; k < hi[2]; ++k)
    for (int64_t j = lo[1]; j < hi[1]; ++j)
      for (int64_t i = lo[0]; i < hi[0]; ++i) {
        if (!inside(i, j, k)) continue;
        const bool take = q >= 1.0 || std::floor(double(m + 1) * q) > std::floor(double(m) * q);
        ++m;
        if (take && n < cap_) samples_[n++] = roi.at(i, j, k);
      }
  const double range = roi.robust_high() - roi.robust_low();
  const double rho = s.sigma_floor_fraction;
  if (!(std::isfinite(rho) && rho >= 0)) {
    say(msg, msg_len, "intensity model: sigma_floor_fraction must be >= 0");
    return ModelStatus::bad_settings;
  }
  const double floor = std::sqrt(roi.noise_sigma() * roi.noise_sigma() + rho * range * rho * range);
  const ModelStatus st = fit_samples(samples_, n, floor, s, lut, msg, msg_len);
  if (st != ModelStatus::ok || !s.scene_competitors) return st;

  // The scene: the same mixture fit (Algorithm 2 + EM, same floor) over the
  // requested crop box, subsampled uniformly into the sample buffer (the
  // sphere's samples are no longer needed).
  const int64_t* blo = roi.lo();
  const int64_t* bhi = roi.hi();
  const uint64_t total =
      uint64_t(bhi[0] - blo[0]) * uint64_t(bhi[1] - blo[1]) * uint64_t(bhi[2] - blo[2]);
  const uint32_t scap = cap_ < kSceneSamples ? cap_ : kSceneSamples;
  const double qs = total <= scap ? 1.0 : double(scap) / double(total);
  uint32_t ns = 0;
  uint64_t ms = 0;
  double smean = 0;
  for (int64_t k = blo[2]; k < bhi[2]; ++k)
    for (int64_t j = blo[1]; j < bhi[1]; ++j)
      for (int64_t i = blo[0]; i < bhi[0]; ++i) {
        const bool take = qs >= 1.0 || std::floor(double(ms + 1) * qs) > std::floor(double(ms) * qs);
        ++ms;
        if (!take || ns >= scap) continue;
        const float v = roi.at(i, j, k);
        if (!std::isfinite(v)) continue;
        samples_[ns++] = v;
        smean += v;
      }
  if (ns == 0) return st;
  smean /= ns;
  double sm2 = 0;
  for (uint32_t j = 0; j < ns; ++j) sm2 += (samples_[j] - smean) * (samples_[j] - smean);
  sm2 /= ns;
  Gaussian1 scene[kMaxComponents];
  uint32_t scene_bins = 0;
  const uint32_t sm = fit_mixture(samples_, ns, smean, sm2, floor, s, scene, &scene_bins, hist_);
  // The object's classes: the scene components that claim (highest weighted
  // density) the mean of some object component. The others compete.
  bool own[kMaxComponents] = {};
  for (uint32_t i = 0; i < m_; ++i) own[most_probable(scene, sm, comp_[i].mean)] = true;
  obj_weight_ = 0;
  sm_ = 0;
  for (uint32_t c = 0; c < sm; ++c) {
    if (own[c]) obj_weight_ += scene[c].weight;
    else scene_[sm_++] = scene[c];
  }
  if (sm_ > 0) normalise_and_tabulate(lut);  // the table now includes the competition
  return st;
}

ModelStatus IntensityModel::fit_samples(const float* x, uint32_t n, double sigma_floor,
                                        const IntensityModelSettings& s, const LutSpec& lut, char* msg,
                                        size_t msg_len) {
  m_ = 0;
  lut_n_ = 0;
  if (n == 0 || x == nullptr) {
    say(msg, msg_len, "intensity model: no samples");
    return ModelStatus::no_samples;
  }
  if (!(std::isfinite(s.bin_radius) && s.bin_radius >= 0 && std::isfinite(s.bin_separation) &&
        s.bin_separation >= 0 && std::isfinite(sigma_floor) && sigma_floor >= 0)) {
    say(msg, msg_len, "intensity model: binning radius/separation and sigma floor must be finite and >= 0");
    return ModelStatus::bad_settings;
  }
  n_ = n;
  sigma_floor_ = sigma_floor;
  double mean = 0, m2 = 0;
  uint32_t nf = 0;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) mean += x[j], ++nf;
  if (nf == 0) {
    say(msg, msg_len, "intensity model: no finite sample");
    return ModelStatus::no_samples;
  }
  mean /= nf;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) m2 += (x[j] - mean) * (x[j] - mean);
  m2 /= nf;
  m_ = fit_mixture(x, n, mean, m2, sigma_floor, s, comp_, &bins_);
  sm_ = 0;
  normalise_and_tabulate(lut);
  return ModelStatus::ok;
}

uint32_t IntensityModel::fit_mixture(const float* x, uint32_t n, double mean, double m2, double sigma_floor,
                                     const IntensityModelSettings& s, Gaussian1* comp, uint32_t* bins_found,
                                     double* hist) {
  const double sd = std::sqrt(m2);
  // The scale of the automatic R and S: the floor, else the samples' spread.
  const double ref = sigma_floor > 0 ? sigma_floor : (sd > 0 ? sd : 1.0);
  BinningSettings b;
  b.radius = s.bin_radius > 0 ? s.bin_radius : 2 * ref;
  b.separation = s.bin_separation > 0 ? s.bin_separation : 4 * ref;
  b.min_count = s.bin_min_count > 0 ? s.bin_min_count : std::max<uint32_t>(8, (n + 19) / 20);
  if (b.min_count > n) b.min_count = n;
  Bin bins[kMaxComponents];
  *bins_found = adaptive_binning(x, n, b, bins, kMaxComponents, mixing_stride(n));
  uint32_t m = *bins_found < kMaxComponents ? *bins_found : kMaxComponents;
  const double vfloor = sigma_floor * sigma_floor;
  if (m == 0) {  // every bin fell under N_m: one component over all samples
    comp[0].weight = 1;
    comp[0].mean = mean;
    comp[0].var = std::max(m2, vfloor);
    m = 1;
  } else {
    double total = 0;
    for (uint32_t i = 0; i < m; ++i) total += bins[i].count;
    for (uint32_t i = 0; i < m; ++i) {
      comp[i].weight = bins[i].count / total;
      comp[i].mean = bins[i].centroid;
      comp[i].var = std::max(bins[i].var, vfloor);
    }
  }
  if (hist && n > kCompressAbove) {
    // Many samples (the scene): EM over bins a 32nd of the floor wide.
    em_fit_compressed(x, n, comp, &m, s.em_iterations, vfloor, ref / kBinsPerSigma, hist, 1e-9);
  } else {
    em_fit_impl(x, n, comp, &m, s.em_iterations, vfloor, 1e-9, false);
  }
  return m;
}

double IntensityModel::density(double v) const {
  double s = 0;
  for (uint32_t i = 0; i < m_; ++i) s += weighted_density(comp_[i], v);
  return s;
}

double IntensityModel::class_mean(double v) const { return m_ ? comp_[most_probable(comp_, m_, v)].mean : 0.0; }

bool IntensityModel::rival_mean(double v, double* mean) const {
  if (m_ == 0 || sm_ == 0 || !(v == v)) return false;
  double rival = 0;
  *mean = scene_[most_probable(scene_, sm_, v, &rival)].mean;
  return rival > obj_weight_ * density(v);
}

double IntensityModel::g_direct(double v) const {
  if (m_ == 0 || !(v == v)) return 0;
  const double dv = density(v);
  if (sm_ > 0) {  // a competing class of the scene is more probable: not object
    double rival = 0;
    for (uint32_t c = 0; c < sm_; ++c) rival += weighted_density(scene_[c], v);
    if (rival > obj_weight_ * dv) return 0;
  }
  const double g = dv / peak_;
  return g < 1 ? g : 1;
}

void IntensityModel::normalise_and_tabulate(const LutSpec& lut) {
  // Peak of the mixture: a grid over mu +- 4 sigma and every mean, then a
  // golden-section refinement around the best grid point.
  double lo = INFINITY, hi = -INFINITY, best_v = comp_[0].mean, best = 0;
  for (uint32_t i = 0; i < m_; ++i) {
    const double sd = std::sqrt(comp_[i].var);
    lo = std::min(lo, comp_[i].mean - 4 * sd);
    hi = std::max(hi, comp_[i].mean + 4 * sd);
    const double d = density(comp_[i].mean);
    if (d > best) best = d, best_v = comp_[i].mean;
  }
  const int kGrid = 4096;
  const double h = (hi - lo) / kGrid;
  for (int t = 0; t <= kGrid; ++t) {
    const double v = lo + h * t;
    const double d = density(v);
    if (d > best) best = d, best_v = v;
  }
  double a = best_v - h, b = best_v + h;
  const double gr = 0.6180339887498949;
  for (int it = 0; it < 60; ++it) {
    const double c1 = b - gr * (b - a), c2 = a + gr * (b - a);
    if (density(c1) > density(c2)) b = c2; else a = c1;
  }
  best = std::max(best, density(0.5 * (a + b)));
  peak_ = best > 0 ? best : 1;

  lut_n_ = 0;
  if (lut_ == nullptr || !(std::isfinite(lut.slope) && lut.slope != 0 && std::isfinite(lut.intercept))) return;
  double raw0;
  uint32_t count;
  switch (lut.type) {
    case VoxelType::U8: raw0 = 0, count = 256; break;
    case VoxelType::I16: raw0 = -32768, count = 65536; break;
    case VoxelType::U16: raw0 = 0, count = 65536; break;
    default: return;  // i32, f32, f64: direct evaluation
  }
  lut_v0_ = lut.slope * raw0 + lut.intercept;
  lut_inv_step_ = 1.0 / lut.slope;
  // Where every component's and competitor's exponent -d^2 / (2 var) is below
  // -746, each exp is 0 (e^-746 < 2^-1076, under half the least subnormal), so
  // g_direct is 0 there: only values within sqrt(1492 var) (plus a relative
  // margin for rounding) of some mean are evaluated.
  double vlo = INFINITY, vhi = -INFINITY;
  auto widen = [&](const Gaussian1& c) {
    const double w = std::sqrt(1492.0 * c.var) * (1 + 1e-6) + 1e-6 * std::fabs(c.mean) + 1e-300;
    vlo = std::min(vlo, c.mean - w);
    vhi = std::max(vhi, c.mean + w);
  };
  for (uint32_t i = 0; i < m_; ++i) widen(comp_[i]);
  for (uint32_t c = 0; c < sm_; ++c) widen(scene_[c]);
  for (uint32_t i = 0; i < count; ++i) {
    const double v = lut.slope * (raw0 + i) + lut.intercept;
    lut_[i] = (v >= vlo && v <= vhi) || !(std::isfinite(vlo) && std::isfinite(vhi)) ? float(g_direct(v)) : 0.0f;
  }
  lut_n_ = count;
}

}  // namespace ffseg
