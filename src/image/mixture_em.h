// EM for a 1-D Gaussian mixture (thesis 5.2.2: E-step eq. 5.2.4, M-step
// eq. 5.2.5-5.2.7) with a variance floor: the intensity model's fit, over the
// samples one by one or over the samples binned (the scene's many voxels).
// cpu: the engine's kernels (the E-step's and exp_block's).
#pragma once
#include <cstdint>

#include "cpu_dispatch.h"

namespace ffseg {

constexpr uint32_t kMaxMixtureComponents = 8;
// Bins of compress_samples(), at most (hist of em_fit_compressed: 3 times this).
constexpr uint32_t kMixtureCompressBins = 4096;

struct Gaussian1 {
  double weight = 0;  // a_i
  double mean = 0;    // mu_i
  double var = 0;     // sigma_i^2
};

struct EmResult {
  uint32_t iterations = 0;
  double log_likelihood = 0;  // per sample, at the returned parameters
};

// EM from the components in comp[0..*m) (at most kMaxMixtureComponents);
// variances floored at var_floor. Components whose weight falls below 1e-4
// are dropped (*m shrinks, at least one stays). Stops when the mean
// log-likelihood improves by less than tol. The log-likelihood is summed with
// one log per 64 samples and an error bound; the plain per-sample sum is
// computed only when the bound cannot decide the stopping test, so iterations
// and results are those of the plain loop. exact_log_likelihood = false
// leaves the reported log_likelihood as that chunked sum (saves a pass; the
// parameters are the same).
EmResult em_fit(const CpuDispatch& cpu, const float* x, uint32_t n, Gaussian1* comp, uint32_t* m,
                uint32_t max_iterations, double var_floor, double tol = 1e-9, bool exact_log_likelihood = true);

// The finite samples of x in bins of the given width (wider when more than
// kMixtureCompressBins would be needed) from their minimum: per non-empty
// bin, in order, the mean less shift (v), the count (w) and the sum of
// squares about the mean (ss). Returns the number of non-empty bins.
uint32_t compress_samples(const float* x, uint32_t n, double shift, double width, double* v, double* w, double* ss);

// The same fit as em_fit over the finite samples binned `width` wide (see
// compress_samples; hist: 3 kMixtureCompressBins doubles): each bin counts as
// its samples' mean with their weight and spread, so the E-step costs the
// non-empty bins, not the samples. Plain log-likelihood sums. Returns the
// number of non-empty bins.
uint32_t em_fit_compressed(const CpuDispatch& cpu, const float* x, uint32_t n, Gaussian1* comp, uint32_t* m,
                           uint32_t max_iterations, double var_floor, double width, double* hist, double tol = 1e-9);

}  // namespace ffseg
