// Vertex normals of the cube-sphere: the cross product of the two contour
// tangents through the vertex (central differences of its four neighbours),
// signed so that it points outward on the initial sphere.
#pragma once
#include "cubesphere.h"

namespace ffseg {

// n: 3 * nv unit normals (a degenerate vertex gets the direction from the
// mesh centroid, or +z).
void vertex_normals(const CubeSphere& m, const double* x, double* n);

}  // namespace ffseg
