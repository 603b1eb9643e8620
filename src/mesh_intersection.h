// Self-intersection check of the cube-sphere mesh at given positions, in
// workspace memory: every pair of triangles that share no edge is tested
// (pairs sharing one vertex: beyond that vertex) by segment-triangle crossings
// (an edge of one triangle passing through the other), candidates from a
// hashed grid over the triangles' centroids. Coplanar touching is not
// reported. The engine's guard refuses any step that would create one.
#pragma once
#include <cstdint>

#include "arena.h"
#include "cubesphere.h"
#include "spatial_grid.h"

namespace ffseg {

struct TriangleScratch {
  uint32_t* tris = nullptr;   // 3 per triangle
  double* centroid = nullptr; // 3 per triangle
  double* radius = nullptr;   // per triangle: farthest vertex from the centroid
  SpatialGrid grid;
  void carve(Arena& a, const CubeSphere& m);
};

// Marks (mark[v] = 1, when mark is not nullptr) the vertices of every
// intersecting pair at positions x (3 per vertex) and returns the number of
// pairs (stops at the first when mark is nullptr).
uint32_t mark_intersections(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark);

}  // namespace ffseg
