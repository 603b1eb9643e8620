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
//
// The clamp puts a point a hair inside the face (kInset of a voxel: 3 nm on
// a 3 mm grid), not on it. Exactly on the face, whether the point lies in
// the grid is decided by the last bit of each later world -> index map (the
// searches' inside tests, nearest-voxel sampling rounding -0.5 or n - 0.5),
// and that bit depends on how the affine was written: the same CT read from
// its DICOM series (decimal origin and spacings, 1e-10 off the NIfTI's)
// sent the cut liver's face vertices to the other side of those tests and
// its label map differed from the NIfTI run's in 81 voxels. kInset is ten
// orders of magnitude above those roundings and far below anything the
// image resolves; the box stays symmetric, the same arithmetic at both ends
// of every axis, so a flipped or permuted storage order clamps alike.
#pragma once
#include <cstdint>

#include "volume.h"

namespace ffseg {

class GridBox {
 public:
  explicit GridBox(const int64_t dims[3]) {
    for (int a = 0; a < 3; ++a) hi_[a] = double(dims[a]) - 0.5;
  }

  // Where clamp() puts a point beyond a face: this share of a voxel inside it.
  static constexpr double kInset = 1e-6;

  bool contains(const double p[3]) const {
    for (int a = 0; a < 3; ++a)
      if (!(p[a] >= kLo && p[a] <= hi_[a])) return false;
    return true;
  }

  // True when index-space point p lies within kFaceTolerance of a face of
  // the box or beyond it: where a search that ran out of the grid put its
  // target (its bisection ends within step / 256, 0.002 voxel by default,
  // of the face).
  static constexpr double kFaceTolerance = 0.01;
  bool at_face(const double p[3]) const {
    for (int a = 0; a < 3; ++a)
      if (!(p[a] > kLo + kFaceTolerance && p[a] < hi_[a] - kFaceTolerance)) return true;
    return false;
  }

  // Moves index-space point p into the box, kInset inside each face it lay
  // beyond or within kInset of (per axis); true when it moved. A NaN
  // coordinate is left as it is (the callers test finiteness).
  bool clamp(double p[3]) const {
    bool moved = false;
    for (int a = 0; a < 3; ++a) {
      const double lo = kLo + kInset, hi = hi_[a] - kInset;
      if (p[a] < lo) {
        p[a] = lo;
        moved = true;
      } else if (p[a] > hi) {
        p[a] = hi;
        moved = true;
      }
    }
    return moved;
  }

 private:
  static constexpr double kLo = -0.5;
  double hi_[3];
};

// Moves world point w (mm) into vol's grid box (GridBox::clamp); true when it
// moved. A point inside, kInset clear of the faces, keeps its bits.
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
