#include "diffusion.h"

namespace ffseg {

void diffuse_displacements(const CubeSphere& m, uint32_t rounds, double* d, uint8_t* has, double* tmp,
                           uint8_t* tmp_has) {
  for (uint32_t r = 0; r < rounds; ++r) {
    for (uint32_t v = 0; v < m.nv; ++v) {
      double acc[3] = {0, 0, 0};
      int cnt = 0;
      if (has[v]) {
        for (int a = 0; a < 3; ++a) acc[a] += d[3 * size_t(v) + a];
        ++cnt;
      }
      for (int k = 0; k < 4; ++k) {
        const uint32_t w = m.nbr[4 * size_t(v) + k];
        if (!has[w]) continue;
        for (int a = 0; a < 3; ++a) acc[a] += d[3 * size_t(w) + a];
        ++cnt;
      }
      tmp_has[v] = cnt > 0;
      for (int a = 0; a < 3; ++a) tmp[3 * size_t(v) + a] = cnt ? acc[a] / cnt : 0.0;
    }
    for (uint32_t v = 0; v < m.nv; ++v) {
      has[v] = tmp_has[v];
      for (int a = 0; a < 3; ++a) d[3 * size_t(v) + a] = tmp[3 * size_t(v) + a];
    }
  }
}

}  // namespace ffseg
