#include "envelope_cholesky.h"

#include <cmath>
#include <cstring>

#include "cpu_x86.h"
#if FFSEG_X86
#define FFSEG_BC_X86 1
#include <immintrin.h>
#else
#define FFSEG_BC_X86 0
#endif

namespace ffseg {

// ---- 2-ring graph ----------------------------------------------------------------

bool build_two_ring(uint32_t nv, const uint32_t* nbr, uint32_t* row_ptr, uint32_t* cols) {
  if (nv == 0) {
    if (row_ptr) row_ptr[0] = 0;
    return row_ptr != nullptr;
  }
  if (nbr == nullptr || row_ptr == nullptr || cols == nullptr) return false;
  for (std::size_t e = 0; e < std::size_t(4) * nv; ++e)
    if (nbr[e] >= nv) return false;
  uint32_t at = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    row_ptr[v] = at;
    uint32_t list[16];
    uint32_t cnt = 0;
    for (int a = 0; a < 4; ++a) {
      const uint32_t u = nbr[4 * std::size_t(v) + a];
      list[cnt++] = u;
      for (int b = 0; b < 4; ++b) {
        const uint32_t w = nbr[4 * std::size_t(u) + b];
        if (w != v && cnt < 16) list[cnt++] = w;
      }
    }
    // Sort, drop duplicates and v itself.
    for (uint32_t i = 1; i < cnt; ++i) {
      const uint32_t x = list[i];
      uint32_t j = i;
      while (j > 0 && list[j - 1] > x) {
        list[j] = list[j - 1];
        --j;
      }
      list[j] = x;
    }
    uint32_t prev = 0xFFFFFFFFu;
    for (uint32_t i = 0; i < cnt; ++i) {
      if (list[i] == prev || list[i] == v) continue;
      cols[at++] = list[i];
      prev = list[i];
    }
  }
  row_ptr[nv] = at;
  return true;
}

// ---- kernels -------------------------------------------------------------------------
//
// R points at column s of the first of 4 rows (row stride wr), J at column s
// of the first of 4 rows (stride wj); len is a multiple of 4.
//   dot4x4:  acc[4 i + j] = sum_k R_i[k] J_j[k]
//   dot4x3:  acc[3 i + r] = sum_k R_i[k] y_r[k]          (forward solve)
//   axpy4x3: y_r[k] -= sum_i R_i[k] x[3 i + r]           (backward solve)

