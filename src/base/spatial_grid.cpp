#include "spatial_grid.h"

namespace ffseg {

void SpatialGrid::carve(Arena& a, uint32_t max_points) {
  carve_table(a, max_points, max_points);
  cellkey_ = a.alloc<uint64_t>(max_points);
  key_ = a.alloc<uint32_t>(max_points);
  sorted_ = a.alloc<double>(size_t(3) * max_points);
}

void BoxGrid::carve(Arena& a, uint32_t max_boxes) {
  carve_table(a, max_boxes, kMaxEntries * max_boxes);
  key_ = a.alloc<uint32_t>(size_t(kMaxEntries) * max_boxes);
}

}  // namespace ffseg
