// exp_block's AVX-512F + FMA kernel (see exp_block.h), built only for x86;
// exp_block.cpp calls it when the engine's dispatch picks it.
#include "exp_block_x86.h"

#include "cpu_x86.h"
#if FFSEG_X86 && defined(__x86_64__)
#include <cmath>
#include <cstring>

// GCC 12's AVX-512 headers trip -Wmaybe-uninitialized on their own
// _mm512_undefined_* placeholders (GCC bug 105593).
#if !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <immintrin.h>

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {


// ---- double-double helpers (table construction only) ------------------------

struct DD {
  double hi, lo;
};
DD two_sum(double a, double b) {
  const double s = a + b, bb = s - a;
  return {s, (a - (s - bb)) + (b - bb)};
}
DD fast_two_sum(double a, double b) {  // |a| >= |b|
  const double s = a + b;
  return {s, b - (s - a)};
}
DD two_prod(double a, double b) {
  const double p = a * b;
  return {p, std::fma(a, b, -p)};
}
DD dd_add(DD a, DD b) {
  const DD s = two_sum(a.hi, b.hi);
  return fast_two_sum(s.hi, s.lo + a.lo + b.lo);
}
DD dd_mul(DD a, DD b) {
  DD p = two_prod(a.hi, b.hi);
  p.lo += a.hi * b.lo + a.lo * b.hi;
  return fast_two_sum(p.hi, p.lo);
}
DD dd_div(DD a, double d) {
  const double q = a.hi / d;
  const DD p = two_prod(q, d);
  const double r = (((a.hi - p.hi) - p.lo) + a.lo) / d;
  return fast_two_sum(q, r);
}

// ln 2 to 106 bits.
constexpr double kLn2Hi = 0x1.62e42fefa39efp-1;
constexpr double kLn2Lo = 0x1.abc9e3b39803fp-56;

struct ExpTable {
  alignas(64) double hi[16];  // 2^(j/16) = hi + lo
  alignas(64) double lo[16];
  double c1, c2, c3;          // ln2/16 = c1 + c2 + c3; c1 39 bits, c2 14 bits
  ExpTable() {
    const DD ln2 = {kLn2Hi, kLn2Lo};
    for (int j = 0; j < 16; ++j) {
      const DD z = dd_mul(ln2, DD{double(j) / 16.0, 0.0});
      DD sum = {1.0, 0.0}, term = {1.0, 0.0};
      for (int n = 1; n <= 34; ++n) {  // z < 0.7: 0.7^34 / 34! < 2^-140
        term = dd_div(dd_mul(term, z), double(n));
        sum = dd_add(sum, term);
      }
      hi[j] = sum.hi;
      lo[j] = sum.lo;
    }
    // Split ln2/16 (exact division by a power of two): c1 keeps the top 39
    // bits of the high part, so k c1 and k c2 are exact for |k| < 2^14.
    const double h = kLn2Hi / 16.0;
    uint64_t b;
    std::memcpy(&b, &h, sizeof b);
    b &= ~((uint64_t(1) << (52 - 38)) - 1);
    std::memcpy(&c1, &b, sizeof b);
    c2 = h - c1;
    c3 = kLn2Lo / 16.0;
  }
};


const ExpTable& table() {
  static const ExpTable t;
  return t;
}

// Eight lanes: out = exp(x) correctly rounded where certified (see the
// header), ok bit set; other lanes undefined.
__attribute__((target("avx512f,fma"))) FFSEG_NO_FMA_CONTRACT inline __mmask8 exp8(const ExpTable& T,
                                                                                      __m512d x, __m512d* out) {
  const __m512d inv_c = _mm512_set1_pd(16.0 / kLn2Hi);
  const __m512d shifter = _mm512_set1_pd(0x1.8p52);
  // k = nearest integer to x 16 / ln2 (the shifter's low mantissa bits).
  const __m512d t = _mm512_add_pd(_mm512_mul_pd(x, inv_c), shifter);
  const __m512d kd = _mm512_sub_pd(t, shifter);
  const __m512i ki = _mm512_sub_epi64(_mm512_castpd_si512(t), _mm512_castpd_si512(shifter));
  // r = x - k ln2/16 = rh + rl: x - k c1 exact (Sterbenz, k c1 exact), minus
  // k c2 (exact product) as a two-sum, minus k c3 into the tail.
  const __m512d r1 = _mm512_fnmadd_pd(kd, _mm512_set1_pd(T.c1), x);
  const __m512d kc2 = _mm512_mul_pd(kd, _mm512_set1_pd(T.c2));
  const __m512d rh = _mm512_sub_pd(r1, kc2);
  const __m512d bb = _mm512_sub_pd(rh, r1);
  const __m512d e2 = _mm512_add_pd(_mm512_sub_pd(r1, _mm512_sub_pd(rh, bb)), _mm512_sub_pd(_mm512_sub_pd(_mm512_setzero_pd(), kc2), bb));
  const __m512d rl = _mm512_sub_pd(e2, _mm512_mul_pd(kd, _mm512_set1_pd(T.c3)));
  // p = exp(rh) - 1 - rh, degree 9 (truncation < 2^-76 for |rh| < 0.0217).
  __m512d p = _mm512_set1_pd(1.0 / 362880.0);
  p = _mm512_fmadd_pd(p, rh, _mm512_set1_pd(1.0 / 40320.0));
  p = _mm512_fmadd_pd(p, rh, _mm512_set1_pd(1.0 / 5040.0));
  p = _mm512_fmadd_pd(p, rh, _mm512_set1_pd(1.0 / 720.0));
  p = _mm512_fmadd_pd(p, rh, _mm512_set1_pd(1.0 / 120.0));
  p = _mm512_fmadd_pd(p, rh, _mm512_set1_pd(1.0 / 24.0));
  p = _mm512_fmadd_pd(p, rh, _mm512_set1_pd(1.0 / 6.0));
  p = _mm512_fmadd_pd(p, rh, _mm512_set1_pd(0.5));
  p = _mm512_mul_pd(p, _mm512_mul_pd(rh, rh));
  // exp(rh + rl) = (1 + rh + p)(1 + rl + ...): q = p + rl + rl (rh + p).
  const __m512d q = _mm512_add_pd(p, _mm512_fmadd_pd(rl, _mm512_add_pd(rh, p), rl));
  // E = 1 + rh + q as a double-double (|rh| < 1).
  const __m512d one = _mm512_set1_pd(1.0);
  const __m512d s = _mm512_add_pd(one, rh);
  const __m512d se = _mm512_sub_pd(rh, _mm512_sub_pd(s, one));
  const __m512d elo0 = _mm512_add_pd(se, q);
  const __m512d eh = _mm512_add_pd(s, elo0);
  const __m512d el = _mm512_sub_pd(elo0, _mm512_sub_pd(eh, s));
  // y = 2^(j/16) E, j = k mod 16 (two-register permutes, no gather).
  const __m512i j = _mm512_and_si512(ki, _mm512_set1_epi64(15));
  const __m512d th = _mm512_permutex2var_pd(_mm512_load_pd(T.hi), j, _mm512_load_pd(T.hi + 8));
  const __m512d tl = _mm512_permutex2var_pd(_mm512_load_pd(T.lo), j, _mm512_load_pd(T.lo + 8));
  const __m512d ph = _mm512_mul_pd(th, eh);
  __m512d pl = _mm512_fmsub_pd(th, eh, ph);
  pl = _mm512_add_pd(pl, _mm512_fmadd_pd(th, el, _mm512_mul_pd(tl, eh)));
  const __m512d yh = _mm512_add_pd(ph, pl);
  const __m512d yl = _mm512_sub_pd(pl, _mm512_sub_pd(yh, ph));
  // Certified: |yl| <= 0.48 ulp on its side (yh in [0.978, 1.96)).
  const __m512d ayl =
      _mm512_castsi512_pd(_mm512_and_si512(_mm512_castpd_si512(yl), _mm512_set1_epi64(0x7fffffffffffffffLL)));
  const __mmask8 below = _mm512_cmp_pd_mask(yh, one, _CMP_LT_OQ) |
                         (_mm512_cmp_pd_mask(yh, one, _CMP_EQ_OQ) & _mm512_cmp_pd_mask(yl, _mm512_setzero_pd(), _CMP_LT_OQ));
  const __m512d lim = _mm512_mask_blend_pd(below, _mm512_set1_pd(0.48 * 0x1p-52), _mm512_set1_pd(0.48 * 0x1p-53));
  __mmask8 ok = _mm512_cmp_pd_mask(ayl, lim, _CMP_LE_OQ);
  ok &= _mm512_cmp_pd_mask(x, _mm512_set1_pd(-670.0), _CMP_GT_OQ);
  ok &= _mm512_cmp_pd_mask(x, _mm512_set1_pd(709.0), _CMP_LT_OQ);
  // Scale by 2^m, m = floor(k / 16): exact (normal range for x in (-670, 709)).
  const __m512i m = _mm512_srai_epi64(ki, 4);
  const __m512d two_m = _mm512_castsi512_pd(_mm512_slli_epi64(_mm512_add_epi64(m, _mm512_set1_epi64(1023)), 52));
  *out = _mm512_mul_pd(yh, two_m);
  return ok;
}

// Uncertified lanes are recorded per vector (a mask byte) and redone after
// the vector loop, so the loop itself has no data-dependent branch.
template <bool FALLBACK>
__attribute__((target("avx512f,fma"))) FFSEG_NO_FMA_CONTRACT void exp8_block(double* v, uint32_t n) {
  const ExpTable& T = table();
  constexpr uint32_t kChunk = 64;  // vectors per pass of the fallback loop (4 KB of stack)
  uint8_t okm[kChunk];
  double xs[kChunk * 8];
  uint32_t t = 0;
  while (t + 8 <= n) {
    uint32_t nvec = (n - t) / 8;
    if (nvec > kChunk) nvec = kChunk;
    for (uint32_t q = 0; q < nvec; ++q) {
      const __m512d x = _mm512_loadu_pd(v + t + 8 * q);
      __m512d y;
      okm[q] = exp8(T, x, &y);
      _mm512_storeu_pd(xs + 8 * q, x);
      _mm512_storeu_pd(v + t + 8 * q, y);
    }
    for (uint32_t q = 0; q < nvec; ++q) {
      uint32_t bad = ~uint32_t(okm[q]) & 0xFFu;
      while (bad) {
        const int l = __builtin_ctz(bad);
        bad &= bad - 1;
        v[t + 8 * q + l] = FALLBACK ? std::exp(xs[8 * q + l]) : NAN;
      }
    }
    t += 8 * nvec;
  }
  if (t < n) {
    double buf[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (uint32_t q = t; q < n; ++q) buf[q - t] = v[q];
    const __m512d x = _mm512_loadu_pd(buf);
    __m512d y;
    const __mmask8 ok = exp8(T, x, &y);
    double ys[8];
    _mm512_storeu_pd(ys, y);
    for (uint32_t q = t; q < n; ++q) {
      const int l = int(q - t);
      v[q] = (ok >> l & 1) ? ys[l] : (FALLBACK ? std::exp(buf[l]) : NAN);
    }
  }
}

// exp of the non-zero values only (exp(0) = 1 needs no evaluation): they are
// packed by register compress, evaluated, and expanded back.
__attribute__((target("avx512f,fma"))) FFSEG_NO_FMA_CONTRACT void exp8_block_nonzero(double* v,
                                                                                               uint32_t n) {
  constexpr uint32_t kChunk = 512;
  double packed[kChunk + 8];
  uint8_t nzm[kChunk / 8];
  const __m512d one = _mm512_set1_pd(1.0);
  uint32_t t = 0;
  while (t + 8 <= n) {
    uint32_t nvec = (n - t) / 8;
    if (nvec > kChunk / 8) nvec = kChunk / 8;
    uint32_t np = 0;
    for (uint32_t q = 0; q < nvec; ++q) {
      const __m512d x = _mm512_loadu_pd(v + t + 8 * q);
      const __mmask8 nz = _mm512_cmp_pd_mask(x, _mm512_setzero_pd(), _CMP_NEQ_UQ);
      _mm512_storeu_pd(packed + np, _mm512_maskz_compress_pd(nz, x));
      np += uint32_t(__builtin_popcount(nz));
      nzm[q] = nz;
    }
    exp8_block<true>(packed, np);
    uint32_t pos = 0;
    for (uint32_t q = 0; q < nvec; ++q) {
      const __mmask8 nz = nzm[q];
      _mm512_storeu_pd(v + t + 8 * q, _mm512_mask_expand_pd(one, nz, _mm512_loadu_pd(packed + pos)));
      pos += uint32_t(__builtin_popcount(nz));
    }
    t += 8 * nvec;
  }
  for (; t < n; ++t) v[t] = v[t] == 0 ? 1.0 : std::exp(v[t]);
}

}  // namespace

void exp_block_avx512(double* v, uint32_t n) { exp8_block<true>(v, n); }
void exp_block_nonzero_avx512(double* v, uint32_t n) { exp8_block_nonzero(v, n); }
void exp_block_kernel_only_avx512(double* v, uint32_t n) { exp8_block<false>(v, n); }

}  // namespace ffseg
#endif