namespace {

struct KPortable {
  static inline void dot4x4(const double* R, std::size_t wr, const double* J, std::size_t wj,
                            std::size_t len, double* acc) {
    for (int jp = 0; jp < 4; jp += 2) {
      const double* j0 = J + jp * wj;
      const double* j1 = j0 + wj;
      double a00 = 0, a01 = 0, a10 = 0, a11 = 0, a20 = 0, a21 = 0, a30 = 0, a31 = 0;
      for (std::size_t k = 0; k < len; ++k) {
        const double b0 = j0[k], b1 = j1[k];
        const double x0 = R[k], x1 = R[wr + k], x2 = R[2 * wr + k], x3 = R[3 * wr + k];
        a00 += x0 * b0;
        a01 += x0 * b1;
        a10 += x1 * b0;
        a11 += x1 * b1;
        a20 += x2 * b0;
        a21 += x2 * b1;
        a30 += x3 * b0;
        a31 += x3 * b1;
      }
      acc[0 + jp] = a00;
      acc[1 + jp] = a01;
      acc[4 + jp] = a10;
      acc[5 + jp] = a11;
      acc[8 + jp] = a20;
      acc[9 + jp] = a21;
      acc[12 + jp] = a30;
      acc[13 + jp] = a31;
    }
  }
  static inline void dot4x3(const double* R, std::size_t wr, const double* y0, const double* y1,
                            const double* y2, std::size_t len, double* acc) {
    for (int i = 0; i < 4; ++i) {
      const double* x = R + i * wr;
      double s0 = 0, s1 = 0, s2 = 0;
      for (std::size_t k = 0; k < len; ++k) {
        s0 += x[k] * y0[k];
        s1 += x[k] * y1[k];
        s2 += x[k] * y2[k];
      }
      acc[3 * i + 0] = s0;
      acc[3 * i + 1] = s1;
      acc[3 * i + 2] = s2;
    }
  }
  static inline void axpy4x3(const double* R, std::size_t wr, const double* x, double* y0,
                             double* y1, double* y2, std::size_t len) {
    const double* r0 = R;
    const double* r1 = R + wr;
    const double* r2 = R + 2 * wr;
    const double* r3 = R + 3 * wr;
    for (std::size_t k = 0; k < len; ++k) {
      y0[k] -= r0[k] * x[0] + r1[k] * x[3] + r2[k] * x[6] + r3[k] * x[9];
      y1[k] -= r0[k] * x[1] + r1[k] * x[4] + r2[k] * x[7] + r3[k] * x[10];
      y2[k] -= r0[k] * x[2] + r1[k] * x[5] + r2[k] * x[8] + r3[k] * x[11];
    }
  }
};

#if FFSEG_BC_X86

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

struct KAvx2 {
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

#endif  // FFSEG_BC_X86

// Plain view of the solver's arrays for the templated drivers.
struct View {
  uint32_t ngroups;
  const uint32_t* gstart;
  const uint64_t* goff;
  double* val;
  double* invdiag;
};

constexpr double kMaxDouble = 1.79769313486231570815e308;

inline std::size_t group_width(uint32_t g, uint32_t start) { return std::size_t(4) * g + 4 - start; }

// Returns kOk or a negative code; *bad_row = new index of the failing pivot.
// Forward substitution of group g: rows 4g..4g+3 of L z = y, for three
// permuted right-hand sides (earlier rows already solved).
template <class K>
inline void forward_group(const View& v, uint32_t g, double* const y[3]) {
  double acc[12];
  const uint32_t r = 4 * g;
  const uint32_t sr = v.gstart[g];
  const std::size_t wr = group_width(g, sr);
  const double* R = v.val + v.goff[g];
  K::dot4x3(R, wr, y[0] + sr, y[1] + sr, y[2] + sr, r - sr, acc);
  const double* D = R + (r - sr);
  for (int i = 0; i < 4; ++i) {
    const double* di = D + i * wr;
    for (int q = 0; q < 3; ++q) {
      double t = y[q][r + i] - acc[3 * i + q];
      for (int m = 0; m < i; ++m) t -= di[m] * y[q][r + m];
      y[q][r + i] = t * v.invdiag[r + i];
    }
  }
}

// Backward substitution L^T x = z of all groups, in place.
template <class K>
inline void backward_all(const View& v, double* const y[3]) {
  double x[12];
  for (uint32_t g = v.ngroups; g-- > 0;) {
    const uint32_t r = 4 * g;
    const uint32_t sr = v.gstart[g];
    const std::size_t wr = group_width(g, sr);
    const double* R = v.val + v.goff[g];
    const double* D = R + (r - sr);
    // The groups are walked downwards through memory, each block of four
    // rows upwards: runs too short for the hardware prefetchers, so the
    // block two groups below is requested into L2 by hand, a few lines per
    // chunk of the axpy below. bench_solver's backward pass at n = 49: 4.3-4.8
    // ms without, 2.8-3.2 ms with the whole block requested at once, 1.6-2.5
    // ms spread (three groups ahead: the same).
    const char* pf = g > 1 ? reinterpret_cast<const char*>(v.val + v.goff[g - 2]) : nullptr;
    const char* pe = g > 1 ? reinterpret_cast<const char*>(v.val + v.goff[g - 1]) : nullptr;
    for (int i = 3; i >= 0; --i) {
      for (int q = 0; q < 3; ++q) {
        double t = y[q][r + i];
        for (int m = i + 1; m < 4; ++m) t -= D[m * wr + i] * x[3 * m + q];
        t *= v.invdiag[r + i];
        x[3 * i + q] = t;
        y[q][r + i] = t;
      }
    }
    // The axpy in chunks of kCols columns (each column independent: the
    // same operations), the prefetches spread over them.
    constexpr uint32_t kCols = 32;
    const uint32_t len = r - sr;
    const std::size_t lines = pf ? std::size_t(pe - pf + 63) / 64 : 0;
    const std::size_t per = len ? (lines * kCols + len - 1) / len : lines;
    for (uint32_t c0 = 0; c0 < len; c0 += kCols) {
      for (std::size_t k = 0; k < per && pf < pe; ++k, pf += 64) __builtin_prefetch(pf, 0, 2);
      const uint32_t c = len - c0 < kCols ? len - c0 : kCols;
      K::axpy4x3(R + c0, wr, x, y[0] + sr + c0, y[1] + sr + c0, y[2] + sr + c0, c);
    }
    for (; pf && pf < pe; pf += 64) __builtin_prefetch(pf, 0, 2);
  }
}

}  // namespace

// The matrix as assign_sorted() takes it, for factor_impl() to store group by
// group just before it factors the group.
struct EnvelopeAssign {
  const uint64_t* off;
  const double* v;
  std::size_t count;
  uint32_t n, npad;  // rows n..npad-1 are padding: identity
};

namespace {

// Group g's block of the storage: zeros, the padding rows' identity, then
// the entries a.off[*k..] that fall in it (*k advances past them).
inline void assign_group(const View& v, const EnvelopeAssign& a, uint32_t g, std::size_t* k) {
  const uint32_t s = v.gstart[g];
  const std::size_t w = group_width(g, s);
  const uint64_t b = v.goff[g], e = b + 4 * w;
  std::memset(v.val + b, 0, (e - b) * sizeof(double));
  for (uint32_t i = 4 * g; i < 4 * g + 4; ++i)
    if (i >= a.n && i < a.npad) v.val[b + (i & 3u) * w + (i - s)] = 1.0;
  std::size_t q = *k;
  for (; q < a.count && a.off[q] < e; ++q) v.val[a.off[q]] = a.v[q];
  *k = q;
}

// rhs: three permuted right-hand sides to forward-substitute group by group as
// the factor's rows are completed (still in cache), or nullptr. as: the
// matrix to store group by group first (the storage as it is: nullptr).
template <class K>
inline int factor_impl(const View& v, uint32_t* bad_row, double* const* rhs, const EnvelopeAssign* as) {
  double acc[16];
  std::size_t next = 0;
  for (uint32_t g = 0; g < v.ngroups; ++g) {
    const uint32_t r = 4 * g;
    const uint32_t sr = v.gstart[g];
    const std::size_t wr = group_width(g, sr);
    double* R = v.val + v.goff[g];  // row i at R + i wr, column k at [k - sr]
    if (as) assign_group(v, *as, g, &next);
    for (uint32_t c = sr; c < r; c += 4) {
      const uint32_t gj = c >> 2;
      const uint32_t sj = v.gstart[gj];
      const std::size_t wj = group_width(gj, sj);
      const double* J = v.val + v.goff[gj];
      const uint32_t s = sr > sj ? sr : sj;
      K::dot4x4(R + (s - sr), wr, J + (s - sj), wj, c - s, acc);
      double* X = R + (c - sr);
      const double* D = J + (c - sj);  // diagonal block of group gj
      const double* inv = v.invdiag + c;
      for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 4; ++i) {
          double* xi = X + i * wr;
          double x = xi[j] - acc[4 * i + j];
          for (int m = 0; m < j; ++m) x -= xi[m] * D[j * wj + m];
          xi[j] = x * inv[j];
        }
      }
    }
    K::dot4x4(R, wr, R, wr, r - sr, acc);
    double* D = R + (r - sr);
    for (int j = 0; j < 4; ++j) {
      double* dj = D + j * wr;
      double x = dj[j] - acc[5 * j];
      for (int m = 0; m < j; ++m) x -= dj[m] * dj[m];
      if (!(x > 0.0 && x <= kMaxDouble)) {  // also catches NaN
        *bad_row = r + uint32_t(j);
        return (x >= -kMaxDouble && x <= 0.0) ? EnvelopeCholesky::kNotPositiveDefinite
                                               : EnvelopeCholesky::kNonFinite;
      }
      const double d = std::sqrt(x);
      dj[j] = d;
      const double id = 1.0 / d;
      v.invdiag[r + j] = id;
      for (int i = j + 1; i < 4; ++i) {
        double* di = D + i * wr;
        double y = di[j] - acc[4 * i + j];
        for (int m = 0; m < j; ++m) y -= di[m] * dj[m];
        di[j] = y * id;
      }
    }
    if (rhs) forward_group<K>(v, g, rhs);
  }
  return EnvelopeCholesky::kOk;
}

