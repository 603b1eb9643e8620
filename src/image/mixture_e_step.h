// The E-step of mixture_em.cpp (eq. 5.2.4) as an always-inlined template,
// shared by the portable instance there and the AVX-512F instance in
// mixture_em_x86.cpp, so both compile the same operations. Internal to image/.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#include "cpu_dispatch.h"
#include "cpu_x86.h"
#include "exp_block.h"
#include "mixture_em.h"

// Before the template: clang takes the pragma from here on, for every file
// that instantiates it.
#include "fp_contract_off.h"

namespace ffseg {
namespace mixture_kernels {

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
__attribute__((always_inline)) inline void e_step_body(const CpuDispatch& cpu, const float* x, uint32_t n, double shift,
                                                       const double* la, const double* mu, const double* ih, double* Z,
                                                       double* Zx, double* Zxx, LogLik* ll_io) {
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
    exp_block_nonzero(cpu, ev[0], (M - 1) * kBlock + nv);
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
__attribute__((always_inline)) inline void e_step_switch(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n,
                                                         double shift, const double* la, const double* mu,
                                                         const double* ih, double* Z, double* Zx, double* Zxx,
                                                         LogLik* ll) {
  static_assert(kMaxMixtureComponents == 8, "one e_step instance per component count");
  switch (m) {
    case 1: e_step_body<1, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 2: e_step_body<2, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 3: e_step_body<3, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 4: e_step_body<4, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 5: e_step_body<5, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 6: e_step_body<6, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    case 7: e_step_body<7, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
    default: e_step_body<8, EXACT>(cpu, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll); break;
  }
}

#if FFSEG_X86
// mixture_em_x86.cpp: the E-step compiled for AVX-512F, the log-likelihood
// exact (EXACT = true) or by chunks.
void e_step_avx512_exact(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift, const double* la,
                         const double* mu, const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll);
void e_step_avx512_chunked(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift,
                           const double* la, const double* mu, const double* ih, double* Z, double* Zx, double* Zxx,
                           LogLik* ll);
#endif

}  // namespace mixture_kernels
}  // namespace ffseg
