// The envelope Cholesky's AVX2 + FMA and AVX-512F tile kernels and the
// drivers compiled with them (the templates in envelope_kernels.h), built
// only for x86; EnvelopeCholesky calls them when the engine's dispatch picks
// them.
#include "envelope_kernels.h"

#if FFSEG_X86
#include <immintrin.h>

namespace ffseg {
namespace envelope_kernels {

namespace {

#define FFSEG_AVX2 __attribute__((target("avx2,fma")))
#define FFSEG_AVX512 __attribute__((target("avx512f,avx2,fma")))

// Sums of a, b, c, d -> one vector {sum a, sum b, sum c, sum d}.
FFSEG_AVX2 static inline __m256d hsum4(__m256d a, __m256d b, __m256d c, __m256d d) {
  const __m256d ab = _mm256_hadd_pd(a, b);  // a01 b01 a23 b23
  const __m256d cd = _mm256_hadd_pd(c, d);  // c01 d01 c23 d23
  const __m256d lo = _mm256_permute2f128_pd(ab, cd, 0x20);
  const __m256d hi = _mm256_permute2f128_pd(ab, cd, 0x31);
  return _mm256_add_pd(lo, hi);
}

// Rows r0..r3 (4 doubles each) <-> columns c0..c3: the 4 x 4 transpose,
// its own inverse.
FFSEG_AVX2 static inline void transpose4(__m256d& a, __m256d& b, __m256d& c, __m256d& d) {
  const __m256d t0 = _mm256_unpacklo_pd(a, b);  // a0 b0 a2 b2
  const __m256d t1 = _mm256_unpackhi_pd(a, b);  // a1 b1 a3 b3
  const __m256d t2 = _mm256_unpacklo_pd(c, d);  // c0 d0 c2 d2
  const __m256d t3 = _mm256_unpackhi_pd(c, d);  // c1 d1 c3 d3
  a = _mm256_permute2f128_pd(t0, t2, 0x20);
  b = _mm256_permute2f128_pd(t1, t3, 0x20);
  c = _mm256_permute2f128_pd(t0, t2, 0x31);
  d = _mm256_permute2f128_pd(t1, t3, 0x31);
}

struct KAvx2 {
  // The tile's four rows minus their dot products, turned into columns so
  // that each column's recurrence runs over the four rows at once: the
  // scalar loop's operations as GCC compiles it for these targets (each
  // x -= a b one fused multiply-add, written out here so that it does not
  // hang on the compiler's choice), lane by lane, without the round trips
  // through memory its scalar updates of X took.
  FFSEG_AVX2 static inline void solve_tile(double* X, std::size_t wr, const double* D, std::size_t wj,
                                           const double* inv, const double* acc) {
    __m256d c0 = _mm256_sub_pd(_mm256_loadu_pd(X), _mm256_loadu_pd(acc));
    __m256d c1 = _mm256_sub_pd(_mm256_loadu_pd(X + wr), _mm256_loadu_pd(acc + 4));
    __m256d c2 = _mm256_sub_pd(_mm256_loadu_pd(X + 2 * wr), _mm256_loadu_pd(acc + 8));
    __m256d c3 = _mm256_sub_pd(_mm256_loadu_pd(X + 3 * wr), _mm256_loadu_pd(acc + 12));
    transpose4(c0, c1, c2, c3);
    const double* d1 = D + wj;
    const double* d2 = D + 2 * wj;
    const double* d3 = D + 3 * wj;
    c0 = _mm256_mul_pd(c0, _mm256_set1_pd(inv[0]));
    c1 = _mm256_fnmadd_pd(c0, _mm256_set1_pd(d1[0]), c1);
    c1 = _mm256_mul_pd(c1, _mm256_set1_pd(inv[1]));
    c2 = _mm256_fnmadd_pd(c0, _mm256_set1_pd(d2[0]), c2);
    c2 = _mm256_fnmadd_pd(c1, _mm256_set1_pd(d2[1]), c2);
    c2 = _mm256_mul_pd(c2, _mm256_set1_pd(inv[2]));
    c3 = _mm256_fnmadd_pd(c0, _mm256_set1_pd(d3[0]), c3);
    c3 = _mm256_fnmadd_pd(c1, _mm256_set1_pd(d3[1]), c3);
    c3 = _mm256_fnmadd_pd(c2, _mm256_set1_pd(d3[2]), c3);
    c3 = _mm256_mul_pd(c3, _mm256_set1_pd(inv[3]));
    transpose4(c0, c1, c2, c3);
    _mm256_storeu_pd(X, c0);
    _mm256_storeu_pd(X + wr, c1);
    _mm256_storeu_pd(X + 2 * wr, c2);
    _mm256_storeu_pd(X + 3 * wr, c3);
  }
  FFSEG_AVX2 static inline void dot4x4(const double* R, std::size_t wr, const double* J,
                                       std::size_t wj, std::size_t len, double* acc) {
    const double* r0 = R;
    const double* r1 = R + wr;
    const double* r2 = R + 2 * wr;
    const double* r3 = R + 3 * wr;
    for (int jp = 0; jp < 4; jp += 2) {
      const double* j0 = J + jp * wj;
      const double* j1 = j0 + wj;
      __m256d a00 = _mm256_setzero_pd(), a01 = a00, a10 = a00, a11 = a00, a20 = a00, a21 = a00,
              a30 = a00, a31 = a00;
      for (std::size_t k = 0; k < len; k += 4) {
        const __m256d b0 = _mm256_load_pd(j0 + k), b1 = _mm256_load_pd(j1 + k);
        __m256d x = _mm256_load_pd(r0 + k);
        a00 = _mm256_fmadd_pd(x, b0, a00);
        a01 = _mm256_fmadd_pd(x, b1, a01);
        x = _mm256_load_pd(r1 + k);
        a10 = _mm256_fmadd_pd(x, b0, a10);
        a11 = _mm256_fmadd_pd(x, b1, a11);
        x = _mm256_load_pd(r2 + k);
        a20 = _mm256_fmadd_pd(x, b0, a20);
        a21 = _mm256_fmadd_pd(x, b1, a21);
        x = _mm256_load_pd(r3 + k);
        a30 = _mm256_fmadd_pd(x, b0, a30);
        a31 = _mm256_fmadd_pd(x, b1, a31);
      }
      alignas(32) double t[8];
      _mm256_store_pd(t, hsum4(a00, a01, a10, a11));
      _mm256_store_pd(t + 4, hsum4(a20, a21, a30, a31));
      acc[0 + jp] = t[0];
      acc[1 + jp] = t[1];
      acc[4 + jp] = t[2];
      acc[5 + jp] = t[3];
      acc[8 + jp] = t[4];
      acc[9 + jp] = t[5];
      acc[12 + jp] = t[6];
      acc[13 + jp] = t[7];
    }
  }
  FFSEG_AVX2 static inline void dot4x3(const double* R, std::size_t wr, const double* y0,
                                       const double* y1, const double* y2, std::size_t len,
                                       double* acc) {
    const double* r0 = R;
    const double* r1 = R + wr;
    const double* r2 = R + 2 * wr;
    const double* r3 = R + 3 * wr;
    __m256d a00 = _mm256_setzero_pd(), a01 = a00, a02 = a00, a10 = a00, a11 = a00, a12 = a00,
            a20 = a00, a21 = a00, a22 = a00, a30 = a00, a31 = a00, a32 = a00;
    for (std::size_t k = 0; k < len; k += 4) {
      const __m256d b0 = _mm256_load_pd(y0 + k), b1 = _mm256_load_pd(y1 + k),
                    b2 = _mm256_load_pd(y2 + k);
      __m256d x = _mm256_load_pd(r0 + k);
      a00 = _mm256_fmadd_pd(x, b0, a00);
      a01 = _mm256_fmadd_pd(x, b1, a01);
      a02 = _mm256_fmadd_pd(x, b2, a02);
      x = _mm256_load_pd(r1 + k);
      a10 = _mm256_fmadd_pd(x, b0, a10);
      a11 = _mm256_fmadd_pd(x, b1, a11);
      a12 = _mm256_fmadd_pd(x, b2, a12);
      x = _mm256_load_pd(r2 + k);
      a20 = _mm256_fmadd_pd(x, b0, a20);
      a21 = _mm256_fmadd_pd(x, b1, a21);
      a22 = _mm256_fmadd_pd(x, b2, a22);
      x = _mm256_load_pd(r3 + k);
      a30 = _mm256_fmadd_pd(x, b0, a30);
      a31 = _mm256_fmadd_pd(x, b1, a31);
      a32 = _mm256_fmadd_pd(x, b2, a32);
    }
    alignas(32) double t[12];
    _mm256_store_pd(t, hsum4(a00, a01, a02, a10));
    _mm256_store_pd(t + 4, hsum4(a11, a12, a20, a21));
    _mm256_store_pd(t + 8, hsum4(a22, a30, a31, a32));
    for (int i = 0; i < 12; ++i) acc[i] = t[i];
  }
  FFSEG_AVX2 static inline void axpy4x3(const double* R, std::size_t wr, const double* x,
                                        double* y0, double* y1, double* y2, std::size_t len) {
    const double* r0 = R;
    const double* r1 = R + wr;
    const double* r2 = R + 2 * wr;
    const double* r3 = R + 3 * wr;
    const __m256d x00 = _mm256_set1_pd(x[0]), x01 = _mm256_set1_pd(x[1]), x02 = _mm256_set1_pd(x[2]);
    const __m256d x10 = _mm256_set1_pd(x[3]), x11 = _mm256_set1_pd(x[4]), x12 = _mm256_set1_pd(x[5]);
    const __m256d x20 = _mm256_set1_pd(x[6]), x21 = _mm256_set1_pd(x[7]), x22 = _mm256_set1_pd(x[8]);
    const __m256d x30 = _mm256_set1_pd(x[9]), x31 = _mm256_set1_pd(x[10]), x32 = _mm256_set1_pd(x[11]);
    for (std::size_t k = 0; k < len; k += 4) {
      const __m256d l0 = _mm256_load_pd(r0 + k), l1 = _mm256_load_pd(r1 + k),
                    l2 = _mm256_load_pd(r2 + k), l3 = _mm256_load_pd(r3 + k);
      __m256d s = _mm256_mul_pd(l0, x00);
      s = _mm256_fmadd_pd(l1, x10, s);
      s = _mm256_fmadd_pd(l2, x20, s);
      s = _mm256_fmadd_pd(l3, x30, s);
      _mm256_store_pd(y0 + k, _mm256_sub_pd(_mm256_load_pd(y0 + k), s));
      s = _mm256_mul_pd(l0, x01);
      s = _mm256_fmadd_pd(l1, x11, s);
      s = _mm256_fmadd_pd(l2, x21, s);
      s = _mm256_fmadd_pd(l3, x31, s);
      _mm256_store_pd(y1 + k, _mm256_sub_pd(_mm256_load_pd(y1 + k), s));
      s = _mm256_mul_pd(l0, x02);
      s = _mm256_fmadd_pd(l1, x12, s);
      s = _mm256_fmadd_pd(l2, x22, s);
      s = _mm256_fmadd_pd(l3, x32, s);
      _mm256_store_pd(y2 + k, _mm256_sub_pd(_mm256_load_pd(y2 + k), s));
    }
  }
};

// out[0..3] = sums of a, b, c, d (all in 512-bit registers, one store).
FFSEG_AVX512 static inline void hsum4_512(__m512d a, __m512d b, __m512d c, __m512d d, double* out) {
  const __m512d ab = _mm512_add_pd(_mm512_maskz_unpacklo_pd(0xFF, a, b), _mm512_maskz_unpackhi_pd(0xFF, a, b));
  const __m512d cd = _mm512_add_pd(_mm512_maskz_unpacklo_pd(0xFF, c, d), _mm512_maskz_unpackhi_pd(0xFF, c, d));
  // 128-bit lanes: ab = (a,b)x4 partials, cd = (c,d)x4 partials.
  const __m512d t = _mm512_add_pd(_mm512_maskz_shuffle_f64x2(0xFF, ab, cd, 0x88), _mm512_maskz_shuffle_f64x2(0xFF, ab, cd, 0xDD));
  // t lanes: (a,b) (a,b) (c,d) (c,d)
  const __m512d u = _mm512_add_pd(_mm512_maskz_shuffle_f64x2(0xFF, t, t, 0x08), _mm512_maskz_shuffle_f64x2(0xFF, t, t, 0x0D));
  // u lanes 0, 1: (a,b) (c,d)
  alignas(64) double tmp[8];
  _mm512_store_pd(tmp, u);
  out[0] = tmp[0];
  out[1] = tmp[1];
  out[2] = tmp[2];
  out[3] = tmp[3];
}

struct KAvx512 {
  FFSEG_AVX512 static inline void dot4x4(const double* R, std::size_t wr, const double* J,
                                         std::size_t wj, std::size_t len, double* acc) {
    const double* r0 = R;
    const double* r1 = R + wr;
    const double* r2 = R + 2 * wr;
    const double* r3 = R + 3 * wr;
    const double* j0 = J;
    const double* j1 = J + wj;
    const double* j2 = J + 2 * wj;
    const double* j3 = J + 3 * wj;
    __m512d a[16];
    for (int i = 0; i < 16; ++i) a[i] = _mm512_setzero_pd();
    std::size_t k = 0;
    // Rows are 32-byte aligned; len is a multiple of 4: one masked head step
    // when len is not a multiple of 8, then full 8-wide steps.
    if (len & 4) {
      const __mmask8 m = 0x0F;
      const __m512d b0 = _mm512_maskz_loadu_pd(m, j0), b1 = _mm512_maskz_loadu_pd(m, j1),
                    b2 = _mm512_maskz_loadu_pd(m, j2), b3 = _mm512_maskz_loadu_pd(m, j3);
      const __m512d x0 = _mm512_maskz_loadu_pd(m, r0), x1 = _mm512_maskz_loadu_pd(m, r1),
                    x2 = _mm512_maskz_loadu_pd(m, r2), x3 = _mm512_maskz_loadu_pd(m, r3);
      a[0] = _mm512_mul_pd(x0, b0);
      a[1] = _mm512_mul_pd(x0, b1);
      a[2] = _mm512_mul_pd(x0, b2);
      a[3] = _mm512_mul_pd(x0, b3);
      a[4] = _mm512_mul_pd(x1, b0);
      a[5] = _mm512_mul_pd(x1, b1);
      a[6] = _mm512_mul_pd(x1, b2);
      a[7] = _mm512_mul_pd(x1, b3);
      a[8] = _mm512_mul_pd(x2, b0);
      a[9] = _mm512_mul_pd(x2, b1);
      a[10] = _mm512_mul_pd(x2, b2);
      a[11] = _mm512_mul_pd(x2, b3);
      a[12] = _mm512_mul_pd(x3, b0);
      a[13] = _mm512_mul_pd(x3, b1);
      a[14] = _mm512_mul_pd(x3, b2);
      a[15] = _mm512_mul_pd(x3, b3);
      k = 4;
    }
    for (; k < len; k += 8) {
      const __m512d b0 = _mm512_loadu_pd(j0 + k), b1 = _mm512_loadu_pd(j1 + k),
                    b2 = _mm512_loadu_pd(j2 + k), b3 = _mm512_loadu_pd(j3 + k);
      __m512d x = _mm512_loadu_pd(r0 + k);
      a[0] = _mm512_fmadd_pd(x, b0, a[0]);
      a[1] = _mm512_fmadd_pd(x, b1, a[1]);
      a[2] = _mm512_fmadd_pd(x, b2, a[2]);
      a[3] = _mm512_fmadd_pd(x, b3, a[3]);
      x = _mm512_loadu_pd(r1 + k);
      a[4] = _mm512_fmadd_pd(x, b0, a[4]);
      a[5] = _mm512_fmadd_pd(x, b1, a[5]);
      a[6] = _mm512_fmadd_pd(x, b2, a[6]);
      a[7] = _mm512_fmadd_pd(x, b3, a[7]);
      x = _mm512_loadu_pd(r2 + k);
      a[8] = _mm512_fmadd_pd(x, b0, a[8]);
      a[9] = _mm512_fmadd_pd(x, b1, a[9]);
      a[10] = _mm512_fmadd_pd(x, b2, a[10]);
      a[11] = _mm512_fmadd_pd(x, b3, a[11]);
      x = _mm512_loadu_pd(r3 + k);
      a[12] = _mm512_fmadd_pd(x, b0, a[12]);
      a[13] = _mm512_fmadd_pd(x, b1, a[13]);
      a[14] = _mm512_fmadd_pd(x, b2, a[14]);
      a[15] = _mm512_fmadd_pd(x, b3, a[15]);
    }
    for (int i = 0; i < 4; ++i) hsum4_512(a[4 * i], a[4 * i + 1], a[4 * i + 2], a[4 * i + 3], acc + 4 * i);
  }
  FFSEG_AVX512 static inline void solve_tile(double* X, std::size_t wr, const double* D, std::size_t wj,
                                             const double* inv, const double* acc) {
    KAvx2::solve_tile(X, wr, D, wj, inv, acc);
  }
  // The solve is memory-bound: the AVX2 versions are as fast.
  FFSEG_AVX512 static inline void dot4x3(const double* R, std::size_t wr, const double* y0,
                                         const double* y1, const double* y2, std::size_t len,
                                         double* acc) {
    KAvx2::dot4x3(R, wr, y0, y1, y2, len, acc);
  }
  FFSEG_AVX512 static inline void axpy4x3(const double* R, std::size_t wr, const double* x,
                                          double* y0, double* y1, double* y2, std::size_t len) {
    KAvx2::axpy4x3(R, wr, x, y0, y1, y2, len);
  }
};

FFSEG_AVX2 __attribute__((flatten)) int factor_avx2_impl(const View& v, uint32_t* bad, double* const* y,
                                                    const EnvelopeAssign* as) {
  return factor_impl<KAvx2>(v, bad, y, as);
}
FFSEG_AVX2 __attribute__((flatten)) void solve_avx2_impl(const View& v, double* a, double* b, double* c, bool fwd) {
  solve_impl<KAvx2>(v, a, b, c, fwd);
}
FFSEG_AVX512 __attribute__((flatten)) int factor_avx512_impl(const View& v, uint32_t* bad, double* const* y,
                                                        const EnvelopeAssign* as) {
  return factor_impl<KAvx512>(v, bad, y, as);
}
FFSEG_AVX512 __attribute__((flatten)) void solve_avx512_impl(const View& v, double* a, double* b,
                                                       double* c, bool fwd) {
  solve_impl<KAvx512>(v, a, b, c, fwd);
}

}  // namespace

int factor_avx2(const View& v, uint32_t* bad, double* const* y, const EnvelopeAssign* as) {
  return factor_avx2_impl(v, bad, y, as);
}
void solve_avx2(const View& v, double* a, double* b, double* c, bool fwd) { solve_avx2_impl(v, a, b, c, fwd); }
int factor_avx512(const View& v, uint32_t* bad, double* const* y, const EnvelopeAssign* as) {
  return factor_avx512_impl(v, bad, y, as);
}
void solve_avx512(const View& v, double* a, double* b, double* c, bool fwd) { solve_avx512_impl(v, a, b, c, fwd); }

}  // namespace envelope_kernels
}  // namespace ffseg
#endif
