// Geometric validity checks for triangle meshes (test support code).
//
// Input convention for every function: `xyz` holds 3 floats per vertex (mm),
// `nv` vertices; `tris` holds 3 vertex indices per triangle, `nt` triangles.
// Everything is computed in double precision. Triangles with an index >= nv
// make is_closed_oriented_manifold() return false and are skipped by the other
// checks (count_self_intersections() throws std::out_of_range for them).
#pragma once
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace ffseg_test {

struct SelfIntersectionReport {
  // Pairs of triangles with no common vertex index that intersect (closed
  // sets: touching counts; coplanar overlaps count). This is the number
  // count_self_intersections() returns.
  std::size_t disjoint_pairs = 0;
  // Pairs sharing exactly one vertex index whose intersection is more than
  // that vertex (a segment or, if coplanar, an area). Coplanar pairs whose
  // wedges at the shared vertex merely touch along a ray are NOT counted.
  std::size_t shared_vertex_pairs = 0;
  // Triangles with (numerically) zero area, a repeated index or a non-finite
  // coordinate; they are skipped by the pair test (a zero-area triangle is
  // never reported as intersecting anything).
  std::size_t degenerate_triangles = 0;
  // Bounding-box-overlapping pairs that went through an exact pair test
  // (diagnostic: shows that the grid keeps the work near-linear).
  std::size_t candidate_pairs = 0;
  // The first `max_pairs` offending pairs of either kind (lower index first),
  // in discovery order.
  std::vector<std::pair<uint32_t, uint32_t>> first_pairs;
};

// Full self-intersection report. Pairs sharing two or three vertex indices
// (edge neighbours, duplicated faces) are not tested. Accelerated by a uniform
// grid over the triangle bounding boxes.
SelfIntersectionReport check_self_intersections(const float* xyz, std::size_t nv,
                                                const uint32_t* tris, std::size_t nt,
                                                std::size_t max_pairs = 16);

// Crossing triangle pairs between two closed meshes a and b (each its own
// vertex numbering): the two as one soup, less what each has on its own.
std::size_t crossings_between(const std::vector<float>& xa, const std::vector<uint32_t>& ta,
                              const std::vector<float>& xb, const std::vector<uint32_t>& tb);

// Number of pairs of triangles that share no vertex and intersect
// (= check_self_intersections().disjoint_pairs). If `first_pairs` is non-null
// it receives up to `max_pairs` offending pairs (both kinds, see above).
std::size_t count_self_intersections(const float* xyz, std::size_t nv,
                                     const uint32_t* tris, std::size_t nt,
                                     std::vector<std::pair<uint32_t, uint32_t>>* first_pairs = nullptr,
                                     std::size_t max_pairs = 16);

// Every directed edge occurs exactly once and its reverse occurs exactly once,
// i.e. every edge is used by exactly two triangles in opposite directions.
// False for an empty mesh, a triangle with a repeated index or an index >= nv.
// (Edge-manifoldness only; pinched vertices are not detected.)
bool is_closed_oriented_manifold(const float* xyz, std::size_t nv,
                                 const uint32_t* tris, std::size_t nt);

// Number of edges shared by exactly two triangles whose unit normals have a
// dot product < cos_limit (e.g. -0.5). Edges used by one or by more than two
// triangles are ignored. Degenerate (zero-area, relative 1e-12) triangles are
// not used for any edge; their number goes to *degenerate if non-null.
std::size_t count_normal_flips(const float* xyz, std::size_t nv,
                               const uint32_t* tris, std::size_t nt,
                               double cos_limit, std::size_t* degenerate = nullptr);

// Signed enclosed volume (mm^3) by the divergence theorem: positive for a
// closed mesh with outward (counter-clockwise seen from outside) winding.
double enclosed_volume(const float* xyz, std::size_t nv,
                       const uint32_t* tris, std::size_t nt);

// Total triangle area (mm^2).
double surface_area(const float* xyz, std::size_t nv,
                    const uint32_t* tris, std::size_t nt);

}  // namespace ffseg_test
