// A hashed uniform grid over points, held in workspace memory: counting sort
// of point ids by cell hash, rebuilt in O(points); ball queries visit the
// cells overlapping the ball's bounding box.
#pragma once
#include <cstdint>

#include "arena.h"

namespace ffseg {

class SpatialGrid {
 public:
  void carve(Arena& a, uint32_t max_points);
  // pts: 3 * count coordinates; h: cell size (> 0).
  void build(const double* pts, uint32_t count, double h);

  // Calls f(id) for every point within r of c (ids are indices into pts).
  template <class F>
  void for_each_in_ball(const double c[3], double r, F&& f) const {
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = cell(c[a] - r);
      hi[a] = cell(c[a] + r);
    }
    const double r2 = r * r;
    for (int64_t z = lo[2]; z <= hi[2]; ++z)
      for (int64_t y = lo[1]; y <= hi[1]; ++y)
        for (int64_t x = lo[0]; x <= hi[0]; ++x) {
          const uint32_t b = hash(x, y, z);
          for (uint32_t k = start_[b]; k < start_[b + 1]; ++k) {
            const uint32_t id = ids_[k];
            const double* p = pts_ + 3 * size_t(id);
            const double dx = p[0] - c[0], dy = p[1] - c[1], dz = p[2] - c[2];
            if (dx * dx + dy * dy + dz * dz <= r2) f(id);
          }
        }
  }

 private:
  int64_t cell(double v) const { return int64_t(__builtin_floor(v * inv_h_)); }
  uint32_t hash(int64_t x, int64_t y, int64_t z) const {
    const uint64_t h = uint64_t(x) * 73856093u ^ uint64_t(y) * 19349663u ^ uint64_t(z) * 83492791u;
    return uint32_t(h & mask_);
  }

  uint32_t max_points_ = 0, table_ = 0, mask_ = 0;
  uint32_t* start_ = nullptr;  // table_ + 1
  uint32_t* ids_ = nullptr;    // max_points_
  uint32_t* key_ = nullptr;    // max_points_
  const double* pts_ = nullptr;
  double inv_h_ = 1;
};

}  // namespace ffseg