// y0..y2: permuted right-hand sides (npad each), solved in place; forward
// false: the forward half was done during the factorisation (factor_impl).
template <class K>
inline void solve_impl(const View& v, double* y0, double* y1, double* y2, bool forward) {
  double* const y[3] = {y0, y1, y2};
  if (forward)
    for (uint32_t g = 0; g < v.ngroups; ++g) forward_group<K>(v, g, y);
  backward_all<K>(v, y);
}

__attribute__((flatten)) int factor_portable(const View& v, uint32_t* bad, double* const* y,
                                             const EnvelopeAssign* as) {
  return factor_impl<KPortable>(v, bad, y, as);
}
__attribute__((flatten)) void solve_portable(const View& v, double* a, double* b, double* c, bool fwd) {
  solve_impl<KPortable>(v, a, b, c, fwd);
}
#if FFSEG_BC_X86
FFSEG_AVX2 __attribute__((flatten)) int factor_avx2(const View& v, uint32_t* bad, double* const* y,
                                                    const EnvelopeAssign* as) {
  return factor_impl<KAvx2>(v, bad, y, as);
}
FFSEG_AVX2 __attribute__((flatten)) void solve_avx2(const View& v, double* a, double* b, double* c, bool fwd) {
  solve_impl<KAvx2>(v, a, b, c, fwd);
}
FFSEG_AVX512 __attribute__((flatten)) int factor_avx512(const View& v, uint32_t* bad, double* const* y,
                                                        const EnvelopeAssign* as) {
  return factor_impl<KAvx512>(v, bad, y, as);
}
FFSEG_AVX512 __attribute__((flatten)) void solve_avx512(const View& v, double* a, double* b,
                                                       double* c, bool fwd) {
  solve_impl<KAvx512>(v, a, b, c, fwd);
}
#endif

