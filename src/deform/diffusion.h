// Diffusion of displacement vectors (thesis eq. 4.2.2 / 5.3.3): each round
// replaces a vertex's displacement by the mean over itself and its four
// neighbours among those that have one; solitary vertices next to vertices
// with displacements receive one. Smooths noise and fills gaps left by flip
// avoidance.
#pragma once
#include <cstdint>

#include "cpu_dispatch.h"
#include "cubesphere.h"

namespace ffseg {

// d: 3 * nv displacements, valid where has[v]; tmp: 3 * nv, tmp_has: nv.
// cpu: the engine's kernels (the rounds over a fully displaced mesh take two
// vertices at a time in SSE2, with the scalar loop's bits).
void diffuse_displacements(const CpuDispatch& cpu, const CubeSphere& m, uint32_t rounds, double* d, uint8_t* has,
                           double* tmp, uint8_t* tmp_has);

// Harmonic fill of the gaps before diffusion: the displacement of every
// solitary vertex that is connected (through solitary vertices) to one with a
// displacement becomes the discrete harmonic extension of the displacements
// around its gap (each the mean of its four neighbours; successive
// over-relaxation, at most max_sweeps sweeps or until no component changes by
// more than tol_mm). A plain diffusion copies the sideways part of a gap's rim
// into it, so that a wide target-less patch (the lid over the cup's cavity)
// converges onto its middle and folds; the harmonic extension of a rim that
// closes in is a uniform contraction. has[v] becomes 1 for the filled vertices.
// queue: nv entries. Returns the number of vertices filled.
uint32_t harmonic_fill(const CubeSphere& m, double* d, uint8_t* has, uint32_t* queue, uint32_t max_sweeps,
                       double tol_mm);

}  // namespace ffseg
