// The engine's view of a tools image: an ffseg_volume that borrows the
// image's buffer (no copy; i fastest, contiguous, as every reader stores it),
// with its index-to-world affine and rescale. Shared by the CLI, the fuzz
// targets and the tests, so that they hand the engine the same description.
#ifndef FFSEG_TOOLS_ENGINE_VOLUME_H
#define FFSEG_TOOLS_ENGINE_VOLUME_H

#include <cstring>

#include "ffseg.h"
#include "nifti.h"

namespace ffseg_tools {

// Valid while img lives and its data is not resized.
inline ffseg_volume engine_volume(const NiftiImage& img) {
  ffseg_volume v;
  std::memset(&v, 0, sizeof v);
  v.struct_size = sizeof v;
  v.voxel_type = uint32_t(img.voxel_type);
  v.data = img.data.data();
  v.data_bytes = img.data.size();
  const int64_t bpv = img.bytes_per_voxel;
  for (int a = 0; a < 3; ++a) v.dims[a] = img.dims[a];
  v.strides[0] = bpv;
  v.strides[1] = bpv * img.dims[0];
  v.strides[2] = bpv * img.dims[0] * int64_t(img.dims[1]);
  std::memcpy(v.index_to_world, img.index_to_world, sizeof v.index_to_world);
  v.rescale_slope = img.scl_slope;
  v.rescale_intercept = img.scl_inter;
  return v;
}

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_ENGINE_VOLUME_H