// Envelope computation shared by init() and stored_entries_for(): given perm
// and iperm, writes the group starts (when gstart != nullptr) and returns the
// stored doubles; *env = strictly-lower envelope, *bw = half-bandwidth.
uint64_t layout_groups(const CsrGraph& g, const uint32_t* perm, const uint32_t* iperm,
                       uint32_t* gstart, uint64_t* goff, uint64_t* env, uint32_t* bw) {
  const uint32_t n = g.n;
  const uint32_t ngroups = (n + 3) / 4;
  uint64_t stored = 0, e = 0;
  uint32_t band = 0;
  for (uint32_t grp = 0; grp < ngroups; ++grp) {
    uint32_t start = 4 * grp;
    for (uint32_t i = 4 * grp; i < 4 * grp + 4 && i < n; ++i) {
      const uint32_t old = perm[i];
      uint32_t first = i;
      for (uint32_t q = g.row_ptr[old]; q < g.row_ptr[old + 1]; ++q) {
        const uint32_t c = iperm[g.cols[q]];
        if (c < first) first = c;
      }
      e += i - first;
      if (i - first > band) band = i - first;
      if (first < start) start = first;
    }
    start &= ~3u;
    if (gstart) gstart[grp] = start;
    if (goff) goff[grp] = stored;
    stored += 4 * group_width(grp, start);
  }
  *env = e;
  *bw = band;
  return stored;
}

}  // namespace

// ---- EnvelopeCholesky ------------------------------------------------------------------

bool EnvelopeCholesky::stored_entries_for(const CsrGraph& g, uint32_t* scratch, uint64_t* entries,
                                          uint32_t* bandwidth) {
  if (scratch == nullptr) return false;
  uint32_t* perm = scratch;
  uint32_t* iperm = scratch + g.n;
  if (!rcm_order(g, perm, scratch + 2 * std::size_t(g.n))) return false;
  for (uint32_t i = 0; i < g.n; ++i) iperm[perm[i]] = i;
  uint64_t env = 0;
  uint32_t bw = 0;
  const uint64_t s = layout_groups(g, perm, iperm, nullptr, nullptr, &env, &bw);
  if (entries) *entries = s;
  if (bandwidth) *bandwidth = bw;
  return true;
}

