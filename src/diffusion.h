// Diffusion of displacement vectors (thesis eq. 4.2.2 / 5.3.3): each round
// replaces a vertex's displacement by the mean over itself and its four
// neighbours among those that have one; solitary vertices next to vertices
// with displacements receive one. Smooths noise and fills gaps left by flip
// avoidance.
#pragma once
#include <cstdint>

#include "cubesphere.h"

namespace ffseg {

// d: 3 * nv displacements, valid where has[v]; tmp: 3 * nv, tmp_has: nv.
void diffuse_displacements(const CubeSphere& m, uint32_t rounds, double* d, uint8_t* has, double* tmp,
                           uint8_t* tmp_has);

}  // namespace ffseg
