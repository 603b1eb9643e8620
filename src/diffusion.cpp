#include "diffusion.h"

#include <cmath>

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

uint32_t harmonic_fill(const CubeSphere& m, double* d, uint8_t* has, uint32_t* queue, uint32_t max_sweeps,
                       double tol_mm) {
  // States: kFree (solitary, not reached), kFixed (has a displacement),
  // kQueued, kGuessed. Breadth-first from the fixed vertices gives the gaps'
  // vertices in order of distance and a first guess (the mean of the
  // neighbours already fixed or guessed); over-relaxed Gauss-Seidel sweeps in
  // that order then solve for the harmonic extension.
  constexpr uint8_t kFree = 0, kFixed = 1, kQueued = 2, kGuessed = 3;
  constexpr double kOmega = 1.8;
  const uint32_t nv = m.nv;
  uint32_t tail = 0;
  for (uint32_t v = 0; v < nv; ++v) has[v] = has[v] ? kFixed : kFree;
  for (uint32_t v = 0; v < nv; ++v) {
    if (has[v] != kFixed) continue;
    const uint32_t* nb = m.nbr + 4 * size_t(v);
    for (int k = 0; k < 4; ++k)
      if (has[nb[k]] == kFree) {
        has[nb[k]] = kQueued;
        queue[tail++] = nb[k];
      }
  }
  for (uint32_t head = 0; head < tail; ++head) {
    const uint32_t v = queue[head];
    const uint32_t* nb = m.nbr + 4 * size_t(v);
    double acc[3] = {0, 0, 0};
    int cnt = 0;
    for (int k = 0; k < 4; ++k) {
      const uint32_t w = nb[k];
      if (has[w] == kFree) {
        has[w] = kQueued;
        queue[tail++] = w;
      } else if (has[w] == kFixed || has[w] == kGuessed) {
        for (int a = 0; a < 3; ++a) acc[a] += d[3 * size_t(w) + a];
        ++cnt;
      }
    }
    for (int a = 0; a < 3; ++a) d[3 * size_t(v) + a] = acc[a] / cnt;  // cnt >= 1: reached from one
    has[v] = kGuessed;
  }
  // Every neighbour of a guessed vertex is fixed or guessed.
  for (uint32_t sweep = 0; sweep < max_sweeps; ++sweep) {
    double change = 0;
    for (uint32_t q = 0; q < tail; ++q) {
      const uint32_t v = queue[q];
      const uint32_t* nb = m.nbr + 4 * size_t(v);
      for (int a = 0; a < 3; ++a) {
        const double mean = 0.25 * (d[3 * size_t(nb[0]) + a] + d[3 * size_t(nb[1]) + a] + d[3 * size_t(nb[2]) + a] +
                                    d[3 * size_t(nb[3]) + a]);
        const double step = kOmega * (mean - d[3 * size_t(v) + a]);
        d[3 * size_t(v) + a] += step;
        change = std::fmax(change, std::fabs(step));
      }
    }
    if (change < tol_mm) break;
  }
  for (uint32_t v = 0; v < nv; ++v) has[v] = has[v] != kFree;
  return tail;
}

}  // namespace ffseg
