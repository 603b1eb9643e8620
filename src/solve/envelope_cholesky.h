// Envelope (variable-band, "skyline") Cholesky factorisation for the SPD systems
// of the deformation step, with a reverse Cuthill-McKee ordering. All storage is
// carved from an Arena; nothing allocates.
//
// Storage. Rows are taken in RCM order and grouped by four. Every row of group
// g (rows 4g..4g+3) stores the columns [start_g, 4g+4), where start_g is the
// smallest first-nonzero column of the group rounded down to a multiple of 4.
// That is a dense 4 x w block per group (w a multiple of 4), so every row
// starts 32-byte aligned and the kernels see no ragged edges. Cholesky fill
// stays inside the envelope, so L overwrites A in place. The few extra zeros
// (alignment, group padding) stay exactly zero during the factorisation.
//
// Kernels. The factorisation is "up-looking" by row groups: for each group, a
// 4 x 4 tile of dot products against every earlier column group, then a small
// triangular fix-up, then the 4 x 4 diagonal block. The tile kernel has an
// AVX-512F, an AVX2+FMA and a portable version: the engine's CpuDispatch
// (cholesky family) picks one per instance at init().
#pragma once
#include <cstddef>
#include <cstdint>

#include "arena.h"
#include "cpu_dispatch.h"
#include "rcm.h"

namespace ffseg {

struct EnvelopeAssign;  // envelope_cholesky.cpp

// ---- 2-ring graph of a mesh in which every vertex has 4 neighbours ----------

// Capacity of the cols array of a 2-ring graph of nv vertices: 4 neighbours +
// 4 x 3 neighbours of neighbours = 16 per vertex at most.
inline std::size_t two_ring_capacity(uint32_t nv) { return std::size_t(16) * nv; }

// Builds the CSR graph in which u ~ v when their mesh distance is 1 or 2 (the
// pattern of A^T A + C^T C + W). nbr[4v .. 4v+3] are the neighbours of v.
// row_ptr: nv + 1 words; cols: two_ring_capacity(nv) words. Columns come out
// sorted and unique, without v itself. Returns false on out-of-range indices.
bool build_two_ring(uint32_t nv, const uint32_t* nbr, uint32_t* row_ptr, uint32_t* cols);

// A 2-ring graph whose storage is carved from an arena (fixed size, so the
// measuring pass is exact).
struct TwoRingGraph {
  uint32_t nv = 0;
  uint32_t* row_ptr = nullptr;
  uint32_t* cols = nullptr;
  void carve(Arena& a, uint32_t nv_) {
    nv = nv_;
    row_ptr = a.alloc<uint32_t>(std::size_t(nv) + 1);
    cols = a.alloc<uint32_t>(two_ring_capacity(nv));
  }
  bool build(const uint32_t* nbr) { return build_two_ring(nv, nbr, row_ptr, cols); }
  CsrGraph graph() const { return CsrGraph{nv, row_ptr, cols}; }
};

// ---- the solver ---------------------------------------------------------------

class EnvelopeCholesky {
 public:
  // factor() results.
  static constexpr int kOk = 0;
  static constexpr int kNotPositiveDefinite = -1;  // a pivot <= 0
  static constexpr int kNonFinite = -2;            // a pivot is NaN or infinite
  static constexpr int kOutOfPattern = -3;         // add() outside the envelope / bad index
  static constexpr int kNotReady = -4;             // init() failed or not called

  // Scratch words init() needs from the caller in measuring mode when no
  // capacity is given (the exact size then needs the ordering).
  static std::size_t measure_scratch_words(uint32_t n) { return 4 * std::size_t(n); }

  // Exact number of doubles the value storage takes for graph g under RCM, and
  // the RCM half-bandwidth. scratch: measure_scratch_words(g.n) words. False on
  // a malformed graph.
  static bool stored_entries_for(const CsrGraph& g, uint32_t* scratch, uint64_t* entries,
                                 uint32_t* bandwidth);

  // Symbolic setup: carves all storage from the arena and, on a real arena,
  // computes the RCM order and the envelope of g (the pattern of the matrix,
  // original numbering). The graph is only read during init.
  //  capacity > 0: the value storage is exactly `capacity` doubles in both
  //    passes; in the measuring pass only g.n is read (row_ptr/cols and
  //    measure_scratch may be null) -- g.n MUST be the real size in both
  //    passes, e.g. CsrGraph{nv, nullptr, nullptr}, because the index arrays
  //    are carved from it. The real pass fails if the envelope needs more
  //    than capacity (see stored_entries_for).
  //  capacity == 0: exact size. In the measuring pass this needs g and
  //    measure_scratch (measure_scratch_words(g.n) words, caller memory; the
  //    arena is not written).
  // cpu: the engine's kernels; this instance runs cpu's cholesky kernel.
  // Returns false on a malformed graph, missing input, exhausted arena or
  // insufficient capacity. Both passes carve the same sequence of blocks.
  bool init(Arena& arena, const CsrGraph& g, const CpuDispatch& cpu, uint64_t capacity = 0,
            uint32_t* measure_scratch = nullptr);

