// The Laplacian deformation energy of thesis 4.2.5 (METHOD.md section 2.6):
//   E = lambda_L |A x' - A x|^2 + sum_i w_i |x'_i - p_i|^2
//       + lambda_u sum_loop-edges |(x'_i - x'_j) - min(1, l_mean / l_ij)(x_i - x_j)|^2
// with A the uniform Laplacian (1 on the diagonal, -1/4 on the four
// neighbours) and l_mean the loop's length through the targets over 4n. The
// thesis has l_mean / l_ij; the min(1, .) makes the uniform term a tension
// (see the .cpp: pushing short edges apart buckles a loop). Its normal equations share one SPD matrix for x, y and z: one factorisation,
// three right-hand sides.
#pragma once
#include <cstdint>

#include "band_cholesky.h"
#include "cubesphere.h"

namespace ffseg {

// Assembles lambda_L A^T A + lambda_u C^T C + diag(w) into S (values only).
void assemble_laplacian(const CubeSphere& m, double lambda_l, double lambda_u, const double* w,
                        EnvelopeCholesky& S);

// Right-hand sides, three columns of nv (rhs[c * nv + v]), for current
// positions x, targets p (used where w > 0) and weights w.
void laplacian_rhs(const CubeSphere& m, double lambda_l, double lambda_u, const double* x, const double* p,
                   const double* w, double* rhs, double* scratch_l /* 3 * nv */);

}  // namespace ffseg
