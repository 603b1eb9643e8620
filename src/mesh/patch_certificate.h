// Certified patches for the guard's yes/no self-intersection query (the hot
// path of a step: is the tried update free of crossings?).
//
// The faces are grouped into clusters: blocks of block x block grid corners
// of a cube face, each face going to the block of the grid corner it
// surrounds (corners on cube edges to the face of the lowest axis). Blocks of
// corners, not of first vertices, keep every window's boundary straight
// (unfolded across cube edges), so that it projects star-shaped; by first
// vertex the boundaries were staircases and more than an eighth of a smooth
// sphere's windows (n = 33) failed the star test. The window of a cluster C
// is the union of the clusters owning a face that shares a vertex with a
// face of C, fixed per mesh; where the window is a topological disk (one
// boundary loop, Euler characteristic 1: checked at build) its boundary loop
// is stored.
//
// Certificate (why a window that passes has no crossing pair). Project the
// window along a direction w (the mean normal): p -> (p.u, p.v) with
// w = u x v. If every triangle of the window projects with positive
// orientation (n_t . w > 0) and the projected boundary loop is a simple
// closed curve, then every point of the plane off the projected edges has as
// many preimages as the loop's winding number around it (the degree of the
// piecewise linear map, every triangle counting +1), so 1 or 0: no two
// triangles' projections overlap in an open set. A crossing as
// mark_intersections() defines it (an open edge of one triangle through the
// interior of another that shares no edge with it) would make the two
// projections overlap near the crossing point, so the window has none. The
// loop is shown simple by being strictly star-shaped around the mean of its
// projected vertices: every edge turns counter-clockwise around it, by more
// than a rounding margin, and the loop winds once. Both tests keep margins
// far above the rounding of the computed projection (see the .cpp).
//
// Coverage: a pair of triangles of clusters C and C' is inside C's window
// when C' is one of C's window clusters (its neighbours); every other pair of
// clusters is reported by for_each_far_pair() when their bounding boxes
// overlap, for the caller's exact test. Windows that do not pass are listed
// (failed) for the caller to test their cluster's triangles against the whole
// window exactly. All memory comes from the arena.
#pragma once
#include <cstdint>

#include "arena.h"
#include "cubesphere.h"

namespace ffseg {

struct PatchCertificate {
  static constexpr uint32_t kMaxNeighbours = 24;  // window clusters per cluster, C included
  // Cluster size (block x block grid corners) and the caller's limit on
  // failed windows (ncl / fail_share), from the mesh resolution (carve):
  // 2 and 1 (no limit) up to n = kSmallMesh, else 4 and 8. At n = 12, blocks
  // of 4 make windows of a whole cube face that never project one to one on
  // a deformed mesh (at least 10 of 74 failed on Colin27 structures: no
  // answer); blocks of 2 let 62-90 of 254 fail and answer 2.6-3.6x faster
  // than the grid. From n = 49 the larger blocks are faster (bench_step).
  // With blocks of 2 even a mesh with more than half its windows failed is
  // answered faster than by the grid (the nine abdominal organs at n = 22,
  // whose guard met such meshes in 271 of 984 tests from scratch: their
  // stepping about 4% faster against the factor stage without the limit of
  // ncl / 2; the cup of bench_step unchanged).
  static constexpr uint32_t kSmallMesh = 40;
  uint32_t block = 4;
  uint32_t fail_share = 8;