  // Zeroes the matrix (keeps the structure).
  void clear();
  // A(i, j) += v and, for i != j, A(j, i) += v: call once per unordered pair
  // (either order). Original numbering, O(1). Entries outside the envelope or
  // indices >= n make factor() return kOutOfPattern.
  inline void add(uint32_t i, uint32_t j, double v) {
    double* p = slot(i, j);
    if (p == nullptr) {
      bad_entry_ = true;
      return;
    }
    *p += v;
  }
  // Element offset of entry (i, j) in the storage, or -1 outside the
  // envelope (original numbering; after init on a real arena).
  int64_t offset_of(uint32_t i, uint32_t j) const {
    const double* p = slot(i, j);
    return p ? int64_t(p - val_) : -1;
  }
  // clear() followed by storing v[k] at offset off[k] (ascending, distinct,
  // from offset_of()), in one pass over the storage.
  void assign_sorted(const uint64_t* off, const double* v, std::size_t count);
  // Value currently stored at (i, j) (A before factor(), L after), original
  // numbering; 0 outside the envelope.
  double get(uint32_t i, uint32_t j) const;

  // In-place Cholesky A = L L^T. Returns kOk or a negative code (then the
  // factor is unusable until the next clear() + assembly). Never traps.
  int factor();
  // Solves A x = b in place for nrhs right-hand sides b + r * ld (original
  // numbering), three at a time. Requires a successful factor(); returns
  // kNotReady otherwise.
  int solve(double* b, int nrhs, std::size_t ld);
  // factor() fused with the forward half of solve() for three right-hand
  // sides b + r * ld (read only): each group of rows is forward-substituted
  // as soon as it is factored, while it is still in cache, instead of in a
  // second pass over the whole factor. solve_forwarded() then does the
  // backward half and writes the three solutions to x + r * ld (x may be b).
  // The results are bit for bit those of factor() + solve(b, 3, ld).
  // Any other call between the two (clear(), assembly, solve()) drops the
  // forward result: solve_forwarded() then returns kNotReady.
  int factor_forward(const double* b, std::size_t ld);
  int solve_forwarded(double* x, std::size_t ld);
  // assign_sorted(off, v, count) fused into factor_forward(b, ld): each group
  // of rows is stored (zeros, then its entries) just before it is factored,
  // so the storage is written once, in cache, instead of in a pass of its own
  // ahead of the factorisation. Bit for bit the results of the two calls;
  // solve_forwarded() follows. After a failure the storage is unusable until
  // the next assembly, as after factor().
  int assign_factor_forward(const uint64_t* off, const double* v, std::size_t count, const double* b,
                            std::size_t ld);

  uint32_t size() const { return n_; }
  uint32_t bandwidth() const { return bandwidth_; }
  // Strictly-lower envelope entries sum_i (i - first_i) of the RCM-ordered matrix.
  uint64_t envelope_entries() const { return envelope_; }
  // Doubles actually stored (envelope + diagonal + padding).
  uint64_t stored_entries() const { return stored_; }
  const uint32_t* perm() const { return perm_; }    // new -> old
  const uint32_t* iperm() const { return iperm_; }  // old -> new
  // Row (original numbering) whose pivot failed in the last factor(), or -1.
  int64_t failed_row() const { return failed_row_; }

  // The tile kernel this instance runs (from init()'s dispatch).
  Isa kernel() const { return cpu_.kernel(KernelFamily::cholesky); }

 private:
  friend struct EnvelopeCholeskyTesting;
  int factor_with(double* const* y, const EnvelopeAssign* as);
  // factor_forward() with as (nullptr: the storage as it is) stored first.
  int forward_with(const double* b, std::size_t ld, const EnvelopeAssign* as);
  // Permuted copies of cnt columns b + q * ld into y[0..2] (zero columns
  // and padding beyond).
  void load_permuted(const double* b, int cnt, std::size_t ld, double* const* y) const;
  // Triangular solves on permuted columns y[0..2] (forward false: backward only).
  void substitute(double* const* y, bool forward) const;

  // Storage of entry (i, j) in original numbering, or nullptr outside the
  // envelope / for indices >= n.
  inline double* slot(uint32_t i, uint32_t j) const {
    if (i >= n_ || j >= n_) return nullptr;
    uint32_t a = iperm_[i], b = iperm_[j];
    if (a < b) {
      const uint32_t t = a;
      a = b;
      b = t;
    }
    const uint32_t g = a >> 2;
    const uint32_t s = gstart_[g];
    if (b < s) return nullptr;
    return val_ + goff_[g] + (a & 3u) * (uint64_t(4) * g + 4 - s) + (b - s);
  }

  CpuDispatch cpu_;
  uint32_t n_ = 0;
  uint32_t npad_ = 0;     // n rounded up to a multiple of 4 (extra rows: identity)
  uint32_t ngroups_ = 0;  // npad / 4
  uint32_t bandwidth_ = 0;
  uint64_t envelope_ = 0;
  uint64_t stored_ = 0;
  uint64_t capacity_ = 0;
  uint32_t* perm_ = nullptr;
  uint32_t* iperm_ = nullptr;
  uint32_t* gstart_ = nullptr;  // ngroups: first stored column of each group
  uint64_t* goff_ = nullptr;    // ngroups: offset of the group's block in val_
  double* val_ = nullptr;
  double* invdiag_ = nullptr;   // npad: 1 / L(i, i)
  double* work_ = nullptr;      // 3 * npad: solve
  bool ready_ = false;
  bool factored_ = false;
  bool forwarded_ = false;  // work_ holds the forward result of factor_forward()
  bool bad_entry_ = false;
  int64_t failed_row_ = -1;
};

}  // namespace ffseg
