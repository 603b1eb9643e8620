// The cube-sphere quadrilateral mesh of thesis section 4.1 (METHOD.md section 1):
// one vertex at the centre of every cell of an n x n grid on each cube face,
// 6 n^2 vertices with exactly four neighbours, 3 groups of n closed contours of
// 4n vertices, 6 n^2 - 6 quads around grid corners plus 8 corner triangles.
#pragma once
#include <cstdint>

#include "arena.h"

namespace ffseg {

constexpr uint32_t kNone = 0xFFFFFFFFu;

struct CubeSphere {
  uint32_t n = 0;
  uint32_t nv = 0;      // 6 n^2
  uint32_t nfaces = 0;  // 6 n^2 + 2: quads, then triangles carry kNone as 4th index
  uint32_t nloops = 0;  // 3 n
  uint32_t loop_len = 0;  // 4 n

  // nbr[4v + 0..3]: neighbours of v along +t1, -t1, +t2, -t2 of its face.
  uint32_t* nbr = nullptr;
  // loops[l * loop_len + p]: vertex at position p of loop l, in cyclic order,
  // counter-clockwise seen from the positive end of the loop's axis.
  // Loop l = axis * n + level.
  uint32_t* loops = nullptr;
  // vloop[2v + 0..1]: the two loops through v; vpos: v's position in each.
  uint32_t* vloop = nullptr;
  uint32_t* vpos = nullptr;
  // faces[4f + 0..3], counter-clockwise seen from outside.
  uint32_t* faces = nullptr;
  // fadj[4f + e]: the face across edge e (faces[4f+e] -> faces[4f+e+1]) of f.
  uint32_t* fadj = nullptr;
  // vfaces[4v + 0..3]: the four faces around vertex v.
  uint32_t* vfaces = nullptr;
  // Unit-sphere positions (equal-angle warp), 3 per vertex.
  double* unit = nullptr;

  static constexpr uint32_t kMinN = 2;
  static constexpr uint32_t kMaxN = 1024;

  // Carves storage (measuring mode when the arena has no base).
  void carve(Arena& a, uint32_t n);
  // Fills everything; requires carve() on a real arena.
  void build();

  uint32_t triangle_count() const { return 2 * (nfaces - 8) + 8; }
  // Corners of face f: 4 for the quads, 3 for the eight corner triangles.
  int face_size(uint32_t f) const { return faces[4 * size_t(f) + 3] == kNone ? 3 : 4; }
  // First triangle of face f in triangulate()'s order (quads first, two each).
  uint32_t first_triangle(uint32_t f) const { return f < nfaces - 8 ? 2 * f : nfaces - 8 + f; }

  // Vertex index of the cell with integer cube coordinates P (see .cpp).
  uint32_t index_of(const int32_t P[3]) const;
  void coords_of(uint32_t v, int32_t P[3]) const;
};

}  // namespace ffseg