  uint32_t ncl = 0;
  uint32_t* face_cluster = nullptr;  // per face
  uint32_t* cl_ptr = nullptr;        // ncl + 1: faces of cluster c are cl_faces[cl_ptr[c] .. cl_ptr[c+1])
  uint32_t* cl_faces = nullptr;      // nfaces
  uint32_t* tri_ptr = nullptr;       // ncl + 1: triangles of cluster c are cl_tris[tri_ptr[c] .. tri_ptr[c+1])
  uint32_t* cl_tris = nullptr;       // triangle count, in cluster order
  // Per call, cluster order: 3 per triangle, its normal. Once certify() has
  // tested the windows (nothing reads the normals after), the cluster boxes
  // in order's order, 6 each, for the far pairs' sweep to read one after the
  // other (valid after a certify() that passed; room for both is carved).
  double* tn = nullptr;
  double* tmargin = nullptr;         // per call, cluster order: the orientation margin of the triangle
  // Per call, cluster order: the triangles' boxes (lo, hi as passed to
  // certify()), one array per bound: pbox[a * ntri + k] the lo of axis a,
  // pbox[(3 + a) * ntri + k] the hi, for the callers' pair filters.
  double* pbox = nullptr;
  uint32_t ntri = 0;
  uint32_t* nb_cnt = nullptr;        // per cluster: window clusters (C first), at most kMaxNeighbours
  uint32_t* nb = nullptr;            // kMaxNeighbours per cluster
  uint32_t* loop_ptr = nullptr;      // ncl + 1; an empty loop: the window cannot be certified
  uint32_t* loop = nullptr;          // boundary loops, counter-clockwise seen from outside
  uint32_t loop_cap = 0;
  // Per call.
  double* box = nullptr;     // 6 per cluster: lo xyz, hi xyz
  double* nsum = nullptr;    // 3 per cluster: sum of its triangles' normals
  uint32_t* order = nullptr; // clusters by box lo x (kept between calls: ties stay in their order)
  uint32_t* failed = nullptr;
  uint32_t nfailed = 0;
  uint8_t* is_failed = nullptr;  // per cluster, per call: its window is in failed

  // Build scratch.
  uint8_t* face_mark = nullptr;
  uint8_t* vert_mark = nullptr;
  uint32_t* next = nullptr;
  bool built = false;

  void carve(Arena& a, const CubeSphere& m);
  void build(const CubeSphere& m);

  // normals: 3 per triangle ((p1 - p0) x (p2 - p0) of the faces' splits),
  // lo/hi: 3 per triangle (exact boxes), triangles in triangulate()'s order. Computes the cluster boxes and tests
  // every window; failed/nfailed list the clusters whose window did not pass.
  // Returns false (nothing decided) when more than max_failed windows fail.
  bool certify(const double* x, const double* normals,
               const double* lo, const double* hi, uint32_t max_failed);

  // Whether d is in c's window: every slot compared, without branches (the
  // unused ones hold kNone), as the far pairs ask it of most overlapping
  // cluster pairs.
  bool neighbours(uint32_t c, uint32_t d) const {
    const uint32_t* p = nb + size_t(kMaxNeighbours) * c;
    uint32_t hit = 0;
    for (uint32_t i = 0; i < kMaxNeighbours; ++i) hit |= uint32_t(p[i] == d);
    return hit != 0;
  }

  // Every pair of clusters (c, d), neither in the other's window, whose boxes
  // overlap; f(c, d) returns true to stop (then so does this, with true).
  // The boxes are sorted by lo x: the clusters after i whose box starts
  // within i's in x run up to the first that starts beyond it (found by
  // bisection); among them, the ones overlapping in y and z are listed
  // without branches (a coin toss each, most of them no), in order.
  template <class F>
  bool for_each_far_pair(F&& f) {
    constexpr uint32_t kChunk = 64;
    uint32_t cand[kChunk];
    for (uint32_t i = 0; i < ncl; ++i) {
      const double* bc = tn + 6 * size_t(i);
      const double hx = bc[3], ly = bc[1], hy = bc[4], lz = bc[2], hz = bc[5];
      uint32_t lo = i + 1, hi = ncl;  // the first j >= lo with lo x beyond hx
      while (lo < hi) {
        const uint32_t mid = lo + (hi - lo) / 2;
        if (tn[6 * size_t(mid)] > hx) hi = mid; else lo = mid + 1;
      }
      for (uint32_t j0 = i + 1; j0 < lo; j0 += kChunk) {
        const uint32_t j1 = lo - j0 < kChunk ? lo : j0 + kChunk;
        uint32_t n = 0;
        for (uint32_t j = j0; j < j1; ++j) {
          const double* bd = tn + 6 * size_t(j);
          cand[n] = j;
          n += uint32_t(!((bd[1] > hy) | (ly > bd[4]) | (bd[2] > hz) | (lz > bd[5])));
        }
        for (uint32_t k = 0; k < n; ++k) {
          const uint32_t c = order[i], d = order[cand[k]];
          if (neighbours(c, d) || neighbours(d, c)) continue;
          if (f(c, d)) return true;
        }
      }
    }
    return false;
  }
};

}  // namespace ffseg
