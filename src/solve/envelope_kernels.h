// The envelope Cholesky's drivers (envelope_cholesky.cpp) as templates over
// the tile kernel K, shared by the portable instance there and the AVX2 /
// AVX-512 instances in envelope_cholesky_x86.cpp. Internal to solve/.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "cpu_x86.h"
#include "envelope_cholesky.h"

namespace ffseg {

// The matrix as assign_sorted() takes it, for factor_impl() to store group by
// group just before it factors the group.
struct EnvelopeAssign {
  const uint64_t* off;
  const double* v;
  std::size_t count;
  uint32_t n, npad;  // rows n..npad-1 are padding: identity
};

namespace envelope_kernels {

// ---- tile kernels (K) -------------------------------------------------------------------------
//
// R points at column s of the first of 4 rows (row stride wr), J at column s
// of the first of 4 rows (stride wj); len is a multiple of 4.
//   dot4x4:  acc[4 i + j] = sum_k R_i[k] J_j[k]
//   dot4x3:  acc[3 i + r] = sum_k R_i[k] y_r[k]          (forward solve)
//   axpy4x3: y_r[k] -= sum_i R_i[k] x[3 i + r]           (backward solve)
//   solve_tile: the 4 x 4 tile X (rows at stride wr) of a row group in the
//            columns of an earlier group, against that group's diagonal
//            block D (stride wj) and inverse pivots inv, acc the rows' dot
//            products with it (dot4x4): column j by column,
//              X_ij = (X_ij - acc[4 i + j] - sum_{m < j} X_im D_jm) inv_j,
//            the sum taken in m order: each kernel does what the scalar
//            loop does compiled for its target, four rows at a time in the
//            wide ones. (The x86 kernels' targets have FMA, and GCC, whose
//            C++ default is -ffp-contract=fast, fuses the loop's x -= a b
//            into one rounding there; the portable kernel rounds the product
//            first.)

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
      K::solve_tile(R + (c - sr), wr, J + (c - sj), wj, v.invdiag + c, acc);
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

#if FFSEG_X86
// envelope_cholesky_x86.cpp: the drivers with the AVX2 + FMA and the
// AVX-512F + AVX2 + FMA tiles.
int factor_avx2(const View& v, uint32_t* bad, double* const* y, const EnvelopeAssign* as);
void solve_avx2(const View& v, double* a, double* b, double* c, bool fwd);
int factor_avx512(const View& v, uint32_t* bad, double* const* y, const EnvelopeAssign* as);
void solve_avx512(const View& v, double* a, double* b, double* c, bool fwd);
#endif

}  // namespace envelope_kernels
}  // namespace ffseg
