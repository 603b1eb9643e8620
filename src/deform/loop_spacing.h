// Even spacing along the contour loops (thesis 4.1's loops; the aim of the
// uniform-distribution term of 4.2.5, issue 29): every loop's vertices are
// moved along the loop's own polyline towards equal arc lengths.
//
// Why: the cube-sphere has a fixed number of vertices, and a mesh that grows
// from a sphere into a tube or horn must bring vertices into it. The solve
// moves each vertex towards its target along its normal, so a front that
// enters a narrow passage is carried by the few vertices whose normals point
// into it: a spike one meridian wide whose tip normal tilts into the wall,
// with its target a millimetre or two ahead (BENCHMARKS.md section 12: a
// quarter torus 8 mm across reached 8% of its length, a C-shaped horn 35%).
// The uniform term of the solve draws long loop edges in (a tension only: as
// a compression it buckles, laplacian_system.cpp); it shortens the stretched
// front as much as it feeds it. Moving vertices along the polyline instead changes
// where they sit on the surface the solve produced, not its shape: no
// compression to buckle, and a stretched loop draws vertices from where
// they are dense into the passage.
//
// Each loop in turn (a vertex lies on two loops, Gauss-Seidel), the vertex at
// arc length s_q moves to s_q + f (s*_q - s_q) along the closed polyline,
// s*_q = o + q T / L equally spaced (T the loop's length, L its vertex count)
// and o the offset that keeps the mean arc length of the loop's vertices
// where it is, so that an evenly spaced loop does not rotate. The arc
// lengths of the blend stay in loop order: no vertex overtakes another.
// Positions on a chord lie a little inside a curved surface (at most the
// sagitta of one edge); the next search corrects it.
#pragma once
#include <cstdint>

#include "cubesphere.h"

namespace ffseg {

// The fraction f of the way to even spacing per step. Chosen on the tube and
// horn phantoms of scripts/tube_phantom.py (binary, 1 mm, 200 steps): f = 0.1,
// 0.25, 0.5, 1 gave the horn Dice 0.960, 0.951, 0.941, 0.586 and the tube a
// reach of 54%, 61%, 64%, 44%; at 1 the loops of the two families pull each
// vertex back and forth.
constexpr double kLoopRespacing = 0.25;

// Scratch doubles respace_loops() needs for mesh m.
inline uint64_t loop_spacing_scratch(const CubeSphere& m) { return 7 * uint64_t(m.loop_len) + 4; }

// x: positions as three columns of nv (x[c * nv + v]), moved in place;
// fraction in (0, 1]; scratch: loop_spacing_scratch(m) doubles. A loop of
// zero or non-finite length is left as it is.
void respace_loops(const CubeSphere& m, double* x, double fraction, double* scratch);

}  // namespace ffseg