bool EnvelopeCholesky::init(Arena& arena, const CsrGraph& g, const CpuDispatch& cpu, uint64_t capacity,
                            uint32_t* measure_scratch) {
  *this = EnvelopeCholesky();
  cpu_ = cpu;
  n_ = g.n;
  npad_ = (n_ + 3) & ~3u;
  ngroups_ = npad_ / 4;
  perm_ = arena.alloc<uint32_t>(n_);
  iperm_ = arena.alloc<uint32_t>(n_);
  gstart_ = arena.alloc<uint32_t>(ngroups_);
  goff_ = arena.alloc<uint64_t>(ngroups_);
  invdiag_ = arena.alloc<double>(npad_);
  work_ = arena.alloc<double>(3 * std::size_t(npad_));
  uint32_t* rcm_scratch = arena.alloc<uint32_t>(rcm_scratch_words(n_));

  if (n_ == 0) {
    val_ = arena.alloc<double>(capacity);
    capacity_ = capacity;
    ready_ = arena.ok() && !arena.measuring();
    return arena.ok();
  }
  const bool have_graph = g.row_ptr != nullptr && (g.row_ptr[n_] == 0 || g.cols != nullptr);

  if (arena.measuring()) {
    uint64_t need = capacity;
    if (capacity == 0) {
      if (!have_graph || measure_scratch == nullptr) return false;
      uint32_t bw = 0;
      if (!stored_entries_for(g, measure_scratch, &need, &bw)) return false;
    }
    val_ = arena.alloc<double>(need);
    capacity_ = need;
    return arena.ok();
  }

  // Real pass.
  if (!have_graph || perm_ == nullptr || iperm_ == nullptr || gstart_ == nullptr ||
      goff_ == nullptr || invdiag_ == nullptr || work_ == nullptr || rcm_scratch == nullptr)
    return false;
  if (!rcm_order(g, perm_, rcm_scratch)) return false;
  for (uint32_t i = 0; i < n_; ++i) iperm_[perm_[i]] = i;
  stored_ = layout_groups(g, perm_, iperm_, gstart_, goff_, &envelope_, &bandwidth_);
  const uint64_t cap = capacity ? capacity : stored_;
  val_ = arena.alloc<double>(cap);
  capacity_ = cap;
  if (val_ == nullptr || !arena.ok() || stored_ > cap) return false;
  ready_ = true;
  clear();
  return true;
}

void EnvelopeCholesky::clear() {
  factored_ = forwarded_ = false;
  bad_entry_ = false;
  failed_row_ = -1;
  if (!ready_) return;
  std::memset(val_, 0, stored_ * sizeof(double));
  // Padding rows n..npad-1: identity.
  for (uint32_t i = n_; i < npad_; ++i) {
    const uint32_t g = i >> 2;
    const uint32_t s = gstart_[g];
    val_[goff_[g] + (i & 3u) * group_width(g, s) + (i - s)] = 1.0;
  }
}

void EnvelopeCholesky::assign_sorted(const uint64_t* off, const double* v, std::size_t count) {
  factored_ = forwarded_ = false;
  bad_entry_ = false;
  failed_row_ = -1;
  if (!ready_) return;
  // Group by group: zero its block, the padding rows' identity, then the
  // values that fall in it (the block is still in cache).
  const View view{ngroups_, gstart_, goff_, val_, invdiag_};
  const EnvelopeAssign as{off, v, count, n_, npad_};
  std::size_t k = 0;
  for (uint32_t g = 0; g < ngroups_; ++g) assign_group(view, as, g, &k);
}

double EnvelopeCholesky::get(uint32_t i, uint32_t j) const {
  if (!ready_) return 0.0;
  const double* p = slot(i, j);
  return p ? *p : 0.0;
}

int EnvelopeCholesky::factor() { return factor_with(nullptr, nullptr); }

int EnvelopeCholesky::factor_forward(const double* b, std::size_t ld) { return forward_with(b, ld, nullptr); }

int EnvelopeCholesky::forward_with(const double* b, std::size_t ld, const EnvelopeAssign* as) {
  forwarded_ = false;
  if (!ready_ || b == nullptr) return kNotReady;
  double* y[3] = {work_, work_ + npad_, work_ + 2 * std::size_t(npad_)};
  load_permuted(b, 3, ld, y);
  const int rc = factor_with(y, as);
  forwarded_ = rc == kOk;
  return rc;
}

