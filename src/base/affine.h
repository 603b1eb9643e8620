// 3x4 row-major affine maps (the top of a 4x4 index-to-world matrix).
#pragma once

namespace ffseg {

inline void affine_point(const double M[12], const double in[3], double out[3]) {
  for (int r = 0; r < 3; ++r) out[r] = M[4 * r] * in[0] + M[4 * r + 1] * in[1] + M[4 * r + 2] * in[2] + M[4 * r + 3];
}

inline void affine_direction(const double M[12], const double in[3], double out[3]) {
  for (int r = 0; r < 3; ++r) out[r] = M[4 * r] * in[0] + M[4 * r + 1] * in[1] + M[4 * r + 2] * in[2];
}

}  // namespace ffseg
