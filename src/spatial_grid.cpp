#include "spatial_grid.h"

namespace ffseg {

void SpatialGrid::carve(Arena& a, uint32_t max_points) {
  max_points_ = max_points;
  table_ = 1;
  while (table_ < 2 * max_points) table_ <<= 1;
  mask_ = table_ - 1;
  start_ = a.alloc<uint32_t>(size_t(table_) + 1);
  ids_ = a.alloc<uint32_t>(max_points);
  key_ = a.alloc<uint32_t>(max_points);
}

void SpatialGrid::build(const double* pts, uint32_t count, double h) {
  pts_ = pts;
  inv_h_ = 1.0 / h;
  for (uint32_t b = 0; b <= table_; ++b) start_[b] = 0;
  for (uint32_t i = 0; i < count; ++i) {
    const double* p = pts + 3 * size_t(i);
    key_[i] = hash(cell(p[0]), cell(p[1]), cell(p[2]));
    ++start_[key_[i] + 1];
  }
  for (uint32_t b = 0; b < table_; ++b) start_[b + 1] += start_[b];
  // Scatter using start_ as a cursor, then shift back.
  for (uint32_t i = 0; i < count; ++i) ids_[start_[key_[i]]++] = i;
  for (uint32_t b = table_; b > 0; --b) start_[b] = start_[b - 1];
  start_[0] = 0;
}

}  // namespace ffseg