int EnvelopeCholesky::assign_factor_forward(const uint64_t* off, const double* v, std::size_t count,
                                            const double* b, std::size_t ld) {
  factored_ = forwarded_ = false;
  bad_entry_ = false;
  failed_row_ = -1;
  if (!ready_ || b == nullptr || (count && (off == nullptr || v == nullptr))) return kNotReady;
  // Offsets past the storage would never be stored by the group walk.
  if (count && off[count - 1] >= stored_) return kOutOfPattern;
  const EnvelopeAssign as{off, v, count, n_, npad_};
  return forward_with(b, ld, &as);
}

int EnvelopeCholesky::factor_with(double* const* y, const EnvelopeAssign* as) {
  factored_ = forwarded_ = false;
  failed_row_ = -1;
  if (!ready_) return kNotReady;
  if (bad_entry_) return kOutOfPattern;
  const View v{ngroups_, gstart_, goff_, val_, invdiag_};
  uint32_t bad = 0;
  int rc = kOk;
  switch (kernel()) {
#if FFSEG_BC_X86
    case Isa::avx512:
      rc = factor_avx512(v, &bad, y, as);
      break;
    case Isa::avx2:
      rc = factor_avx2(v, &bad, y, as);
      break;
#endif
    default:
      rc = factor_portable(v, &bad, y, as);
      break;
  }
  if (rc != kOk) {
    failed_row_ = bad < n_ ? int64_t(perm_[bad]) : -1;
    return rc;
  }
  factored_ = true;
  return kOk;
}

void EnvelopeCholesky::load_permuted(const double* b, int cnt, std::size_t ld, double* const* y) const {
  for (int q = 0; q < 3; ++q) {
    if (q < cnt) {
      const double* src = b + std::size_t(q) * ld;
      for (uint32_t i = 0; i < n_; ++i) y[q][i] = src[perm_[i]];
      for (uint32_t i = n_; i < npad_; ++i) y[q][i] = 0.0;
    } else {
      std::memset(y[q], 0, npad_ * sizeof(double));
    }
  }
}

void EnvelopeCholesky::substitute(double* const* y, bool forward) const {
  const View v{ngroups_, gstart_, goff_, val_, invdiag_};
  switch (kernel()) {
#if FFSEG_BC_X86
    case Isa::avx512:
      solve_avx512(v, y[0], y[1], y[2], forward);
      break;
    case Isa::avx2:
      solve_avx2(v, y[0], y[1], y[2], forward);
      break;
#endif
    default:
      solve_portable(v, y[0], y[1], y[2], forward);
      break;
  }
}

int EnvelopeCholesky::solve(double* b, int nrhs, std::size_t ld) {
  forwarded_ = false;
  if (!ready_ || !factored_) return kNotReady;
  if (nrhs <= 0) return kOk;
  if (b == nullptr) return kNotReady;
  double* y[3] = {work_, work_ + npad_, work_ + 2 * std::size_t(npad_)};
  for (int r0 = 0; r0 < nrhs; r0 += 3) {
    const int cnt = nrhs - r0 < 3 ? nrhs - r0 : 3;
    load_permuted(b + std::size_t(r0) * ld, cnt, ld, y);
    substitute(y, true);
    for (int q = 0; q < cnt; ++q) {
      double* dst = b + std::size_t(r0 + q) * ld;
      for (uint32_t i = 0; i < n_; ++i) dst[perm_[i]] = y[q][i];
    }
  }
  return kOk;
}

int EnvelopeCholesky::solve_forwarded(double* x, std::size_t ld) {
  if (!ready_ || !factored_ || !forwarded_ || x == nullptr) return kNotReady;
  forwarded_ = false;
  double* y[3] = {work_, work_ + npad_, work_ + 2 * std::size_t(npad_)};
  substitute(y, false);
  for (int q = 0; q < 3; ++q) {
    double* dst = x + std::size_t(q) * ld;
    for (uint32_t i = 0; i < n_; ++i) dst[perm_[i]] = y[q][i];
  }
  return kOk;
}

}  // namespace ffseg
