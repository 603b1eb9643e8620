#include "step_guard.h"

#include "rasterize.h"

namespace ffseg {

namespace {

constexpr int kMaxRounds = 12;

void tri_normal(const double* a, const double* b, const double* c, double n[3]) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
}

}  // namespace

uint32_t guard_step(const CubeSphere& m, const double* x_old, double* x_new, uint8_t* mark) {
  const size_t nv = m.nv;
  for (size_t v = 0; v < nv; ++v) mark[v] = 0;
  uint32_t touched = 0;
  for (int round = 0; round < kMaxRounds + 1; ++round) {
    uint32_t bad = 0;
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      uint32_t tri[6];
      const int nt = face_triangles(m, f, tri);
      for (int t = 0; t < nt; ++t) {
        const uint32_t* id = tri + 3 * t;
        double pn[3][3];
        for (int k = 0; k < 3; ++k)
          for (int c = 0; c < 3; ++c) pn[k][c] = x_new[c * nv + id[k]];
        double n0[3], n1[3];
        tri_normal(x_old + 3 * size_t(id[0]), x_old + 3 * size_t(id[1]), x_old + 3 * size_t(id[2]), n0);
        tri_normal(pn[0], pn[1], pn[2], n1);
        if (n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] > 0) continue;
        ++bad;
        for (int k = 0; k < 3; ++k) mark[id[k]] = 2;
      }
    }
    if (bad == 0) break;
    const bool last = round == kMaxRounds;
    for (size_t v = 0; v < nv; ++v) {
      if (mark[v] != 2) continue;
      mark[v] = 1;
      for (int c = 0; c < 3; ++c) {
        double& p = x_new[c * nv + v];
        const double o = x_old[3 * v + c];
        p = last ? o : o + 0.5 * (p - o);
      }
    }
  }
  for (size_t v = 0; v < nv; ++v) touched += mark[v] != 0;
  return touched;
}

}  // namespace ffseg
