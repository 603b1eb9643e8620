// A cube-sphere mesh carried to another resolution (coarse to fine): every
// vertex of the target mesh takes the position the source mesh has at the
// same point of the cube-sphere parametrisation, by bilinear interpolation
// over the source cells around it (across a cube edge, the cells of the
// neighbouring face). A mesh grown at a coarse n and resampled to a fine n
// starts the fine mesh where the coarse one stopped, instead of from the
// sphere: the fine mesh then only corrects what the coarse one could not
// resolve, with displacements of a few of its edges rather than dozens.
#pragma once
#include <cstdint>

#include "cubesphere.h"

namespace ffseg {

// src: 3 floats per vertex of a cube-sphere of resolution n_src (6 n_src^2
// vertices, in CubeSphere's vertex order, as the engine extracts them); x: 3
// per vertex of m. n_src == m.n copies.
void resample_cubesphere(const CubeSphere& m, const float* src, uint32_t n_src, double* x);

}  // namespace ffseg
