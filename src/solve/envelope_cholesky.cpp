#include "envelope_cholesky.h"

#include <cmath>
#include <cstring>

#include "envelope_kernels.h"

namespace ffseg {

// ---- 2-ring graph ----------------------------------------------------------------

bool build_two_ring(uint32_t nv, const uint32_t* nbr, uint32_t* row_ptr, uint32_t* cols) {
  if (nv == 0) {
    if (row_ptr) row_ptr[0] = 0;
    return row_ptr != nullptr;
  }
  if (nbr == nullptr || row_ptr == nullptr || cols == nullptr) return false;
  for (std::size_t e = 0; e < std::size_t(4) * nv; ++e)
    if (nbr[e] >= nv) return false;
  uint32_t at = 0;
  for (uint32_t v = 0; v < nv; ++v) {
    row_ptr[v] = at;
    uint32_t list[16];
    uint32_t cnt = 0;
    for (int a = 0; a < 4; ++a) {
      const uint32_t u = nbr[4 * std::size_t(v) + a];
      list[cnt++] = u;
      for (int b = 0; b < 4; ++b) {
        const uint32_t w = nbr[4 * std::size_t(u) + b];
        if (w != v && cnt < 16) list[cnt++] = w;
      }
    }
    // Sort, drop duplicates and v itself.
    for (uint32_t i = 1; i < cnt; ++i) {
      const uint32_t x = list[i];
      uint32_t j = i;
      while (j > 0 && list[j - 1] > x) {
        list[j] = list[j - 1];
        --j;
      }
      list[j] = x;
    }
    uint32_t prev = 0xFFFFFFFFu;
    for (uint32_t i = 0; i < cnt; ++i) {
      if (list[i] == prev || list[i] == v) continue;
      cols[at++] = list[i];
      prev = list[i];
    }
  }
  row_ptr[nv] = at;
  return true;
}

namespace {

using namespace envelope_kernels;

struct KPortable {
  static inline void dot4x4(const double* R, std::size_t wr, const double* J, std::size_t wj,
                            std::size_t len, double* acc) {
    for (int jp = 0; jp < 4; jp += 2) {
      const double* j0 = J + jp * wj;
      const double* j1 = j0 + wj;
      double a00 = 0, a01 = 0, a10 = 0, a11 = 0, a20 = 0, a21 = 0, a30 = 0, a31 = 0;
      for (std::size_t k = 0; k < len; ++k) {
        const double b0 = j0[k], b1 = j1[k];
        const double x0 = R[k], x1 = R[wr + k], x2 = R[2 * wr + k], x3 = R[3 * wr + k];
        a00 += x0 * b0;
        a01 += x0 * b1;
        a10 += x1 * b0;
        a11 += x1 * b1;
        a20 += x2 * b0;
        a21 += x2 * b1;
        a30 += x3 * b0;
        a31 += x3 * b1;
      }
      acc[0 + jp] = a00;
      acc[1 + jp] = a01;
      acc[4 + jp] = a10;
      acc[5 + jp] = a11;
      acc[8 + jp] = a20;
      acc[9 + jp] = a21;
      acc[12 + jp] = a30;
      acc[13 + jp] = a31;
    }
  }
  static inline void dot4x3(const double* R, std::size_t wr, const double* y0, const double* y1,
                            const double* y2, std::size_t len, double* acc) {
    for (int i = 0; i < 4; ++i) {
      const double* x = R + i * wr;
      double s0 = 0, s1 = 0, s2 = 0;
      for (std::size_t k = 0; k < len; ++k) {
        s0 += x[k] * y0[k];
        s1 += x[k] * y1[k];
        s2 += x[k] * y2[k];
      }
      acc[3 * i + 0] = s0;
      acc[3 * i + 1] = s1;
      acc[3 * i + 2] = s2;
    }
  }
  static inline void solve_tile(double* X, std::size_t wr, const double* D, std::size_t wj,
                                const double* inv, const double* acc) {
    for (int j = 0; j < 4; ++j) {
      for (int i = 0; i < 4; ++i) {
        double* xi = X + i * wr;
        double x = xi[j] - acc[4 * i + j];
        for (int m = 0; m < j; ++m) x -= xi[m] * D[j * wj + m];
        xi[j] = x * inv[j];
      }
    }
  }
  static inline void axpy4x3(const double* R, std::size_t wr, const double* x, double* y0,
                             double* y1, double* y2, std::size_t len) {
    const double* r0 = R;
    const double* r1 = R + wr;
    const double* r2 = R + 2 * wr;
    const double* r3 = R + 3 * wr;
    for (std::size_t k = 0; k < len; ++k) {
      y0[k] -= r0[k] * x[0] + r1[k] * x[3] + r2[k] * x[6] + r3[k] * x[9];
      y1[k] -= r0[k] * x[1] + r1[k] * x[4] + r2[k] * x[7] + r3[k] * x[10];
      y2[k] -= r0[k] * x[2] + r1[k] * x[5] + r2[k] * x[8] + r3[k] * x[11];
    }
  }
};

__attribute__((flatten)) int factor_portable(const View& v, uint32_t* bad, double* const* y,
                                             const EnvelopeAssign* as) {
  return factor_impl<KPortable>(v, bad, y, as);
}
__attribute__((flatten)) void solve_portable(const View& v, double* a, double* b, double* c, bool fwd) {
  solve_impl<KPortable>(v, a, b, c, fwd);
}

// Envelope computation shared by init() and stored_entries_for(): given perm
// and iperm, writes the group starts (when gstart != nullptr) and returns the
// stored doubles; *env = strictly-lower envelope, *bw = half-bandwidth.
uint64_t layout_groups(const CsrGraph& g, const uint32_t* perm, const uint32_t* iperm,
                       uint32_t* gstart, uint64_t* goff, uint64_t* env, uint32_t* bw) {
  const uint32_t n = g.n;
  const uint32_t ngroups = (n + 3) / 4;
  uint64_t stored = 0, e = 0;
  uint32_t band = 0;
  for (uint32_t grp = 0; grp < ngroups; ++grp) {
    uint32_t start = 4 * grp;
    for (uint32_t i = 4 * grp; i < 4 * grp + 4 && i < n; ++i) {
      const uint32_t old = perm[i];
      uint32_t first = i;
      for (uint32_t q = g.row_ptr[old]; q < g.row_ptr[old + 1]; ++q) {
        const uint32_t c = iperm[g.cols[q]];
        if (c < first) first = c;
      }
      e += i - first;
      if (i - first > band) band = i - first;
      if (first < start) start = first;
    }
    start &= ~3u;
    if (gstart) gstart[grp] = start;
    if (goff) goff[grp] = stored;
    stored += 4 * group_width(grp, start);
  }
  *env = e;
  *bw = band;
  return stored;
}

}  // namespace

// ---- EnvelopeCholesky ------------------------------------------------------------------

bool EnvelopeCholesky::stored_entries_for(const CsrGraph& g, uint32_t* scratch, uint64_t* entries,
                                          uint32_t* bandwidth) {
  if (scratch == nullptr) return false;
  uint32_t* perm = scratch;
  uint32_t* iperm = scratch + g.n;
  if (!rcm_order(g, perm, scratch + 2 * std::size_t(g.n))) return false;
  for (uint32_t i = 0; i < g.n; ++i) iperm[perm[i]] = i;
  uint64_t env = 0;
  uint32_t bw = 0;
  const uint64_t s = layout_groups(g, perm, iperm, nullptr, nullptr, &env, &bw);
  if (entries) *entries = s;
  if (bandwidth) *bandwidth = bw;
  return true;
}

bool EnvelopeCholesky::init(Arena& arena, const CsrGraph& g, const CpuDispatch& cpu, uint64_t capacity,
                            uint32_t* measure_scratch) {
  *this = EnvelopeCholesky();
  cpu_ = cpu;
  n_ = g.n;
  npad_ = (n_ + 3) & ~3u;
  ngroups_ = npad_ / 4;
  perm_ = arena.alloc<uint32_t>(n_);
  iperm_ = arena.alloc<uint32_t>(n_);
  gstart_ = arena.alloc<uint32_t>(ngroups_);
  goff_ = arena.alloc<uint64_t>(ngroups_);
  invdiag_ = arena.alloc<double>(npad_);
  work_ = arena.alloc<double>(3 * std::size_t(npad_));
  uint32_t* rcm_scratch = arena.alloc<uint32_t>(rcm_scratch_words(n_));

  if (n_ == 0) {
    val_ = arena.alloc<double>(capacity);
    capacity_ = capacity;
    ready_ = arena.ok() && !arena.measuring();
    return arena.ok();
  }
  const bool have_graph = g.row_ptr != nullptr && (g.row_ptr[n_] == 0 || g.cols != nullptr);

  if (arena.measuring()) {
    uint64_t need = capacity;
    if (capacity == 0) {
      if (!have_graph || measure_scratch == nullptr) return false;
      uint32_t bw = 0;
      if (!stored_entries_for(g, measure_scratch, &need, &bw)) return false;
    }
    val_ = arena.alloc<double>(need);
    capacity_ = need;
    return arena.ok();
  }

  // Real pass.
  if (!have_graph || perm_ == nullptr || iperm_ == nullptr || gstart_ == nullptr ||
      goff_ == nullptr || invdiag_ == nullptr || work_ == nullptr || rcm_scratch == nullptr)
    return false;
  if (!rcm_order(g, perm_, rcm_scratch)) return false;
  for (uint32_t i = 0; i < n_; ++i) iperm_[perm_[i]] = i;
  stored_ = layout_groups(g, perm_, iperm_, gstart_, goff_, &envelope_, &bandwidth_);
  const uint64_t cap = capacity ? capacity : stored_;
  val_ = arena.alloc<double>(cap);
  capacity_ = cap;
  if (val_ == nullptr || !arena.ok() || stored_ > cap) return false;
  ready_ = true;
  clear();
  return true;
}

void EnvelopeCholesky::clear() {
  factored_ = forwarded_ = false;
  bad_entry_ = false;
  failed_row_ = -1;
  if (!ready_) return;
  std::memset(val_, 0, stored_ * sizeof(double));
  // Padding rows n..npad-1: identity.
  for (uint32_t i = n_; i < npad_; ++i) {
    const uint32_t g = i >> 2;
    const uint32_t s = gstart_[g];
    val_[goff_[g] + (i & 3u) * group_width(g, s) + (i - s)] = 1.0;
  }
}

void EnvelopeCholesky::assign_sorted(const uint64_t* off, const double* v, std::size_t count) {
  factored_ = forwarded_ = false;
  bad_entry_ = false;
  failed_row_ = -1;
  if (!ready_) return;
  // Group by group: zero its block, the padding rows' identity, then the
  // values that fall in it (the block is still in cache).
  const View view{ngroups_, gstart_, goff_, val_, invdiag_};
  const EnvelopeAssign as{off, v, count, n_, npad_};
  std::size_t k = 0;
  for (uint32_t g = 0; g < ngroups_; ++g) assign_group(view, as, g, &k);
}

double EnvelopeCholesky::get(uint32_t i, uint32_t j) const {
  if (!ready_) return 0.0;
  const double* p = slot(i, j);
  return p ? *p : 0.0;
}

int EnvelopeCholesky::factor() { return factor_with(nullptr, nullptr); }

int EnvelopeCholesky::factor_forward(const double* b, std::size_t ld) { return forward_with(b, ld, nullptr); }

int EnvelopeCholesky::forward_with(const double* b, std::size_t ld, const EnvelopeAssign* as) {
  forwarded_ = false;
  if (!ready_ || b == nullptr) return kNotReady;
  double* y[3] = {work_, work_ + npad_, work_ + 2 * std::size_t(npad_)};
  load_permuted(b, 3, ld, y);
  const int rc = factor_with(y, as);
  forwarded_ = rc == kOk;
  return rc;
}

int EnvelopeCholesky::assign_factor_forward(const uint64_t* off, const double* v, std::size_t count,
                                            const double* b, std::size_t ld) {
  factored_ = forwarded_ = false;
  bad_entry_ = false;
  failed_row_ = -1;
  if (!ready_ || b == nullptr || (count && (off == nullptr || v == nullptr))) return kNotReady;
  // Offsets past the storage would never be stored by the group walk.
  if (count && off[count - 1] >= stored_) return kOutOfPattern;
  const EnvelopeAssign as{off, v, count, n_, npad_};
  return forward_with(b, ld, &as);
}

int EnvelopeCholesky::factor_with(double* const* y, const EnvelopeAssign* as) {
  factored_ = forwarded_ = false;
  failed_row_ = -1;
  if (!ready_) return kNotReady;
  if (bad_entry_) return kOutOfPattern;
  const View v{ngroups_, gstart_, goff_, val_, invdiag_};
  uint32_t bad = 0;
  int rc = kOk;
  switch (kernel()) {
#if FFSEG_X86
    case Isa::avx512:
      rc = factor_avx512(v, &bad, y, as);
      break;
    case Isa::avx2:
      rc = factor_avx2(v, &bad, y, as);
      break;
#endif
    default:
      rc = factor_portable(v, &bad, y, as);
      break;
  }
  if (rc != kOk) {
    failed_row_ = bad < n_ ? int64_t(perm_[bad]) : -1;
    return rc;
  }
  factored_ = true;
  return kOk;
}

void EnvelopeCholesky::load_permuted(const double* b, int cnt, std::size_t ld, double* const* y) const {
  for (int q = 0; q < 3; ++q) {
    if (q < cnt) {
      const double* src = b + std::size_t(q) * ld;
      for (uint32_t i = 0; i < n_; ++i) y[q][i] = src[perm_[i]];
      for (uint32_t i = n_; i < npad_; ++i) y[q][i] = 0.0;
    } else {
      std::memset(y[q], 0, npad_ * sizeof(double));
    }
  }
}

void EnvelopeCholesky::substitute(double* const* y, bool forward) const {
  const View v{ngroups_, gstart_, goff_, val_, invdiag_};
  switch (kernel()) {
#if FFSEG_X86
    case Isa::avx512:
      solve_avx512(v, y[0], y[1], y[2], forward);
      break;
    case Isa::avx2:
      solve_avx2(v, y[0], y[1], y[2], forward);
      break;
#endif
    default:
      solve_portable(v, y[0], y[1], y[2], forward);
      break;
  }
}

int EnvelopeCholesky::solve(double* b, int nrhs, std::size_t ld) {
  forwarded_ = false;
  if (!ready_ || !factored_) return kNotReady;
  if (nrhs <= 0) return kOk;
  if (b == nullptr) return kNotReady;
  double* y[3] = {work_, work_ + npad_, work_ + 2 * std::size_t(npad_)};
  for (int r0 = 0; r0 < nrhs; r0 += 3) {
    const int cnt = nrhs - r0 < 3 ? nrhs - r0 : 3;
    load_permuted(b + std::size_t(r0) * ld, cnt, ld, y);
    substitute(y, true);
    for (int q = 0; q < cnt; ++q) {
      double* dst = b + std::size_t(r0 + q) * ld;
      for (uint32_t i = 0; i < n_; ++i) dst[perm_[i]] = y[q][i];
    }
  }
  return kOk;
}

int EnvelopeCholesky::solve_forwarded(double* x, std::size_t ld) {
  if (!ready_ || !factored_ || !forwarded_ || x == nullptr) return kNotReady;
  forwarded_ = false;
  double* y[3] = {work_, work_ + npad_, work_ + 2 * std::size_t(npad_)};
  substitute(y, false);
  for (int q = 0; q < 3; ++q) {
    double* dst = x + std::size_t(q) * ld;
    for (uint32_t i = 0; i < n_; ++i) dst[perm_[i]] = y[q][i];
  }
  return kOk;
}

}  // namespace ffseg
