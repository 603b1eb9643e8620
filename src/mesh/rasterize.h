// Scan conversion of the closed mesh onto the volume grid (voxel centre inside).
#pragma once
#include <cstdint>

#include "cubesphere.h"
#include "volume.h"

namespace ffseg {

// mask[i*s0 + j*s1 + k*s2] = 1 where the voxel centre is inside the closed mesh
// with vertices x (3 per vertex, mm), else 0; strides NULL = contiguous.
void rasterize_mesh(const CubeSphere& m, const double* x, const VolumeView& vol, uint8_t* mask,
                    const int64_t strides[3]);

}  // namespace ffseg
