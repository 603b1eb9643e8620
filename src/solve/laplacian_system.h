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

#include "envelope_cholesky.h"
#include "cubesphere.h"

namespace ffseg {

// The matrix's entries in storage order, each with the additions that
// assemble_laplacian() makes to it, in the order it makes them (the mesh
// rows r holding both ends ascending, then the loop edges, then w): built
// once for a mesh and a solver structure, it lets assembly write the storage
// in one pass with the same sums.
struct LaplacianProgram {
  uint64_t* off = nullptr;   // storage offset, ascending
  uint32_t* vert = nullptr;  // row vertex (diagonal entries: whose w)
  uint16_t* code = nullptr;  // see laplacian_system.cpp
  double* val = nullptr;     // per entry, scratch
  uint8_t* vloops = nullptr; // per vertex: loop edges at it (scratch of build)
  uint8_t* eloops = nullptr; // 4 per vertex: loop edges to neighbour k (scratch of build)
  uint32_t count = 0, cap = 0;
  bool ok = false;
  // laplacian_values()' cache: the entries other than w depend on lambda_L
  // and lambda_u only, so with the same two the off-diagonal values in val
  // stand and each diagonal entry is its sum without w (dbase) plus w.
  uint32_t* diag = nullptr;  // nv: the diagonal entries' indices into val
  double* dbase = nullptr;   // nv: their sums without w
  uint32_t ndiag = 0;
  double cached_l = 0, cached_u = 0;
  bool cached = false;
  void carve(Arena& a, uint32_t nv);
  // Sets ok when every entry was found in S's envelope.
  void build(const CubeSphere& m, const EnvelopeCholesky& S);
};

// Assembles lambda_L A^T A + lambda_u C^T C + diag(w) into S (values only);
// with prog (built, ok) in one pass over the storage, the same values.
void assemble_laplacian(const CubeSphere& m, double lambda_l, double lambda_u, const double* w,
                        EnvelopeCholesky& S, LaplacianProgram* prog = nullptr);

// The values of assemble_laplacian() with prog (built, ok) into prog.val, in
// storage order, not stored: for EnvelopeCholesky::assign_factor_forward().
void laplacian_values(double lambda_l, double lambda_u, const double* w, LaplacianProgram& prog);

// Right-hand sides, three columns of nv (rhs[c * nv + v]), for current
// positions x, targets p (used where w > 0) and weights w.
void laplacian_rhs(const CubeSphere& m, double lambda_l, double lambda_u, const double* x, const double* p,
                   const double* w, double* rhs, double* scratch_l /* 3 * nv */);

// The positional term of one step (eq. 4.2.6): p_i = u_i + alpha d_i where the
// vertex has a displacement (has[v]), else u_i, each weighted by
// lambda_p max(kWeightFloor, |p_i - u_i| / mean) plus a kAnchor share of
// lambda_p that ties every vertex to u_i. target gets the one point per
// vertex the two pull towards (their weighted mean), w the sum of the two
// weights; x: current positions u, d: displacements, 3 per vertex.
// scratch: nv doubles.
// border (optional, several objects: thesis 6.3): a border vertex with a
// displacement is weighted lambda_p border_weight instead, so that the
// Laplacian terms barely move it from its target.
void positional_terms(uint32_t nv, const double* x, const double* d, const uint8_t* has, double alpha,
                      double lambda_p, double* target, double* w, double* scratch, const uint8_t* border = nullptr,
                      double border_weight = 0);

}  // namespace ffseg
