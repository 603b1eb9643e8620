#include "spatial_grid.h"

namespace ffseg {

void SpatialGrid::carve(Arena& a, uint32_t max_points) {
  max_points_ = max_points;
  table_ = 1;
  while (table_ < 2 * max_points) table_ <<= 1;
  mask_ = table_ - 1;
  start_ = a.alloc<uint32_t>(size_t(table_) + 1);
  ids_ = a.alloc<uint32_t>(max_points);
  cellkey_ = a.alloc<uint64_t>(max_points);
  key_ = a.alloc<uint32_t>(max_points);
}

void BoxGrid::carve(Arena& a, uint32_t max_boxes) {
  max_entries_ = kMaxEntries * max_boxes;
  table_ = 1;
  while (table_ < 2 * max_boxes) table_ <<= 1;
  mask_ = table_ - 1;
  start_ = a.alloc<uint32_t>(size_t(table_) + 1);
  ids_ = a.alloc<uint32_t>(max_entries_);
  key_ = a.alloc<uint32_t>(max_entries_);
}

}  // namespace ffseg
