// Non-flipping self-intersection handling (thesis 4.2.4, fig. 4.7): for each
// vertex u_i with displacement d_i, any other vertex u_j or target v_j within
// |d_i| whose displacement disagrees in direction (the tau test of eq. 4.2.1)
// signals a fold; both displacements are halved, repeatedly, until no such pair
// remains (or a pass budget is spent).
#pragma once
#include <cstdint>

#include "cubesphere.h"
#include "direction_cones.h"
#include "spatial_grid.h"

namespace ffseg {

struct IntersectionScratch {
  SpatialGrid grid;      // over 2 * nv points
  double* pts = nullptr; // 6 * nv: vertices, then targets
  uint8_t* mark = nullptr;
  double* len = nullptr;  // nv: |d_v| this pass (each ball's partners read it)
  DirectionCones cones;   // over grid's buckets
  SpatialGrid moved;      // over nv points: the targets moved by the passes after the first
  void carve(Arena& a, uint32_t nv);
};

// d: 3 * nv displacements, valid where has[v]; this step moves each vertex by
// alpha d, so the search radius is alpha |d_i| (the thesis' D for the step
// actually taken). Returns the number of vertices whose displacement was
// shortened.
uint32_t prevent_folds(const CubeSphere& m, const double* x, double* d, const uint8_t* has, double tau,
                       double alpha, IntersectionScratch& s);

}  // namespace ffseg
