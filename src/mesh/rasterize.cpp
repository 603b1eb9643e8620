// Parity scan conversion along the i axis: every triangle toggles the first
// voxel of each (j,k) row past the point where the row's ray crosses it, then
// a running XOR along each row turns toggles into inside/outside. The caller's
// mask is its own scratch, so no memory is needed.
#include "rasterize.h"

#include <cmath>

#include "min_max.h"
#include "triangulation.h"

namespace ffseg {

namespace {

// Rays run through (j + dj, k + dk): a tiny irrational-looking offset keeps them
// off mesh vertices and edges placed exactly on grid lines by symmetry.
constexpr double kDj = 1.17e-7, kDk = 2.31e-7;

// Twice the signed area of (a, b, p) in the (j, k) plane, evaluated with the
// lower vertex index first so that the two triangles sharing an edge see exactly
// opposite values: a ray is then counted by exactly one of them.
// The voxel rows lo..hi (clamped to 0..n-1) whose shifted centres lie in
// [a, b]; empty (lo > hi) when none does or a bound is NaN. Clamped before
// the conversion: a vertex far off the grid must not overflow int64_t.
inline void centre_range(double a, double b, double shift, int64_t n, int64_t* lo, int64_t* hi) {
  const double l = std::ceil(a - shift), h = std::floor(b - shift);
  if (!(l <= h && h >= 0 && l <= double(n - 1))) {
    *lo = 1;
    *hi = 0;
    return;
  }
  *lo = l > 0 ? int64_t(l) : 0;
  *hi = h < double(n - 1) ? int64_t(h) : n - 1;
}

inline double edge_fn(const double* pa, uint32_t ia, const double* pb, uint32_t ib, double pj, double pk) {
  if (ia > ib) return -edge_fn(pb, ib, pa, ia, pj, pk);
  return (pb[1] - pa[1]) * (pk - pa[2]) - (pb[2] - pa[2]) * (pj - pa[1]);
}

// The toggles of the parity scan for the voxel rows (j, k) of the box
// [lo, lo + n) (volume index space): toggle(i, j, k, s) for the first voxel of
// the row, clamped to the box, whose centre lies past the row's crossing of
// a triangle (crossings beyond the box's end are dropped: they change no
// voxel of it); s is the sign of the triangle's area projected on (j, k),
// which tells entries from exits of a consistently oriented mesh. The rows'
// rays and crossings are those of the whole grid, so a box's mask is the
// grid's mask cut to the box bit for bit.
template <class Toggle>
void scan_crossings(const CubeSphere& m, const double* x, const VolumeView& vol, const int64_t lo[3],
                    const int64_t n[3], Toggle&& toggle) {
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    uint32_t tri[6];
    const int nt = face_triangles(m, f, tri, x);
    for (int t = 0; t < nt; ++t) {
      double p[3][3];
      const uint32_t id[3] = {tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]};
      for (int c = 0; c < 3; ++c) vol.world_to_index(x + 3 * size_t(id[c]), p[c]);
      double mnj = p[0][1], mxj = p[0][1], mnk = p[0][2], mxk = p[0][2];
      for (int c = 1; c < 3; ++c) {
        mnj = fmin_inline(mnj, p[c][1]); mxj = fmax_inline(mxj, p[c][1]);
        mnk = fmin_inline(mnk, p[c][2]); mxk = fmax_inline(mxk, p[c][2]);
      }
      int64_t j0, j1, k0, k1;
      centre_range(mnj - double(lo[1]), mxj - double(lo[1]), kDj, n[1], &j0, &j1);
      centre_range(mnk - double(lo[2]), mxk - double(lo[2]), kDk, n[2], &k0, &k1);
      for (int64_t kb = k0; kb <= k1; ++kb)
        for (int64_t jb = j0; jb <= j1; ++jb) {
          const int64_t j = jb + lo[1], k = kb + lo[2];
          const double pj = double(j) + kDj, pk = double(k) + kDk;
          const double w0 = edge_fn(p[1], id[1], p[2], id[2], pj, pk);
          const double w1 = edge_fn(p[2], id[2], p[0], id[0], pj, pk);
          const double w2 = edge_fn(p[0], id[0], p[1], id[1], pj, pk);
          const bool inside = (w0 > 0 && w1 > 0 && w2 > 0) || (w0 < 0 && w1 < 0 && w2 < 0);
          if (!inside) continue;
          const double sum = w0 + w1 + w2;
          const double xi = (w0 * p[0][0] + w1 * p[1][0] + w2 * p[2][0]) / sum;
          // Voxel centres strictly past the crossing change state.
          double first = std::floor(xi) + 1.0;
          if (first < double(lo[0])) first = double(lo[0]);
          if (!(first < double(lo[0] + n[0]))) continue;
          toggle(int64_t(first) - lo[0], jb, kb, w0 > 0);
        }
    }
  }
}

}  // namespace

