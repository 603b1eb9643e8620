// A guard on each step's motion: no triangle of the mesh may turn by 90
// degrees or more between the old and the new positions (an inverted or
// collapsed face is a flip in the making), and no edge may become a fold
// (adjacent triangles at more than 120 degrees), no triangle may cross
// another, nor, when obstacles are given, another object's. The whole update
// is scaled back by halves, then locally, until the mesh passes; the old
// mesh passes trivially.
#pragma once
#include <cstdint>

#include "arena.h"
#include "cubesphere.h"
#include "mesh_contact.h"
#include "mesh_intersection.h"

namespace ffseg {

// One object's fold-test splits and normals (the guard's cache, see
// TriangleScratch::face_n_new) at the positions its last guarded step
// accepted (key), while valid. Objects that share one TriangleScratch take
// turns in it, so each keeps its own here: its next step starts from these
// positions and finds their splits and normals ready.
struct GuardCache {
  double* n = nullptr;     // 6 per face
  uint8_t* alt = nullptr;  // per face
  double* key = nullptr;   // 3 per vertex
  bool valid = false;
  // What failed the last step's line search (a fold test's face, or the
  // contacts after a passing fold test): its next step's line search asks
  // it first. Only the order of the tests hangs on it.
  uint32_t offence_face = kNone;
  bool offence_contact = false;
  void carve(Arena& a, const CubeSphere& m);
};

// x_old: current positions (3 per vertex); x_new: proposed positions as three
// columns of nv (x_new[c * nv + v]), scaled back in place towards x_old;
// xs: 3 * nv scratch; share (nv doubles), mark and grow (nv bytes) are scratch; ts also carries
// the local rounds' incremental state (each round re-tests only the faces and
// triangles around the vertices whose share changed). Returns the mean share
// of the update kept (1 when nothing turned, folded or crossed); share then
// holds each vertex's.
// obstacles (optional): the other objects, built by build_obstacles(); then
// every position set the guard tests must also be free of contacts with
// them (mark_contacts()), the vertices in contact held back as the
// offenders of a fold or crossing are. x_old must be free of contacts (the
// guard falls back to it). Without obstacles the result is bit for bit that
// of the guard alone.
// keep (optional): the object's own cache, read when x_old is its key and
// left for the next step (instead of ts's); the result is the same.
double guard_step(const CubeSphere& m, const double* x_old, double* x_new, double* xs, double* share,
                  uint8_t* mark, uint8_t* grow, TriangleScratch& ts, ContactScratch* obstacles = nullptr,
                  GuardCache* keep = nullptr);

// The box (lo[3], hi[3]) holding every position set guard_step() can test
// for x_old and x_new (laid out as guard_step() takes them): the region to
// build its obstacles for (build_obstacles()).
void guard_region(const CubeSphere& m, const double* x_old, const double* x_new, double region[6]);

// The same test at positions xs (3 per vertex): sets mark[v] = 1 for the
// vertices of every triangle that turned by 90 degrees or more and of every
// face at a new fold; returns how many offences (mark may be nullptr).
uint32_t mark_violations(const CubeSphere& m, const double* x_old, const double* xs, uint8_t* mark);

}  // namespace ffseg
