// Triangles of the cube-sphere (each quad split along its 0-2 diagonal) and
// scan conversion of the closed mesh onto the volume grid (voxel centre inside).
#pragma once
#include <cstdint>

#include "cubesphere.h"
#include "volume.h"

namespace ffseg {

// Writes the triangles of face f (3 or 6 indices); returns how many triangles.
inline int face_triangles(const CubeSphere& m, uint32_t f, uint32_t out[6]) {
  const uint32_t* q = m.faces + 4 * size_t(f);
  out[0] = q[0]; out[1] = q[1]; out[2] = q[2];
  if (q[3] == kNone) return 1;
  out[3] = q[0]; out[4] = q[2]; out[5] = q[3];
  return 2;
}

// All triangles, 3 indices each, outward (counter-clockwise seen from outside).
void triangulate(const CubeSphere& m, uint32_t* tris);

// mask[i*s0 + j*s1 + k*s2] = 1 where the voxel centre is inside the closed mesh
// with vertices x (3 per vertex, mm), else 0; strides NULL = contiguous.
void rasterize_mesh(const CubeSphere& m, const double* x, const VolumeView& vol, uint8_t* mask,
                    const int64_t strides[3]);

}  // namespace ffseg
