// One volume stored in other ways that hold the same anatomy in world space:
// flipped along an axis (the affine's column negated, its origin moved to
// the far end), with permuted axes, or in another voxel type holding the
// same values. A segmentation must not depend on which (issue 19).
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ffseg.h"

namespace ffseg_test {

struct StoredVariant {
  std::string name;
  int64_t dims[3] = {0, 0, 0};
  double A[16] = {};
  uint32_t type = FFSEG_U8;
  double rescale_slope = 1, rescale_intercept = 0;
  std::vector<uint8_t> data;        // the variant's voxels, x fastest
  std::vector<size_t> to_original;  // variant voxel -> voxel of the original grid

  ffseg_volume volume() const;
  // A mask over this variant's grid, mapped onto the original grid.
  std::vector<uint8_t> to_original_grid(const std::vector<uint8_t>& mask) const;
};

// The original (dims, affine A, raw stored values x fastest as doubles, its
// voxel type and rescale) "as stored", then: flipped along i, j and k, with
// axes permuted to (j, k, i), and its values as f32 and as f64 (the rescale
// applied). raw values must be representable in `type`.
std::vector<StoredVariant> stored_variants(const int64_t dims[3], const double A[16], const std::vector<double>& raw,
                                           uint32_t type, double rescale_slope = 1, double rescale_intercept = 0);

// One grey-level object from the sphere (c, r), stepped to rest (at most
// max_steps), rasterised on the variant's grid and mapped to the original's.
std::vector<uint8_t> segment_variant(const StoredVariant& v, const double c[3], double r, uint32_t n,
                                     int max_steps = 100);

// Voxels where two masks of one grid differ.
size_t differing_voxels(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b);

}  // namespace ffseg_test
