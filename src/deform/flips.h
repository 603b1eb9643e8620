// Flip detection (thesis 4.2.3, eq. 4.2.1) and flip avoidance (4.2.4) on the
// closed contours: an edge between consecutive non-solitary vertices u_i, u_j
// flips when unit(u_i - u_j) . unit(v_i - v_j) <= tau; in every maximal run of
// flipping vertices along a contour only the middle one keeps its target.
#pragma once
#include <cstdint>

#include "cubesphere.h"

namespace ffseg {

// flipping[v] = 1 when v forms a flipping edge on either of its contours.
// Returns the number of flipping vertices.
uint32_t detect_flips(const CubeSphere& m, const double* x, const double* target, const uint8_t* has,
                      double tau, uint8_t* flipping);

// Makes all but the middle vertex of every run solitary (has = 0). scratch
// holds m.loop_len entries. Returns the number of vertices made solitary.
uint32_t avoid_flips(const CubeSphere& m, const uint8_t* flipping, uint8_t* has, uint32_t* scratch);

}  // namespace ffseg
