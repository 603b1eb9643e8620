// Segmentation accuracy metrics on binary masks (tools code; standard library only).
//
// Mask convention: `const uint8_t*` with one byte per voxel, non-zero = object;
// dims[3] = {ni, nj, nk}, i fastest and contiguous (index = i + ni*(j + nj*k));
// spacing[3] = voxel size in mm along i, j, k. Distances are between voxel
// centres, in mm.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace ffseg_tools {

// Result of compare_masks(a, b): `a` is the segmentation under test, `b` the
// reference.
//
//   dice  = 2|A∩B| / (|A|+|B|)
//   voe   = 1 - |A∩B| / |A∪B|            (volumetric overlap error, SLIVER07)
//   rvd   = (|A| - |B|) / |B|            (signed; > 0 means A is too large)
//   vol_a_ml, vol_b_ml = voxel count * voxel volume / 1000
//   border_a, border_b = number of border voxels: object voxels with at least
//       one of their 26 neighbours outside the object (beyond the grid counts
//       as outside)
//   Surface distances: for every border voxel of A the distance to the nearest
//   border voxel of B, and for every border voxel of B the distance to the
//   nearest border voxel of A; D = the union (concatenation) of both sets,
//   |D| = border_a + border_b.
//   assd_mm = mean of D
//   hd95_mm = 95th percentile of D, nearest-rank convention: the value at
//             position ceil(0.95 |D|) in D sorted ascending (1-based), i.e. the
//             smallest d with at least 95% of D <= d (no interpolation)
//   hd_mm   = max of D (symmetric Hausdorff distance of the borders)
//
// Empty masks: both empty -> dice 1, voe 0, rvd 0, all distances 0 (the masks
// are identical). Exactly one empty -> dice 0, voe 1, rvd = -1 if B is non-empty
// (A empty) or +inf if B is empty, and assd/hd95/hd = +infinity (the distance to
// an empty set); check std::isfinite() before averaging over cases.
struct SegMetrics {
  double dice, voe, rvd, assd_mm, hd95_mm, hd_mm, vol_a_ml, vol_b_ml;
  std::size_t border_a, border_b;
};

SegMetrics compare_masks(const uint8_t* a, const uint8_t* b, const int dims[3],
                         const double spacing[3]);

// Exact squared Euclidean distance (mm^2) from every voxel to the nearest voxel
// of the set, using the real spacing (Felzenszwalb-Huttenlocher separable
// lower-envelope transform, O(voxels)). The set is {mask != 0} when
// target_nonzero, else {mask == 0}. Set voxels get 0. If the set is empty
// every voxel gets +infinity. Only voxels inside the grid belong to the set.
std::vector<double> edt_sq_mm2(const uint8_t* mask, const int dims[3], const double spacing[3],
                               bool target_nonzero = true);

// As edt_sq_mm2 but the distance itself (mm). For "distance to the label's
// border" use target_nonzero = false: each object voxel then gets the distance
// to the nearest background voxel inside the grid (see find_deepest_voxel for
// the variant where beyond-the-grid also counts as background).
std::vector<double> edt_mm(const uint8_t* mask, const int dims[3], const double spacing[3],
                           bool target_nonzero = true);

// Marks border voxels (definition above) with 1 in `out` (dims-sized, every
// byte written) and returns their number.
std::size_t border_mask(const uint8_t* mask, const int dims[3], uint8_t* out);

// The object voxel farthest from the background; ties (depths equal to 1e-9,
// relative) go to the lowest linear index. Background = zero voxels of the
// grid plus the layer of voxels just beyond the grid (consistent with the
// border definition), so a mask filling the whole grid still has finite depths. *dist_mm is the distance from that
// voxel's centre to the nearest background voxel centre (>= the smallest
// spacing). Returns false (and leaves the outputs untouched) if the mask is
// empty. Either output pointer may be null.
bool find_deepest_voxel(const uint8_t* mask, const int dims[3], const double spacing[3],
                        std::array<int, 3>* ijk, double* dist_mm);

}  // namespace ffseg_tools
