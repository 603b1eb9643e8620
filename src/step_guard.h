// A guard on each step's motion: no triangle of the mesh may turn by 90
// degrees or more between the old and the new positions (an inverted or
// collapsed face is a flip in the making). Vertices of offending triangles have
// their motion halved, repeatedly, until every triangle passes; the old mesh
// passes trivially, so this always terminates with a flip-free update.
#pragma once
#include <cstdint>

#include "cubesphere.h"

namespace ffseg {

// x_old: current positions (3 per vertex); x_new: proposed positions as three
// columns of nv (x_new[c * nv + v]), shortened in place. mark: nv bytes of
// scratch. Returns the number of vertices whose motion was shortened.
uint32_t guard_step(const CubeSphere& m, const double* x_old, double* x_new, uint8_t* mark);

}  // namespace ffseg
