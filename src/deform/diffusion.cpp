#include "diffusion.h"

#include <cmath>

#include "diffusion_x86.h"
#include "min_max.h"

namespace ffseg {

namespace {

// Every vertex has a displacement (the usual case after harmonic_fill): each
// round is the plain 5-point mean, summed in the general loop's order (from
// 0, the vertex, then its neighbours) so every value is bit for bit the
// same; rounds alternate between d and tmp instead of copying back.
void diffuse_all(const CpuDispatch& cpu, const CubeSphere& m, uint32_t rounds, double* d, double* tmp) {
  const uint32_t nv = m.nv;
  const uint32_t* nbr = m.nbr;
  double* src = d;
  double* dst = tmp;
  for (uint32_t r = 0; r < rounds; ++r) {
    uint32_t v = 0;
#if FFSEG_X86 && defined(__SSE2__)
    if (cpu.kernel(KernelFamily::diffusion) == Isa::sse2) v = diffuse_round_sse2(nv, nbr, src, dst);
#else
    (void)cpu;
#endif
    for (; v < nv; ++v) {
      const uint32_t* nb = nbr + 4 * size_t(v);
      const double *p = src + 3 * size_t(v), *p0 = src + 3 * size_t(nb[0]), *p1 = src + 3 * size_t(nb[1]),
                   *p2 = src + 3 * size_t(nb[2]), *p3 = src + 3 * size_t(nb[3]);
      double* q = dst + 3 * size_t(v);
      for (int a = 0; a < 3; ++a) q[a] = ((((0.0 + p[a]) + p0[a]) + p1[a]) + p2[a] + p3[a]) / 5;
    }
    double* t = src;
    src = dst;
    dst = t;
  }
  if (src != d)
    for (size_t q = 0; q < size_t(3) * nv; ++q) d[q] = src[q];
}

}  // namespace

void diffuse_displacements(const CpuDispatch& cpu, const CubeSphere& m, uint32_t rounds, double* d, uint8_t* has,
                           double* tmp, uint8_t* tmp_has) {
  bool all = true;
  for (uint32_t v = 0; v < m.nv && all; ++v) all = has[v] != 0;
  if (all && rounds > 0) {
    // The general loop would leave tmp and tmp_has as the last round's.
    diffuse_all(cpu, m, rounds, d, tmp);
    for (uint32_t v = 0; v < m.nv; ++v) {
      has[v] = 1;
      tmp_has[v] = 1;
    }
    return;
  }
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
        change = fmax_inline(change, std::fabs(step));
      }
    }
    if (change < tol_mm) break;
  }
  for (uint32_t v = 0; v < nv; ++v) has[v] = has[v] != kFree;
  return tail;
}

}  // namespace ffseg
