#include "mixture_em.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "cpu_x86.h"
#include "exp_block.h"
#include "mixture_e_step.h"

#include "fp_contract_off.h"  // after every other include

namespace ffseg {

namespace {

using namespace mixture_kernels;

template <bool EXACT>
void e_step_base(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift, const double* la,
                 const double* mu, const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
  e_step_switch<EXACT>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

template <bool EXACT>
void e_step_m(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, double shift, const double* la,
              const double* mu, const double* ih, double* Z, double* Zx, double* Zxx, LogLik* ll) {
#if FFSEG_X86
  if (cpu.kernel(KernelFamily::mixture) == Isa::avx512) {
    if (EXACT) e_step_avx512_exact(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
    else e_step_avx512_chunked(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
    return;
  }
#endif
  e_step_base<EXACT>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

void e_step_dispatch(const CpuDispatch& cpu, bool exact, uint32_t m, const float* x, uint32_t n, double shift,
                     const double* la, const double* mu, const double* ih, double* Z, double* Zx, double* Zxx,
                     LogLik* ll) {
  if (exact) e_step_m<true>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
  else e_step_m<false>(cpu, m, x, n, shift, la, mu, ih, Z, Zx, Zxx, ll);
}

// The exact mean log-likelihood (the reference sum) at parameters la, mu, ih.
double exact_ll(const CpuDispatch& cpu, uint32_t m, const float* x, uint32_t n, uint32_t nf, double shift,
                const double* la, const double* mu, const double* ih, double half_log_2pi) {
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
    r.log_likelihood =
        prev_exact || !exact_result ? ll_prev : exact_ll(cpu, pm, x, n, nf, shift, pla, pmu, pih, half_log_2pi);
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
void em_fit_weighted(const CpuDispatch& cpu, const double* v, const double* w, const double* ss, uint32_t np,
                     Gaussian1* comp, uint32_t* m_io, uint32_t max_iterations, double var_floor, double tol) {
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
