// ffseg tools: a closed triangle mesh cut by the slice planes of a grid.
//
// Each plane is the one through the voxel centres of slice k (normal: the
// grid's i axis x j axis). A vertex on the plane counts as above it, so every
// triangle the plane crosses is cut along exactly two of its edges, and on a
// closed mesh the cut segments join, edge to edge, into closed polygons: one
// per piece of the object in that slice, holes as polygons of their own. The
// points are exact edge-plane intersections (sub-voxel), in world mm (RAS).
#ifndef FFSEG_TOOLS_SLICE_CONTOURS_H
#define FFSEG_TOOLS_SLICE_CONTOURS_H

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "nifti.h"

namespace ffseg_tools {

using Polygon = std::vector<std::array<double, 3>>;  // closed: the last point joins the first

struct SliceContour {
    int slice;  // k
    Polygon points;
};

// The polygons where the plane n . x = d cuts the mesh (xyz: nv x 3 floats,
// tris: nt x 3 indices). false with *err when an edge the plane crosses does
// not belong to exactly two triangles (the mesh is not closed).
bool plane_contours(const float* xyz, size_t nv, const uint32_t* tris, size_t nt, const double n[3], double d,
                    std::vector<Polygon>* out, std::string* err);

// Every slice of `grid` that cuts the mesh, slices in k order.
bool grid_slice_contours(const float* xyz, size_t nv, const uint32_t* tris, size_t nt, const NiftiImage& grid,
                         std::vector<SliceContour>* out, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_SLICE_CONTOURS_H