void rasterize_mesh(const CubeSphere& m, const double* x, const VolumeView& vol, uint8_t* mask,
                    const int64_t strides_in[3]) {
  const int64_t* D = vol.dims();
  int64_t s[3];
  if (strides_in) {
    s[0] = strides_in[0]; s[1] = strides_in[1]; s[2] = strides_in[2];
  } else {
    s[0] = 1; s[1] = D[0]; s[2] = D[0] * D[1];
  }
  for (int64_t k = 0; k < D[2]; ++k)
    for (int64_t j = 0; j < D[1]; ++j)
      for (int64_t i = 0; i < D[0]; ++i) mask[i * s[0] + j * s[1] + k * s[2]] = 0;

  int64_t jlo = D[1], jhi = -1, klo = D[2], khi = -1;
  const int64_t zero[3] = {0, 0, 0};
  scan_crossings(m, x, vol, zero, D, [&](int64_t i, int64_t j, int64_t k, bool) {
    mask[i * s[0] + j * s[1] + k * s[2]] ^= 1;
    if (j < jlo) jlo = j;
    if (j > jhi) jhi = j;
    if (k < klo) klo = k;
    if (k > khi) khi = k;
  });
  for (int64_t k = klo; k <= khi; ++k)
    for (int64_t j = jlo; j <= jhi; ++j) {
      uint8_t inside = 0;
      for (int64_t i = 0; i < D[0]; ++i) {
        uint8_t& cell = mask[i * s[0] + j * s[1] + k * s[2]];
        inside ^= cell;
        cell = inside;
      }
    }
}

int64_t rasterize_mesh_box(const CubeSphere& m, const double* x, const VolumeView& vol, const int64_t lo[3],
                           const int64_t n[3], uint8_t* mask) {
  const int64_t n01 = n[0] * n[1], count = n01 * n[2];
  for (int64_t q = 0; q < count; ++q) mask[q] = 0;
  scan_crossings(m, x, vol, lo, n, [&](int64_t i, int64_t j, int64_t k, bool) { mask[i + n[0] * j + n01 * k] ^= 1; });
  int64_t inside_count = 0;
  for (int64_t r = 0; r < n[1] * n[2]; ++r) {
    uint8_t inside = 0;
    uint8_t* row = mask + n[0] * r;
    for (int64_t i = 0; i < n[0]; ++i) {
      inside ^= row[i];
      row[i] = inside;
      inside_count += inside;
    }
  }
  return inside_count;
}

int64_t count_inside_voxels(const CubeSphere& m, const double* x, const VolumeView& vol) {
  // Along a row, the voxels inside are those past an entry less those past
  // the exit that follows it: sum s (N - first) over the row's crossings,
  // with s +1 for one orientation and -1 for the other. Which orientation
  // enters depends on the mesh's and the affine's handedness, the same for
  // every row, hence the absolute value of the total.
  const int64_t* D = vol.dims();
  const int64_t zero[3] = {0, 0, 0};
  int64_t signed_count = 0;
  scan_crossings(m, x, vol, zero, D, [&](int64_t i, int64_t, int64_t, bool s) {
    signed_count += s ? D[0] - i : i - D[0];
  });
  return signed_count < 0 ? -signed_count : signed_count;
}

bool mesh_fills_grid(const CubeSphere& m, const double* x, const VolumeView& vol, double fraction) {
  const int64_t* D = vol.dims();
  const double limit = fraction * double(D[0]) * double(D[1]) * double(D[2]);
  // Every voxel centre inside the mesh lies in its vertices' bounding box:
  // when the box holds no more centres than the limit, nothing is counted.
  double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (uint32_t v = 0; v < m.nv; ++v) {
    double p[3];
    vol.world_to_index(x + 3 * size_t(v), p);
    for (int a = 0; a < 3; ++a) {
      lo[a] = fmin_inline(lo[a], p[a]);
      hi[a] = fmax_inline(hi[a], p[a]);
    }
  }
  double box = 1;
  for (int a = 0; a < 3; ++a) {
    const double l = std::fmax(std::ceil(lo[a]), 0.0), h = std::fmin(std::floor(hi[a]), double(D[a] - 1));
    box *= h >= l ? h - l + 1 : 0;
  }
  if (!(box > limit)) return false;
  return double(count_inside_voxels(m, x, vol)) > limit;
}

}  // namespace ffseg
