#include "triangulation.h"

namespace ffseg {

void triangulate(const CubeSphere& m, const double* x, uint32_t* tris) {
  size_t t = 0;
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    uint32_t tri[6];
    const int c = face_triangles(m, f, tri, x);
    for (int i = 0; i < 3 * c; ++i) tris[t++] = tri[i];
  }
}

}  // namespace ffseg
