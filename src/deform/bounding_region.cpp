#include "bounding_region.h"

#include <cmath>
#include <cstdio>

#include "rasterize.h"
#include "spatial_grid.h"  // floor_i64

namespace ffseg {

void RegionMap::carve(Arena& a, int64_t max_voxels) {
  t = a.alloc<float>(max_voxels > 0 ? size_t(max_voxels) : 0);
  valid = false;
}

bool RegionMap::holds(const VolumeView& vol, const double* x, uint32_t nv, double margin_mm) const {
  if (!valid) return false;
  const int64_t* D = vol.dims();
  const double* h = vol.spacing();
  // The inner part of the box; a face on the grid's border is no limit.
  double lo_in[3], hi_in[3];
  for (int a = 0; a < 3; ++a) {
    const double m = margin_mm / h[a];
    lo_in[a] = lo[a] > 0 ? double(lo[a]) + m : -1e300;
    hi_in[a] = lo[a] + n[a] < D[a] ? double(lo[a] + n[a] - 1) - m : 1e300;
  }
  for (uint32_t v = 0; v < nv; ++v) {
    double p[3];
    vol.world_to_index(x + 3 * size_t(v), p);
    for (int a = 0; a < 3; ++a)
      if (!(p[a] >= lo_in[a] && p[a] <= hi_in[a])) return false;
  }
  return true;
}

namespace {

// Nearest voxel of index-space point p, false off the grid.
bool nearest_voxel(const VolumeView& vol, const double p[3], int64_t q[3]) {
  const int64_t* D = vol.dims();
  for (int a = 0; a < 3; ++a) {
    if (!(p[a] > -0.5 && p[a] < double(D[a]) - 0.5)) return false;
    q[a] = floor_i64(p[a] + 0.5);
    if (q[a] >= D[a]) q[a] = D[a] - 1;
  }
  return true;
}

constexpr int kSpeedTable = 4096;

// The speed image over the box (fm's layout), eq. 6.2.2-6.2.3.
void fill_speed(const VolumeView& vol, const RegionSpeed& sp, const int64_t lo[3], const int64_t n[3], float* s) {
  if (sp.model == nullptr) {
    int64_t q = 0;
    for (int64_t k = 0; k < n[2]; ++k)
      for (int64_t j = 0; j < n[1]; ++j)
        vol.for_each_in_row(lo[0], lo[1] + j, lo[2] + k, 0, n[0], [&](int64_t, double v) {
          s[q++] = (std::isfinite(v) && v != 0) ? 1.0f : 0.0f;
        });
    return;
  }
  const SmoothedRoi* roi = sp.roi;
  const int64_t* glo = roi && roi->valid() ? roi->data_lo() : nullptr;
  const int64_t* ghi = roi && roi->valid() ? roi->data_hi() : nullptr;
  // The values first (smoothed where the crop has them), into s, and their range.
  double vmin = INFINITY, vmax = -INFINITY;
  int64_t q = 0;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j) {
      const int64_t gj = lo[1] + j, gk = lo[2] + k;
      const bool row_smoothed = glo && gj >= glo[1] && gj < ghi[1] && gk >= glo[2] && gk < ghi[2];
      vol.for_each_in_row(lo[0], gj, gk, 0, n[0], [&](int64_t t, double raw) {
        const int64_t gi = lo[0] + t;
        const double v = row_smoothed && gi >= glo[0] && gi < ghi[0] ? double(roi->at(gi, gj, gk)) : raw;
        const float f = float(v);
        s[q++] = f;
        if (std::isfinite(f)) {
          vmin = std::fmin(vmin, double(f));
          vmax = std::fmax(vmax, double(f));
        }
      });
    }
  float table[kSpeedTable];
  const double step = vmax > vmin ? (vmax - vmin) / (kSpeedTable - 1) : 1.0;
  for (int b = 0; b < kSpeedTable; ++b)
    table[b] = float(sp.model->posterior_against(vmin + b * step, sp.others, sp.other_count));
  const double inv = 1.0 / step;
  for (int64_t p = 0; p < q; ++p) {
    const float v = s[p];
    if (!std::isfinite(v)) {
      s[p] = 0.0f;
      continue;
    }
    const double f = (double(v) - vmin) * inv;
    int b = int(f);
    if (b >= kSpeedTable - 1) b = kSpeedTable - 2;
    if (b < 0) b = 0;
    const double w = f - b;
    s[p] = float(table[b] + w * (table[b + 1] - table[b]));
  }
}

}  // namespace

