// Contact between closed cube-sphere meshes, in workspace memory: the hard
// no-overlap guarantee of several objects (thesis chapter 6 keeps organs
// apart by their bounding regions; ffseg makes it certain). Two meshes are
// in contact when a triangle of one crosses a triangle of the other (an
// edge of one through the other's interior, the self-intersection test's
// rule, mesh_intersection.h) or when one encloses the other (no crossing,
// but a vertex of one inside the other's closed surface, by ray parity).
//
// The obstacles (the other objects, fixed while one object's step is
// guarded) are entered once into a hashed grid over their triangle boxes;
// each query then costs O(vertices) when the query mesh's bounding box
// meets no obstacle's, and otherwise grows with the triangles where the
// boxes overlap. All meshes share one CubeSphere topology (one n).
#pragma once
#include <cstdint>

#include "arena.h"
#include "cubesphere.h"
#include "spatial_grid.h"

namespace ffseg {

// An obstacle's face splits as its caller holds them: alt[f] is face f's
// split at positions key (3 per vertex) as face_triangles() gives it (1:
// the 1-3 diagonal). alt nullptr: none held.
struct ObstacleSplits {
  const uint8_t* alt = nullptr;
  const double* key = nullptr;
};

struct ContactScratch {
  uint32_t max_obstacles = 0, count = 0;
  uint32_t nt = 0;                    // triangles per mesh
  const double** pos = nullptr;       // per obstacle: its positions (the caller's, 3 per vertex)
  ObstacleSplits* splits = nullptr;   // per obstacle: the caller's splits of it (alt nullptr: none)
  double* box = nullptr;              // per obstacle: lo[3], hi[3] of its vertices, widened by eps
  // Per obstacle: kActive (its box meets the region: its faces there are
  // set up and in the grid), kComplete (every face set up, for the ray test).
  static constexpr uint8_t kActive = 1, kComplete = 2;
  uint8_t* state = nullptr;
  uint8_t* fdone = nullptr;           // per obstacle and face: split and boxed
  // The obstacle triangles build_obstacles() set up, in ascending id order
  // (its scratch: the grids' builds walk these instead of every id).
  uint32_t* entered = nullptr;
  uint32_t nentered = 0;
  // Obstacle triangles, id k * nt + t: vertex indices (3 each, within
  // obstacle k, face_triangles() split at its positions) and boxes, valid
  // where fdone is set for the triangle's face.
  uint32_t* tris = nullptr;
  double* lo = nullptr;
  double* hi = nullptr;
  uint32_t* big = nullptr;            // triangles too wide for the grid's cells
  uint32_t nbig = 0, big_cap = 0;
  BoxGrid grid;
  // The big triangles in a grid of their own, its cells as wide as the
  // widest (big_fit: every one entered; else they are scanned).
  BoxGrid big_grid;
  bool big_fit = false;
  double eps = 0;                     // the boxes' widening against rounding
  // The query mesh: its triangles (3 each), boxes, and which of them are
  // set (per face, 1 when its triangles were split and boxed this query).
  uint32_t* qtris = nullptr;
  double* qlo = nullptr;
  double* qhi = nullptr;
  uint8_t* qface = nullptr;
  uint8_t* qcode = nullptr;           // per vertex: outcodes against a box (scratch)
  uint8_t* crossed = nullptr;         // per obstacle, this query
  double* zone = nullptr;             // per obstacle met, this query: its box's overlap with the query's (6)
  // mark_contacts_tracked(): the crossing pairs (query triangle, obstacle
  // triangle) at the positions of the last call, valid while tracked; then
  // qtris, qlo and qhi also hold every face that qface marks, as split and
  // boxed at those positions.
  uint32_t* pairs = nullptr;
  uint32_t npairs = 0, pair_cap = 0;
  bool tracked = false;
  // sweep_obstacles(): per face of the query mesh, 1 when some position set
  // of the sweep may bring one of its triangles' boxes onto an obstacle
  // triangle's (only these are tested while swept).
  uint8_t* reach = nullptr;
  bool swept = false;
  void carve(Arena& a, const CubeSphere& m, uint32_t max_obstacles);
};

// The obstacles: the closed meshes at positions xs[k] (3 per vertex each),
// k < count <= max_obstacles. Their positions are read again by every
// mark_contacts() call and must stay unchanged until the last.
// region (optional; lo[3] then hi[3]): a box holding every position set that
// will be queried (for the step guard: guard_region(), the boxes of the old
// and the proposed positions together); a query outside it may miss
// contacts. Obstacles whose box misses it cost one pass over their
// vertices, and only their faces meeting it enter the grid.
// splits (optional, one per obstacle; read until the last query, as xs): a
// face of obstacle k whose corners are those of splits[k].key bit for bit
// takes its split from splits[k].alt instead of deciding it again: the same
// function of the same bits, so the same triangles. Each object's step guard
// keeps its splits at the positions it accepted, and the object then
// stands as an obstacle to every other one. Faces are compared, not whole
// meshes: a query's region meets a few of an obstacle's faces.
void build_obstacles(const CubeSphere& m, const double* const* xs, uint32_t count, ContactScratch& s,
                     const double* region = nullptr, const ObstacleSplits* splits = nullptr);

// Declares that until the next build_obstacles() every position set queried
// has each vertex v on the segment from a to b (up to the rounding of a
// blend between them): a holds 3 values per vertex, b three columns of nv
// (b[c * nv + v], the step guard's layout). The queries then skip the faces
// whose boxes over the whole sweep miss every obstacle triangle's: a crossing
// point lies in both triangles' boxes, so these faces can cross nothing, and
// counts, marks and pairs stay those of the queries without it. The guard
// tests one update at many scales, and most of the faces it moves are far
// from every neighbour.
void sweep_obstacles(const CubeSphere& m, const double* a, const double* b, ContactScratch& s);

// Contacts of the mesh at positions x (3 per vertex) with the obstacles:
// every crossing pair (a triangle of x, a triangle of an obstacle) counts
// one, and an obstacle that x lies inside of or encloses without any
// crossing counts one. mark (nv bytes, may be nullptr: then it stops at the
// first offence) gets 1 at the vertices of x that take part: the vertices
// of x's crossing triangles; every vertex of x when x lies inside an
// obstacle or encloses one. Returns the number of offences. Touching
// (coplanar contact, a vertex on the other surface) is not an offence.
// alt (optional): per face, its split at x as face_triangles() gives it
// (1: the 1-3 diagonal), when the caller has it.
uint32_t mark_contacts(const CubeSphere& m, const double* x, ContactScratch& s, uint8_t* mark,
                       const uint8_t* alt = nullptr);

// The same with mark required and the crossing pairs kept in s: when moved
// is given and the previous call was tracked too (with the same obstacles),
// positions x may differ from that call's only at the vertices with
// moved[v] != 0, and only the triangles around them are tested again. Marks
// and count equal mark_contacts'. Any mark_contacts() or build_obstacles()
// call in between ends the tracking.
uint32_t mark_contacts_tracked(const CubeSphere& m, const double* x, ContactScratch& s, uint8_t* mark,
                               const uint8_t* moved, const uint8_t* alt = nullptr);

}  // namespace ffseg
