// Adaptive binning (thesis Algorithm 2, after [LL03]): the number and the
// starting values of the intensity model's mixture components. A value joins
// its nearest bin when within the radius R, opens a new bin when at least the
// separation S from every bin, and waits for the next pass in between; bins
// move to their members' centroid after each pass, bins closer than S merge,
// bins with fewer than N_m members are removed, until the centroids rest.
#pragma once
#include <cstdint>

#include "cpu_dispatch.h"

namespace ffseg {

// Bins held while a pass runs (the result keeps at most max_bins of them).
constexpr uint32_t kMaxBinningClusters = 64;

struct Bin {
  double centroid = 0;  // c_i
  uint32_t count = 0;   // members in the last pass
  double var = 0;       // members' variance about the centroid's mean
};

struct BinningSettings {
  double radius = 0;       // R: a value joins its nearest bin within R
  double separation = 0;   // S: a value opens a new bin at >= S from every bin
  uint32_t min_count = 1;  // N_m: bins with fewer members are removed
  uint32_t max_passes = 50;
};

// Algorithm 2 over x[0..n) (cpu: the engine's kernels; the AVX-512 pass holds
// up to 8 bins in lanes), visiting x in the order perm(s) = (s * stride) mod n
// (stride coprime with n; 1 = as given). Writes at most max_bins bins, sorted by
// centroid, and returns their number.
uint32_t adaptive_binning(const CpuDispatch& cpu, const float* x, uint32_t n, const BinningSettings& s, Bin* bins,
                          uint32_t max_bins, uint32_t stride = 1);
// A stride close to 0.618 n coprime with n (a well-mixed visiting order).
uint32_t mixing_stride(uint32_t n);

}  // namespace ffseg