RegionStatus compute_region(const CubeSphere& m, const double* x, const VolumeView& vol, const RegionSpeed& speed,
                            double width_mm, FastMarching& fm, uint8_t* seed_mask, RegionMap& out, char* msg,
                            size_t msg_len) {
  out.valid = false;
  const int64_t* D = vol.dims();
  const double* h = vol.spacing();
  // The mesh's box in index space (eq. 6.2.6-6.2.11), grown by width_mm.
  double mn[3] = {1e300, 1e300, 1e300}, mx[3] = {-1e300, -1e300, -1e300};
  for (uint32_t v = 0; v < m.nv; ++v) {
    double p[3];
    vol.world_to_index(x + 3 * size_t(v), p);
    for (int a = 0; a < 3; ++a) {
      mn[a] = std::fmin(mn[a], p[a]);
      mx[a] = std::fmax(mx[a], p[a]);
    }
  }
  int64_t lo[3], n[3];
  for (int a = 0; a < 3; ++a) {
    const double g = width_mm / h[a];
    double l = std::floor(mn[a] - g), u = std::ceil(mx[a] + g);
    if (!(l <= u) || u < 0 || l > double(D[a] - 1)) {
      if (msg && msg_len) std::snprintf(msg, msg_len, "bounding region: the mesh has left the volume");
      return RegionStatus::off_grid;
    }
    if (l < 0) l = 0;
    if (u > double(D[a] - 1)) u = double(D[a] - 1);
    lo[a] = int64_t(l);
    n[a] = int64_t(u) - lo[a] + 1;
  }
  const FmStatus bs = fm.begin(n, h, msg, msg_len);
  if (bs == FmStatus::too_large) return RegionStatus::too_large;
  if (bs != FmStatus::ok) return RegionStatus::off_grid;
  // The front: the voxels inside the mesh and the one nearest to each vertex.
  rasterize_mesh_box(m, x, vol, lo, n, seed_mask);
  const int64_t count = n[0] * n[1] * n[2];
  for (uint32_t v = 0; v < m.nv; ++v) {
    double p[3];
    int64_t q[3];
    vol.world_to_index(x + 3 * size_t(v), p);
    if (!nearest_voxel(vol, p, q)) continue;
    seed_mask[(q[0] - lo[0]) + n[0] * ((q[1] - lo[1]) + n[1] * (q[2] - lo[2]))] = 1;
  }
  fm.seed_mask(seed_mask);
  float* s = fm.speed_buffer();
  fill_speed(vol, speed, lo, n, s);
  const float cap = float(width_mm);
  fm.march(s, cap);
  const float* t = fm.times();
  for (int64_t q = 0; q < count; ++q) out.t[q] = t[q] <= cap ? t[q] : RegionMap::kNotReached;
  for (int a = 0; a < 3; ++a) {
    out.lo[a] = lo[a];
    out.n[a] = n[a];
  }
  out.cap = cap;
  out.reached = fm.accepted();
  out.valid = true;
  return RegionStatus::ok;
}

uint32_t RegionSet::owner(int64_t i, int64_t j, int64_t k) const {
  uint32_t best = kNobody;
  float bt = RegionMap::kNotReached;
  for (uint32_t o = 0; o < count; ++o) {
    const RegionMap& r = regions[o];
    if (!r.valid) continue;
    const float t = r.time_at(i, j, k);
    if (t < bt) {  // strictly earlier: ties stay with the lower index
      bt = t;
      best = o;
    }
  }
  return best;
}

bool RegionSet::owns(uint32_t object, int64_t i, int64_t j, int64_t k) const { return owner(i, j, k) == object; }

uint32_t RegionSet::owner_at(const VolumeView& vol, const double p[3]) const {
  int64_t q[3];
  if (!nearest_voxel(vol, p, q)) return kNobody;
  return owner(q[0], q[1], q[2]);
}

}  // namespace ffseg
