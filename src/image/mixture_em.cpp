#include "mixture_em.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "cpu_x86.h"
#include "exp_block.h"

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {

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
__attribute__((always_inline)) inline void e_step_body(const CpuDispatch& cpu, const float* x, uint32_t n, double shift, const double* la,
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
__attribute__((always_inline)) inline void e_step_switch(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift,
                                                         const double* la, const double* mu, const double* ih,
                                                         double* Z, double* Zx, double* Zxx, LogLik* ll) {
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

template <bool EXACT>
void e_step_base(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift, const double* la, const double* mu,
                 const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
  e_step_switch<EXACT>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

#if FFSEG_X86
template <bool EXACT>
__attribute__((target("avx512f"))) FFSEG_NO_FMA_CONTRACT void e_step_avx512(
    const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift, const double* la, const double* mu, const double* ih,
    double* Z, double* Zx, double* Zxx, LogLik* ll) {
  e_step_switch<EXACT>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}
#endif

template <bool EXACT>
void e_step_m(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift, const double* la, const double* mu,
              const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
#if FFSEG_X86
  if (cpu.kernel(KernelFamily::mixture) == Isa::avx512) {
    e_step_avx512<EXACT>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
    return;
  }
#endif
  e_step_base<EXACT>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

void e_step_dispatch(const CpuDispatch& cpu, bool exact, uint32_t m, const float* x, uint32_t n, double shift, const double* la,
                     const double* mu, const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
  if (exact) e_step_m<true>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
  else e_step_m<false>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

// The exact mean log-likelihood (the reference sum) at parameters la, mu, ih.
double exact_ll(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, uint32_t nf, double shift, const double* la, const double* mu,
                const double* ih, double half_log_2pi) {
  double Z[kMaxMixtureComponents] = {}, Zx[kMaxMixtureComponents] = {},
         Zxx[kMaxMixtureComponents] = {};
  LogLik L;
  e_step_dispatch(cpu, true, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, &L);
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
EmResult em_fit_impl(const CpuDispatch& cpu, const float* x, uint32_t n, Gaussian1* comp, uint32_t* m_io,
                     uint32_t max_iterations, double var_floor, double tol, bool exact_result) {
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
  double a[kMaxMixtureComponents], mu[kMaxMixtureComponents], v[kMaxMixtureComponents];
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
  const uint32_t M = kMaxMixtureComponents;
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
    e_step_dispatch(cpu, false, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, &L);
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
        if (!prev_exact) ll_prev = exact_ll(cpu, pm, x, n, nf, shift, pla, pmu, pih, half_log_2pi);
        ll = exact_ll(cpu, em, x, n, nf, shift, la, emu, ih, half_log_2pi);
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
    r.log_likelihood = ll_exact || !exact_result ? ll : exact_ll(cpu, cm, x, n, nf, shift, la, emu, ih, half_log_2pi);
  } else if (report == kReportPrev) {
    r.log_likelihood = prev_exact || !exact_result ? ll_prev : exact_ll(cpu, pm, x, n, nf, shift, pla, pmu, pih, half_log_2pi);
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

// EM over weighted points (compress_samples): point j stands for
// w[j] samples with mean v[j] (shifted by the caller) and sum of squares
// ss[j] about v[j]. The same iteration as em_fit_impl, each point's
// responsibilities taken at its mean: Z_i += w z_i, Zx_i += w z_i v,
// Zxx_i += z_i (w v^2 + ss), so every component's first and second moments
// are exact where a point's samples share its responsibilities. Same start,
// variance floor, dropping rule and stopping test (plain sums).
void em_fit_weighted(const CpuDispatch& cpu, const double* v, const double* w, const double* ss, uint32_t np, Gaussian1* comp,
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
  constexpr uint32_t M = kMaxMixtureComponents;
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
      for (uint32_t i = 0; i < m; ++i) exp_block(cpu, ev + i * kBlock, nb);
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

uint32_t compress_samples(const float* x, uint32_t n, double shift, double width, double* v, double* w,
                          double* ss) {
  double lo = INFINITY, hi = -INFINITY;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) {
      lo = std::min(lo, double(x[j]));
      hi = std::max(hi, double(x[j]));
    }
  if (!(lo <= hi)) return 0;
  double h = width;
  if (!(h > 0) || !std::isfinite(h) || (hi - lo) / h >= double(kMixtureCompressBins - 1))
    h = (hi - lo) / (kMixtureCompressBins - 1);
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

uint32_t em_fit_compressed(const CpuDispatch& cpu, const float* x, uint32_t n, Gaussian1* comp, uint32_t* m,
                           uint32_t max_iterations, double var_floor, double width, double* hist, double tol) {
  double mean = 0;
  uint32_t nf = 0;
  for (uint32_t j = 0; j < n; ++j)
    if (std::isfinite(x[j])) mean += x[j], ++nf;
  if (nf == 0 || *m == 0) return 0;
  mean /= nf;
  double* hv = hist;
  double* hw = hist + kMixtureCompressBins;
  double* hs = hist + 2 * size_t(kMixtureCompressBins);
  const uint32_t np = compress_samples(x, n, mean, width, hv, hw, hs);
  for (uint32_t i = 0; i < *m; ++i) comp[i].mean -= mean;
  em_fit_weighted(cpu, hv, hw, hs, np, comp, m, max_iterations, var_floor, tol);
  for (uint32_t i = 0; i < *m; ++i) comp[i].mean += mean;
  return np;
}

EmResult em_fit(const CpuDispatch& cpu, const float* x, uint32_t n, Gaussian1* comp, uint32_t* m_io,
                uint32_t max_iterations, double var_floor, double tol, bool exact_log_likelihood) {
  return em_fit_impl(cpu, x, n, comp, m_io, max_iterations, var_floor, tol, exact_log_likelihood);
}

}  // namespace ffseg
