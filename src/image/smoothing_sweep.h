// The Perona-Malik sweep of smoothing.cpp (SmoothedRoi::diffuse) as an
// always-inlined template over the vector width, shared by the 4-lane
// instance there and the AVX2 / AVX-512F instances in smoothing_x86.cpp, so
// every width compiles the same operations. Internal to image/.
#pragma once
#include <cstdint>
#include <cstring>

#include "cpu_x86.h"

// Before the template: clang takes the pragma from here on, for every file
// that instantiates it.
#include "fp_contract_off.h"

namespace ffseg {
namespace smoothing_kernels {

// Floats of padding around each flux buffer of the sweep (vector loads one
// lane before a row's first u face).
constexpr int64_t kFluxPad = 16;

// Flux of one face, c(|dI|/h) dI / h^2 (eq. 5.2.1, 5.2.2), d = neighbour - centre.
inline float face_flux(float d, float w, float ik) { return w * d / (1.0f + d * d * ik); }

// W voxels at once with the scalar code's exact operations and order (vector
// lanes are IEEE single precision like the scalar unit, and no FMA is formed:
// the wide kernels' targets leave out "fma", which is what keeps GCC from
// contracting a * b + c, since it does so in C++ whatever the -std mode), so the result is bit-identical to the plain per-voxel update
// (every face that exists, in the order -u, +u, -v, +v, -w, +w) for every W.
// The helpers below take and return 32- and 64-byte vectors; they are always
// inlined into the kernels compiled for those widths, so no call crosses the
// ABI difference GCC warns about.
#pragma GCC diagnostic ignored "-Wpsabi"
typedef float V4 __attribute__((vector_size(16)));
typedef float V8 __attribute__((vector_size(32)));
typedef float V16 __attribute__((vector_size(64)));
typedef int32_t V4i __attribute__((vector_size(16)));
typedef int32_t V8i __attribute__((vector_size(32)));
typedef int32_t V16i __attribute__((vector_size(64)));
template <class V>
__attribute__((always_inline)) inline V loadv(const float* p) {
  V r;
  std::memcpy(&r, p, sizeof r);
  return r;
}
template <class V>
__attribute__((always_inline)) inline void storev(float* p, V v) {
  std::memcpy(p, &v, sizeof v);
}
template <class V>
__attribute__((always_inline)) inline V face_fluxv(V d, V w, V ik, V one) {
  return w * d / (one + d * d * ik);
}

// One explicit step over the region (planes along the slowest axis, swept in
// place with two planes of scratch; see SmoothedRoi::diffuse), each face's
// flux computed once: face_flux(-d) is -face_flux(d) bit for bit (IEEE
// negation is exact and rounding symmetric), so the -u, -v and -w faces of a
// voxel take the negated flux its neighbour computed for its +u, +v, +w
// face. The sums keep the per-voxel order (-u, +u, -v, +v, -w, +w) and
// never hold -0 (they start at +0), so adding the negated zero of a flux
// changes nothing: bit-identical. The u fluxes of a row come first (fu), the
// v and w ones go to the current buffers for the next row and plane (the
// previous buffers are read: vectors may overlap, so never in place). Rows
// of at least 2W voxels: W lanes throughout, the first and last vector with
// the edge voxels (the last one overlaps the interior: the same values
// again); shorter rows voxel by voxel.
template <class V, class VI, int W>
__attribute__((always_inline)) inline void diffuse_sweep(float* buf, float* scratch, int64_t E0, int64_t E1,
                                                         int64_t E2, const float w[3], const float ik[3]) {
  const int64_t P = E0 * E1;
  scratch[0] = scratch[P + 1] = scratch[2 * P + 2] = 0.0f;
  float* fw[2] = {scratch + 2 * P + 3 + kFluxPad, scratch + 3 * P + 3 + 3 * kFluxPad};
  float* fu = scratch + 4 * P + 3 + 5 * kFluxPad;
  float* fv[2] = {fu + E0 + 2 * kFluxPad, fu + 2 * E0 + 4 * kFluxPad};
  fu[-1] = fu[E0 - 1] = 0.0f;  // no face beyond either end (never added: the pads keep loads finite)
  V one, w0, w1, w2, k0, k1, k2, zero;
  VI first, last;
  for (int l = 0; l < W; ++l) {
    one[l] = 1.0f, zero[l] = 0.0f;
    w0[l] = w[0], w1[l] = w[1], w2[l] = w[2];
    k0[l] = ik[0], k1[l] = ik[1], k2[l] = ik[2];
    first[l] = l == 0 ? -1 : 0;
    last[l] = l == W - 1 ? -1 : 0;
  }
  for (int64_t q = 0; q < E2; ++q) {
    // Old values: plane q in copy q & 1, plane q - 1 in the other, plane q + 1
    // still untouched in buf; the new plane q is written in place.
    float* cur = scratch + 1 + (q & 1) * (P + 1);
    const bool has_prev = q > 0, has_next = q + 1 < E2;
    const float* next = has_next ? buf + (q + 1) * P : nullptr;
    float* outp = buf + q * P;
    std::memcpy(cur, outp, size_t(P) * sizeof(float));
    const float* fw_prev = fw[(q + 1) & 1];  // plane q - 1's +w fluxes
    float* fw_cur = fw[q & 1];
    for (int64_t v = 0; v < E1; ++v) {
      const int64_t row = v * E0;
      const bool vm = v > 0, vp = v + 1 < E1;
      const float* fv_prev = fv[(v + 1) & 1];  // row v - 1's +v fluxes
      float* fv_cur = fv[v & 1];
      const float* c = cur + row;
      int64_t u = 0;
      if (E0 >= 2 * W)
        for (; u + W <= E0 - 1; u += W) storev<V>(fu + u, face_fluxv<V>(loadv<V>(c + u + 1) - loadv<V>(c + u), w0, k0, one));
      for (; u < E0 - 1; ++u) fu[u] = face_flux(c[u + 1] - c[u], w[0], ik[0]);
      // Voxels u .. u + W - 1 (edge: FIRST / LAST drop the missing u face).
      auto block = [&](int64_t u0, bool is_first, bool is_last) {
        const int64_t i = row + u0;
        const V c0 = loadv<V>(cur + i);
        V acc = zero;
        const V a1 = acc - loadv<V>(fu + u0 - 1);
        acc = is_first ? (first ? acc : a1) : a1;
        const V a2 = acc + loadv<V>(fu + u0);
        acc = is_last ? (last ? acc : a2) : a2;
        if (vm) acc -= loadv<V>(fv_prev + u0);
        if (vp) {
          const V f = face_fluxv<V>(loadv<V>(cur + i + E0) - c0, w1, k1, one);
          acc += f;
          storev<V>(fv_cur + u0, f);
        }
        if (has_prev) acc -= loadv<V>(fw_prev + i);
        if (has_next) {
          const V f = face_fluxv<V>(loadv<V>(next + i) - c0, w2, k2, one);
          acc += f;
          storev<V>(fw_cur + i, f);
        }
        storev<V>(outp + i, c0 + acc);
      };
      if (E0 >= 2 * W) {
        block(0, true, false);
        for (u = W; u + W <= E0 - 1; u += W) block(u, false, false);
        block(E0 - W, false, true);
        continue;
      }
      for (u = 0; u < E0; ++u) {
        const int64_t i = row + u;
        const float c0 = cur[i];
        float acc = 0;
        if (u > 0) acc -= fu[u - 1];
        if (u + 1 < E0) acc += fu[u];
        if (vm) acc -= fv_prev[u];
        if (vp) {
          const float f = face_flux(cur[i + E0] - c0, w[1], ik[1]);
          acc += f;
          fv_cur[u] = f;
        }
        if (has_prev) acc -= fw_prev[i];
        if (has_next) {
          const float f = face_flux(next[i] - c0, w[2], ik[2]);
          acc += f;
          fw_cur[i] = f;
        }
        outp[i] = c0 + acc;
      }
    }
  }
}

#if FFSEG_X86
// smoothing_x86.cpp: one sweep in 8 (AVX2) or 16 (AVX-512F) lanes.
void diffuse_sweep_avx2(float* buf, float* scratch, int64_t E0, int64_t E1, int64_t E2, const float w[3],
                        const float ik[3]);
void diffuse_sweep_avx512(float* buf, float* scratch, int64_t E0, int64_t E1, int64_t E2, const float w[3],
                          const float ik[3]);
#endif

}  // namespace smoothing_kernels
}  // namespace ffseg
