// Self-intersection check of the cube-sphere mesh at given positions, in
// workspace memory: every pair of triangles that share no edge is tested
// (pairs sharing one vertex: beyond that vertex) by segment-triangle crossings
// (an edge of one triangle passing through the other), candidates: pairs
// whose bounding boxes overlap (a hashed grid over the boxes, the few widest
// boxes querying it) and whose bounding spheres meet. Coplanar touching is not
// reported. The engine's guard refuses any step that would create one.
#pragma once
#include <cstdint>

#include "arena.h"
#include "cubesphere.h"
#include "patch_certificate.h"
#include "spatial_grid.h"

namespace ffseg {

struct TriangleScratch {
  uint32_t* tris = nullptr;   // 3 per triangle
  double* centroid = nullptr; // 3 per triangle
  double* radius = nullptr;   // per triangle: farthest vertex from the centroid
  double* normal = nullptr;   // 3 per triangle: (p1 - p0) x (p2 - p0)
  double* lo = nullptr;       // 3 per triangle: bounding box (widened a hair)
  double* hi = nullptr;
  // Per triangle: kOutside, too wide for the grid (then listed in big, at
  // most big_cap); kWide, too wide for the reference cells.
  uint8_t* is_big = nullptr;
  uint32_t* big = nullptr;
  uint32_t nbig = 0, big_cap = 0;
  BoxGrid grid;
  double eps = 0;             // the boxes' widening
  // The reference cell size of the last full check (1 / ref_inv_h): when
  // more than ref_cap boxes outgrow its cells, a tracked call starts afresh.
  // The grid's own cell size only sets the cost of finding the pairs.
  double ref_inv_h = 1;
  uint32_t ref_cap = 0;
  // mark_intersections_tracked: the crossing pairs (t < u) at the positions
  // of the last call, valid while tracked; touched: per triangle, scratch.
  uint32_t* pairs = nullptr;
  uint32_t npairs = 0, pair_cap = 0;
  bool tracked = false;
  // A recorded check the certificate decided leaves the grid to the first
  // tracked call after it (a guard call's first test is usually its last),
  // which lays it out for that check's boxes from these.
  bool layout_pending = false;
  double layout_emean = 0, layout_rmax = 0;
  uint8_t* touched = nullptr;
  // For the step guard: one byte per face, two per vertex.
  uint8_t* face_flags = nullptr;
  uint8_t* vertex_flags = nullptr;
  uint8_t* vertex_marks = nullptr;
  uint8_t* vertex_pending = nullptr;  // moved since the guard's last intersection test
  // For the step guard's fold test: per face, the normals of its triangles
  // (3 each, face_triangles() order) as split at the old positions and
  // computed there, and as split and computed at the tested positions, and
  // the two splits (1: the 1-3 diagonal).
  double* face_n_old = nullptr;
  double* face_n_new = nullptr;
  uint8_t* face_alt_old = nullptr;
  uint8_t* face_alt_new = nullptr;
  // The positions (3 per vertex) the face_*_new cache was left valid for by
  // the last guard_step(), when new_key_valid: the next step's old positions
  // are usually these, and then the cache is swapped in instead of computed.
  double* new_key = nullptr;
  bool new_key_valid = false;
  // Whether the guard's last test stopped before refreshing every face of
  // the face_*_new cache (then it holds no whole position set).
  bool face_new_partial = false;
  // The yes/no query (mark == nullptr) and the recorded check from scratch
  // (mark_intersections_tracked without moved) first try to certify the
  // mesh's local windows free of crossings (patch_certificate.h); the pairs
  // of the windows that fail are then the only ones to decide.
  PatchCertificate cert;
  void carve(Arena& a, const CubeSphere& m);
  // What depends on the mesh's topology only (the certificate's clusters,
  // windows and their boundary loops), once the mesh is built: an engine does
  // it at creation so that no step pays for it; a scratch used without it
  // builds it at its first yes/no query.
  void build_topology(const CubeSphere& m) { cert.build(m); }

  bool certificate_enabled() const { return use_certificate_; }
  void count_certified() { ++certified_calls_; }
  void count_reused_cache() { ++reused_old_cache_; }

 private:
  // Switches and counters for the tests (mesh_testing.h), which compare the
  // certified and the plain path and check that the guard's cache is used.
  friend struct TriangleScratchTesting;
  bool use_certificate_ = true;
  uint32_t certified_calls_ = 0;   // queries and recorded checks the certificate decided
  uint32_t reused_old_cache_ = 0;  // guard steps that swapped the cache in
};

// Marks (mark[v] = 1, when mark is not nullptr) the vertices of every
// intersecting pair at positions x (3 per vertex) and returns the number of
// pairs (stops at the first when mark is nullptr).
// alt (optional): per face, its split at x as face_triangles() gives it
// (1: the 1-3 diagonal), when the caller has it.
uint32_t mark_intersections(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark,
                            const uint8_t* alt = nullptr);

// The same with mark required and the pairs kept in s: when moved is given
// and the previous call was tracked too, positions x may differ from that
// call's only at the vertices with moved[v] != 0, and only the triangles
// around them are tested again (when they are more than an eighth of the
// mesh's, all of them, from scratch). Marks and count equal mark_intersections'.
// Any mark_intersections() call in between ends the tracking.
uint32_t mark_intersections_tracked(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark,
                                    const uint8_t* moved, const uint8_t* alt = nullptr);

}  // namespace ffseg
