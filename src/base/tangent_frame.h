// An orthonormal frame (e1, e2) of the plane normal to a unit vector n, with
// e1 from the coordinate axis least aligned with n and e2 = n x e1, so that
// (e1, e2, n) is right-handed. Used to order the faces around a grid corner
// (cubesphere) and to project a window of the mesh (patch_certificate).
#pragma once
#include <cmath>

namespace ffseg {

inline void tangent_frame(const double n[3], double e1[3], double e2[3]) {
  int mi = 0;
  for (int d = 1; d < 3; ++d)
    if (std::fabs(n[d]) < std::fabs(n[mi])) mi = d;
  double h[3] = {0, 0, 0};
  h[mi] = 1;
  const double dp = h[0] * n[0] + h[1] * n[1] + h[2] * n[2];
  for (int d = 0; d < 3; ++d) e1[d] = h[d] - dp * n[d];
  const double el = std::sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
  for (int d = 0; d < 3; ++d) e1[d] /= el;
  e2[0] = n[1] * e1[2] - n[2] * e1[1];
  e2[1] = n[2] * e1[0] - n[0] * e1[2];
  e2[2] = n[0] * e1[1] - n[1] * e1[0];
}

}  // namespace ffseg
