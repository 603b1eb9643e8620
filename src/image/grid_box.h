// The scan's box: where a mesh may lie (issue 30: an organ cut by the scan's
// first or last slice, a partial scan).
//
// The grid covers the index-space box [-0.5, dims - 0.5] (voxel centres at
// the integers, each voxel half a spacing either side). Beyond it nothing was
// imaged, so nothing there can be segmented: an organ the scan cuts is
// segmented as its part inside the scan, bounded by the box's face.
//
// The searches already end the organ at the face (beyond the grid reads as
// background, so the crossing lies on it), but the solve does not: its
// smoothness terms round the flat cap a cut organ presses against the face,
// and carried vertices up to a voxel beyond it (the shared CT's liver, cut by
// the scan's top slice: 2.7 mm). The engine therefore clamps every solved
// position onto the box before the step guard checks the update; clamping
// is the box's nearest-point map along index axes, the identity inside.
// Searching along the face instead (a ray that meets the box slides on it)
// was measured and lost Dice on the same scans (BENCHMARKS.md section 10).
#pragma once
#include <cstdint>

#include "volume.h"

namespace ffseg {

class GridBox {
 public:
  explicit GridBox(const int64_t dims[3]) {
    for (int a = 0; a < 3; ++a) hi_[a] = double(dims[a]) - 0.5;
  }

  bool contains(const double p[3]) const {
    for (int a = 0; a < 3; ++a)
      if (!(p[a] >= kLo && p[a] <= hi_[a])) return false;
    return true;
  }

  // Moves index-space point p onto the box (per axis); true when it moved.
  // A NaN coordinate is left as it is (the callers test finiteness).
  bool clamp(double p[3]) const {
    bool moved = false;
    for (int a = 0; a < 3; ++a) {
      if (p[a] < kLo) {
        p[a] = kLo;
        moved = true;
      } else if (p[a] > hi_[a]) {
        p[a] = hi_[a];
        moved = true;
      }
    }
    return moved;
  }

 private:
  static constexpr double kLo = -0.5;
  double hi_[3];
};

// Moves world point w (mm) onto vol's grid box; true when it moved. A point
// inside keeps its bits.
inline bool clamp_to_grid(const VolumeView& vol, double w[3]) {
  double p[3];
  vol.world_to_index(w, p);
  if (!GridBox(vol.dims()).clamp(p)) return false;
  vol.index_to_world(p, w);
  return true;
}

// True when world point w (mm) lies in vol's grid box.
inline bool in_grid(const VolumeView& vol, const double w[3]) {
  double p[3];
  vol.world_to_index(w, p);
  return GridBox(vol.dims()).contains(p);
}

}  // namespace ffseg
