#include "normals.h"

#include <cmath>

namespace ffseg {

void vertex_normals(const CubeSphere& m, const double* x, double* n) {
  double c[3] = {0, 0, 0};
  for (uint32_t v = 0; v < m.nv; ++v)
    for (int d = 0; d < 3; ++d) c[d] += x[3 * v + d];
  for (int d = 0; d < 3; ++d) c[d] /= double(m.nv);
  for (uint32_t v = 0; v < m.nv; ++v) {
    const uint32_t* q = m.nbr + 4 * size_t(v);
    double a[3], b[3];
    for (int d = 0; d < 3; ++d) {
      a[d] = x[3 * q[0] + d] - x[3 * q[1] + d];  // along +t1
      b[d] = x[3 * q[2] + d] - x[3 * q[3] + d];  // along +t2
    }
    // t1 x t2 is the face's axis; faces with an odd index have the + sign.
    const double s = ((v / (m.n * m.n)) % 2) ? 1.0 : -1.0;
    double r[3] = {s * (a[1] * b[2] - a[2] * b[1]), s * (a[2] * b[0] - a[0] * b[2]),
                   s * (a[0] * b[1] - a[1] * b[0])};
    double len = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (!(len > 1e-300)) {
      for (int d = 0; d < 3; ++d) r[d] = x[3 * v + d] - c[d];
      len = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
      if (!(len > 1e-300)) { r[0] = 0; r[1] = 0; r[2] = 1; len = 1; }
    }
    for (int d = 0; d < 3; ++d) n[3 * v + d] = r[d] / len;
  }
}

}  // namespace ffseg
