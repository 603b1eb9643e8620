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

// The same mask cut to the box of voxels [lo, lo + n) of the volume grid
// (lo >= 0, lo + n <= dims), written contiguously (voxel (i, j, k) of the box
// at mask[i + n0 (j + n1 k)]): equal bit for bit to rasterize_mesh's voxels
// there. Returns the number of voxels inside.
int64_t rasterize_mesh_box(const CubeSphere& m, const double* x, const VolumeView& vol, const int64_t lo[3],
                           const int64_t n[3], uint8_t* mask);

// The voxels rasterize_mesh sets, counted without a mask (from the signed
// crossings of each row; equal to the parity count unless the mesh
// intersects itself).
int64_t count_inside_voxels(const CubeSphere& m, const double* x, const VolumeView& vol);

// Whether more than fraction of the grid's voxels have their centres inside
// the mesh; counts them only when the mesh's bounding box holds that many.
bool mesh_fills_grid(const CubeSphere& m, const double* x, const VolumeView& vol, double fraction);

}  // namespace ffseg
