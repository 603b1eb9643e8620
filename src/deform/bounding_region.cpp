#include "bounding_region.h"

#include <cmath>
#include <cstdio>
#include <cstring>

#include "min_max.h"
#include "rasterize.h"
#include "spatial_grid.h"  // floor_i64

namespace ffseg {

void RegionMap::carve(Arena& a, int64_t max_voxels, bool speed_table) {
  t = a.alloc<float>(max_voxels > 0 ? size_t(max_voxels) : 0);
  speed.table = speed_table ? a.alloc<float>(kSpeedTableSize) : nullptr;
  speed.epoch = 0;
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

// The cells of the box, for the speed and seed passes.
struct CellBox {
  const int64_t* lo;  // voxel box
  const int64_t* n;
  const int64_t* f;   // voxels per cell
  const int64_t* clo; // cell box
  const int64_t* cn;
  bool unit() const { return f[0] == 1 && f[1] == 1 && f[2] == 1; }
  // Crop index of the cell holding voxel lo + (i, j, k).
  int64_t cell(int64_t i, int64_t j, int64_t k) const {
    return ((lo[0] + i) / f[0] - clo[0]) + cn[0] * (((lo[1] + j) / f[1] - clo[1]) + cn[1] * ((lo[2] + k) / f[2] - clo[2]));
  }
  // Voxels of the box in cell c along axis a.
  int64_t share(int a, int64_t c) const {
    const int64_t first = (clo[a] + c) * f[a], l = first > lo[a] ? first : lo[a];
    const int64_t e = first + f[a], h = e < lo[a] + n[a] ? e : lo[a] + n[a];
    return h - l;
  }
};

// Calls g(i, j, k, v) for every voxel lo + (i, j, k) of the box, rows along
// i, with v the smoothed value where the crop has it and the raw value
// elsewhere (the object's own smoothing, never a second one).
template <class G>
void for_each_value(const VolumeView& vol, const SmoothedRoi* roi, const int64_t lo[3], const int64_t n[3], G&& g) {
  const int64_t* glo = roi && roi->valid() ? roi->data_lo() : nullptr;
  const int64_t* ghi = roi && roi->valid() ? roi->data_hi() : nullptr;
  for (int64_t k = 0; k < n[2]; ++k)
    for (int64_t j = 0; j < n[1]; ++j) {
      const int64_t gj = lo[1] + j, gk = lo[2] + k;
      const bool row_smoothed = glo && gj >= glo[1] && gj < ghi[1] && gk >= glo[2] && gk < ghi[2];
      vol.for_each_in_row(lo[0], gj, gk, 0, n[0], [&](int64_t t, double raw) {
        const int64_t gi = lo[0] + t;
        g(t, j, k, row_smoothed && gi >= glo[0] && gi < ghi[0] ? double(roi->at(gi, gj, gk)) : raw);
      });
    }
}

// The posterior of eq. 6.2.2-6.2.3 tabulated over [vmin, vmax], linear in
// between: made into table (kSpeedTableSize entries), or taken from cache
// when it holds the table of the same range at the same models' epoch (the
// same function of the same values: the same floats).
struct SpeedTable {
  const float* table;
  double vmin, inv;
  SpeedTable(const RegionSpeed& sp, double lo, double hi, float* own, SpeedTableCache* cache) : vmin(lo) {
    const double step = hi > lo ? (hi - lo) / (kSpeedTableSize - 1) : 1.0;
    inv = 1.0 / step;
    const bool keep = cache && cache->table && sp.models_epoch != 0;
    if (keep && cache->epoch == sp.models_epoch && same_bits(cache->lo, lo) && same_bits(cache->hi, hi)) {
      table = cache->table;
      return;
    }
    float* out = keep ? cache->table : own;
    // A block of entries at a time: the posteriors' exps go through the
    // vector kernel, whose values are std::exp's bit for bit.
    constexpr int kBlock = 256;
    static_assert(kSpeedTableSize % kBlock == 0, "whole blocks");
    double v[kBlock], p[kBlock];
    for (int first = 0; first < kSpeedTableSize; first += kBlock) {
      for (int t = 0; t < kBlock; ++t) v[t] = lo + (first + t) * step;
      sp.model->posterior_against(v, kBlock, sp.others, sp.other_count, p);
      for (int t = 0; t < kBlock; ++t) out[first + t] = float(p[t]);
    }
    if (keep) {
      cache->epoch = sp.models_epoch;
      cache->lo = lo;
      cache->hi = hi;
    }
    table = out;
  }
  static bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
  float operator()(float v) const {
    if (!std::isfinite(v)) return 0.0f;
    const double f = (double(v) - vmin) * inv;
    int b = int(f);
    if (b >= kSpeedTableSize - 1) b = kSpeedTableSize - 2;
    if (b < 0) b = 0;
    const double w = f - b;
    return float(table[b] + w * (table[b + 1] - table[b]));
  }
};

// The speed image over the box's cells (fm's layout), eq. 6.2.2-6.2.3: per
// voxel on unit cells, else the mean of each cell's voxels.
// cache (may be nullptr): the region's last table (SpeedTable).
void fill_speed(const VolumeView& vol, const RegionSpeed& sp, const CellBox& cb, float* s, SpeedTableCache* cache) {
  const int64_t* lo = cb.lo;
  const int64_t* n = cb.n;
  const bool unit = cb.unit();
  const int64_t cells = cb.cn[0] * cb.cn[1] * cb.cn[2];
  auto indicator = [](double v) { return (std::isfinite(v) && v != 0) ? 1.0f : 0.0f; };
  if (unit && sp.model == nullptr) {
    int64_t q = 0;
    for_each_value(vol, nullptr, lo, n, [&](int64_t, int64_t, int64_t, double v) { s[q++] = indicator(v); });
    return;
  }
  // The range of the values first (on unit cells, the values kept in s).
  double vmin = INFINITY, vmax = -INFINITY;
  int64_t q = 0;
  if (sp.model) {
    for_each_value(vol, sp.roi, lo, n, [&](int64_t, int64_t, int64_t, double v) {
      const float f = float(v);
      if (unit) s[q++] = f;
      // Compared inline: std::fmin / fmax were a libm call per voxel, and
      // with finite values they differ at most in a zero's sign, which the
      // table built from the range never reads.
      if (std::isfinite(f)) {
        vmin = vmin < double(f) ? vmin : double(f);
        vmax = vmax > double(f) ? vmax : double(f);
      }
    });
  }
  float own[kSpeedTableSize];  // the table when none is kept
  if (unit) {
    const SpeedTable table(sp, vmin, vmax, own, cache);
    for (int64_t p = 0; p < q; ++p) s[p] = table(s[p]);
    return;
  }
  // Cells: the sum of their voxels' speeds, then the mean.
  for (int64_t c = 0; c < cells; ++c) s[c] = 0.0f;
  if (sp.model) {
    const SpeedTable table(sp, vmin, vmax, own, cache);
    for_each_value(vol, sp.roi, lo, n, [&](int64_t i, int64_t j, int64_t k, double v) {
      s[cb.cell(i, j, k)] += table(float(v));
    });
  } else {
    for_each_value(vol, nullptr, lo, n, [&](int64_t i, int64_t j, int64_t k, double v) {
      s[cb.cell(i, j, k)] += indicator(v);
    });
  }
  for (int64_t c2 = 0; c2 < cb.cn[2]; ++c2)
    for (int64_t c1 = 0; c1 < cb.cn[1]; ++c1)
      for (int64_t c0 = 0; c0 < cb.cn[0]; ++c0) {
        const int64_t count = cb.share(0, c0) * cb.share(1, c1) * cb.share(2, c2);
        s[c0 + cb.cn[0] * (c1 + cb.cn[1] * c2)] /= float(count);
      }
}

}  // namespace

bool region_cells(const int64_t lo[3], const int64_t n[3], const double h[3], int64_t max_cells, double max_cell_mm,
                  int64_t f[3]) {
  const double hmin = std::fmin(h[0], std::fmin(h[1], h[2]));
  double c = 1;
  // Each pass coarsens some axis still in several cells (f_a <= lo_a + n_a),
  // but for rounding at c beyond 2^53: a bound, never met on a real grid.
  const int64_t passes = lo[0] + n[0] + lo[1] + n[1] + lo[2] + n[2] + 64;
  for (int64_t pass = 0; pass < passes; ++pass) {
    double count = 1;
    int64_t cells[3];
    for (int a = 0; a < 3; ++a) {
      const double r = std::round(c * hmin / h[a]);
      f[a] = !(r >= 1) ? 1 : r > double(lo[a] + n[a]) ? lo[a] + n[a] : int64_t(r);  // NaN: 1; lo + n: one cell
      if (double(f[a]) * h[a] > max_cell_mm && f[a] > 1) return false;
      cells[a] = (lo[a] + n[a] - 1) / f[a] - lo[a] / f[a] + 1;
      count *= double(cells[a]);
    }
    if (count <= double(max_cells)) return true;
    // Only a coarser axis still in more than one cell can lower the count:
    // go straight to the next c at which one of them coarsens, so that a
    // grid whose spacings differ by orders of magnitude is not walked one c
    // at a time (1e-8 mm against 1 mm took 12 s).
    double next = HUGE_VAL;
    for (int a = 0; a < 3; ++a)
      if (cells[a] > 1) next = std::fmin(next, std::ceil((double(f[a]) + 0.5) * h[a] / hmin));
    if (!(next < HUGE_VAL)) return false;
    c = std::fmax(std::nextafter(c + 1, HUGE_VAL), next);
  }
  return false;
}

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
      mn[a] = fmin_inline(mn[a], p[a]);
      mx[a] = fmax_inline(mx[a], p[a]);
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
  int64_t f[3];
  if (!region_cells(lo, n, h, fm.max_voxels(), 0.5 * width_mm, f)) {
    if (msg && msg_len)
      std::snprintf(msg, msg_len,
                    "bounding region box %lld x %lld x %lld voxels does not fit the region budget of %lld voxels "
                    "(config.max_region_voxels, or max_roi_voxels when it is 0) on cells of at most half the "
                    "region width (%g mm)",
                    (long long)n[0], (long long)n[1], (long long)n[2], (long long)fm.max_voxels(), 0.5 * width_mm);
    return RegionStatus::too_large;
  }
  int64_t clo[3], cn[3];
  double hc[3];
  for (int a = 0; a < 3; ++a) {
    clo[a] = lo[a] / f[a];
    cn[a] = (lo[a] + n[a] - 1) / f[a] - clo[a] + 1;
    hc[a] = h[a] * double(f[a]);
  }
  const CellBox cb{lo, n, f, clo, cn};
  const FmStatus bs = fm.begin(cn, hc, msg, msg_len);
  if (bs == FmStatus::too_large) return RegionStatus::too_large;
  if (bs != FmStatus::ok) return RegionStatus::off_grid;
  // The front: the cells whose centres lie inside the mesh and the one
  // nearest to each vertex.
  const VolumeView cells = cb.unit() ? vol : vol.cell_geometry(f);
  rasterize_mesh_box(m, x, cells, clo, cn, seed_mask);
  const int64_t count = cn[0] * cn[1] * cn[2];
  for (uint32_t v = 0; v < m.nv; ++v) {
    double p[3];
    int64_t q[3];
    cells.world_to_index(x + 3 * size_t(v), p);
    if (!nearest_voxel(cells, p, q)) continue;
    if (q[0] < clo[0] || q[1] < clo[1] || q[2] < clo[2] || q[0] >= clo[0] + cn[0] || q[1] >= clo[1] + cn[1] ||
        q[2] >= clo[2] + cn[2])
      continue;
    seed_mask[(q[0] - clo[0]) + cn[0] * ((q[1] - clo[1]) + cn[1] * (q[2] - clo[2]))] = 1;
  }
  fm.seed_mask(seed_mask);
  float* s = fm.speed_buffer();
  fill_speed(vol, speed, cb, s, &out.speed);
  const float cap = float(width_mm);
  fm.march(s, cap);
  const float* t = fm.times();
  for (int64_t q = 0; q < count; ++q) out.t[q] = t[q] <= cap ? t[q] : RegionMap::kNotReached;
  for (int a = 0; a < 3; ++a) {
    out.lo[a] = lo[a];
    out.n[a] = n[a];
    out.f[a] = f[a];
    out.clo[a] = clo[a];
    out.cn[a] = cn[a];
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

}  // namespace ffseg
