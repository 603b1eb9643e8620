// ffseg tools: whether two grids hold the same voxel centres, whatever order
// each stores them in, and the other grid's voxels brought into the
// reference's order.
//
// A label map converted between LPS and RAS storage, or written slice-major by
// another tool, holds the same voxel centres as the scan it was drawn on with
// its axes permuted or reversed. Such a map is re-indexed exactly (a voxel
// copied, never interpolated). Two grids match when some permutation and
// reversal of the other grid's axes puts every voxel centre within
// kCentreTolerance voxels (of the reference's smallest spacing) of the
// reference's centre of the same index; the eight corner voxels are checked,
// which bounds every voxel since both maps are affine.
#ifndef FFSEG_TOOLS_GRID_MATCH_H
#define FFSEG_TOOLS_GRID_MATCH_H

#include <cstddef>
#include <string>

#include "nifti.h"

namespace ffseg_tools {

constexpr double kCentreTolerance = 0.01;  // voxels

// Reference axis a is the other grid's axis `axis[a]`, reversed when
// reversed[a] (index n - 1 - i).
struct AxisMap {
    int axis[3] = {0, 1, 2};
    bool reversed[3] = {false, false, false};
    bool identity() const;
};

// true and *m when `other` holds ref's voxel centres; false and *why naming
// what differs (the dimensions, or how far the nearest order's centres are
// apart and where).
bool match_voxel_centres(const NiftiImage& ref, const NiftiImage& other, AxisMap* m, std::string* why);

// `other`'s voxels in ref's order and with ref's geometry (the type, rescale
// and description of `other`).
NiftiImage reindex_to(const NiftiImage& ref, const NiftiImage& other, const AxisMap& m);

// For grids that differ: each ref voxel takes the value of the other grid's
// voxel nearest its centre in world space (stored 0 beyond the other grid);
// *outside counts those.
NiftiImage resample_nearest(const NiftiImage& ref, const NiftiImage& other, size_t* outside);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_GRID_MATCH_H
