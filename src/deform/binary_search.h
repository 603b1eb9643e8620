// Correspondence search (thesis 4.2.2; METHOD.md section 2.1) for binary
// targets: walk each vertex's normal, outward when the vertex lies inside the
// object and inward when it lies outside, up to the search range, and return
// the first crossing of the object's surface (the 0.5 level of the trilinearly
// interpolated indicator) with sub-voxel precision. Beyond the grid is background.
#pragma once
#include <cstdint>

#include "bounding_region.h"
#include "volume.h"

namespace ffseg {

// The range the engine searches when params.search_range_mm is 0 (automatic):
// far enough for a sphere placed well inside an organ to reach its surface.
constexpr double kBinarySearchRangeMm = 80;

struct SearchSettings {
  double range_mm = kBinarySearchRangeMm;
  double step_mm = 0.5;
};

// Trilinear interpolation of the indicator (voxel != 0) at index-space point p.
double indicator_linear(const VolumeView& vol, const double p[3]);

// For every vertex: has[v] = 1 and target[3v..] = the crossing, or has[v] = 0
// (solitary). Returns the number of vertices with a target. With region
// (several objects, thesis 6.3; border then required): an outward ray that
// reaches a sample of another object's region stops at the sample before it,
// which is the target, and border[v] = 1 (else 0).
uint32_t search_binary(const VolumeView& vol, uint32_t nv, const double* x, const double* normals,
                       const SearchSettings& s, double* target, uint8_t* has, const RegionLimit* region = nullptr,
                       uint8_t* border = nullptr);

}  // namespace ffseg
