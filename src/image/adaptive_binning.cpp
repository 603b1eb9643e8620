#include "adaptive_binning.h"

#include <algorithm>
#include <cmath>

#include "adaptive_binning_x86.h"

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
