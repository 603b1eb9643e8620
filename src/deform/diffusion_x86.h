// The displacement diffusion's x86 kernel (diffusion_x86.cpp), declared where
// it is built (x86 with SSE2, not FFSEG_PORTABLE).
#pragma once
#include <cstdint>

#include "cpu_x86.h"
#if FFSEG_X86 && defined(__SSE2__)

namespace ffseg {

// One round of the plain 5-point mean over a fully displaced mesh (src ->
// dst, 3 doubles per vertex; nbr: 4 neighbours per vertex) for the vertex
// pairs from 0 on, with the scalar loop's additions in its order; returns the
// first vertex left for that loop.
uint32_t diffuse_round_sse2(uint32_t nv, const uint32_t* nbr, const double* src, double* dst);

}  // namespace ffseg
#endif
