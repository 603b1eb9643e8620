// Tests of the RCM ordering and the envelope Cholesky solver.
#include <doctest/doctest.h>

#include "support/system_entries.h"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "arena.h"
#include "envelope_cholesky.h"
#include "cubesphere.h"
#include "rcm.h"
#include "testing.h"

namespace {

using ffseg::Arena;
using ffseg::CsrGraph;
using ffseg::EnvelopeCholesky;
using ffseg::CpuDispatch;
using ffseg::Isa;
using Kernel = ffseg::Isa;

const CpuDispatch kCpu = CpuDispatch::detect();

// 64-byte aligned heap block for arenas.
struct Block {
  void* p = nullptr;
  explicit Block(std::size_t bytes) { p = std::aligned_alloc(64, Arena::round_up(bytes ? bytes : 64)); }
  ~Block() { std::free(p); }
  Block(const Block&) = delete;
  Block& operator=(const Block&) = delete;
};

// Symmetric graph from an edge list (both directions stored, duplicates and
// self loops removed).
struct Graph {
  uint32_t n = 0;
  std::vector<uint32_t> row_ptr, cols;
  CsrGraph csr() const { return CsrGraph{n, row_ptr.data(), cols.data()}; }
};

Graph make_graph(uint32_t n, const std::vector<std::pair<uint32_t, uint32_t>>& edges) {
  std::vector<std::vector<uint32_t>> adj(n);
  for (auto e : edges) {
    if (e.first == e.second) continue;
    adj[e.first].push_back(e.second);
    adj[e.second].push_back(e.first);
  }
  Graph g;
  g.n = n;
  g.row_ptr.push_back(0);
  for (auto& a : adj) {
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
    g.cols.insert(g.cols.end(), a.begin(), a.end());
    g.row_ptr.push_back(uint32_t(g.cols.size()));
  }
  return g;
}

// w x h grid, 5-point stencil, vertices relabelled by label[] (nullptr = row-major).
Graph grid_graph(uint32_t w, uint32_t h, const std::vector<uint32_t>* label) {
  std::vector<std::pair<uint32_t, uint32_t>> e;
  auto id = [&](uint32_t x, uint32_t y) {
    const uint32_t v = y * w + x;
    return label ? (*label)[v] : v;
  };
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      if (x + 1 < w) e.push_back({id(x, y), id(x + 1, y)});
      if (y + 1 < h) e.push_back({id(x, y), id(x, y + 1)});
    }
  return make_graph(w * h, e);
}

bool is_permutation(const std::vector<uint32_t>& p) {
  std::vector<char> seen(p.size(), 0);
  for (uint32_t v : p) {
    if (v >= p.size() || seen[v]) return false;
    seen[v] = 1;
  }
  return true;
}

std::vector<uint32_t> rcm(const Graph& g) {
  std::vector<uint32_t> perm(g.n), scratch(ffseg::rcm_scratch_words(g.n));
  REQUIRE(ffseg::rcm_order(g.csr(), perm.data(), scratch.data()));
  return perm;
}

std::vector<uint32_t> inverse(const std::vector<uint32_t>& p) {
  std::vector<uint32_t> ip(p.size());
  for (uint32_t i = 0; i < p.size(); ++i) ip[p[i]] = i;
  return ip;
}

// A solver set up over its own exactly measured arena.
struct Solver {
  EnvelopeCholesky chol;
  Block* block = nullptr;
  std::size_t measured = 0, used = 0;
  bool ok = false;
  explicit Solver(const CsrGraph& g) {
    std::vector<uint32_t> scratch(EnvelopeCholesky::measure_scratch_words(g.n));
    Arena probe;
    REQUIRE(chol.init(probe, g, kCpu, 0, scratch.data()));
    measured = probe.used();
    block = new Block(measured);
    Arena a(block->p, measured);
    ok = chol.init(a, g, kCpu);
    used = a.used();
  }
  ~Solver() { delete block; }
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;
};

using ffseg_test::Entry;

std::vector<Entry> cube_sphere_system(const ffseg::CubeSphere& m, double lL, double lP, double lU,
                                      const std::vector<double>& w) {
  return ffseg_test::cube_sphere_system(m.nv, m.nbr, lL, lP, lU, w);
}

Eigen::SparseMatrix<double> to_eigen(uint32_t n, const std::vector<Entry>& t) {
  std::vector<Eigen::Triplet<double>> et;
  for (const Entry& e : t) {
    et.emplace_back(int(e.i), int(e.j), e.v);
    if (e.i != e.j) et.emplace_back(int(e.j), int(e.i), e.v);
  }
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(et.begin(), et.end());
  return A;
}

double rel_diff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / b.norm();
}

struct Mesh {
  ffseg::CubeSphere m;
  Block* block = nullptr;
  explicit Mesh(uint32_t n) {
    Arena probe;
    m.carve(probe, n);
    block = new Block(probe.used());
    Arena a(block->p, probe.used());
    m.carve(a, n);
    m.build();
  }
  ~Mesh() { delete block; }
  Mesh(const Mesh&) = delete;
  Mesh& operator=(const Mesh&) = delete;
};

Graph two_ring(const ffseg::CubeSphere& m) {
  Graph g;
  g.n = m.nv;
  g.row_ptr.resize(m.nv + 1);
  g.cols.resize(ffseg::two_ring_capacity(m.nv));
  REQUIRE(ffseg::build_two_ring(m.nv, m.nbr, g.row_ptr.data(), g.cols.data()));
  g.cols.resize(g.row_ptr[m.nv]);
  return g;
}

// The tile kernels this CPU runs, the portable one first.
std::vector<Kernel> kernels() {
  std::vector<Kernel> ks;
  for (Kernel k : {Kernel::portable, Kernel::avx2, Kernel::avx512})
    if (CpuDispatch::supports(ffseg::KernelFamily::cholesky, k)) ks.push_back(k);
  return ks;
}

}  // namespace

TEST_CASE("rcm: permutation that reduces the bandwidth of a scrambled grid") {
  const uint32_t w = 37, h = 23;
  std::vector<uint32_t> label(w * h);
  for (uint32_t i = 0; i < label.size(); ++i) label[i] = i;
  std::mt19937 rng(7);
  std::shuffle(label.begin(), label.end(), rng);
  const Graph g = grid_graph(w, h, &label);
  const uint32_t bw0 = ffseg::graph_bandwidth(g.csr(), nullptr);
  const std::vector<uint32_t> perm = rcm(g);
  REQUIRE(is_permutation(perm));
  const std::vector<uint32_t> ip = inverse(perm);
  const uint32_t bw = ffseg::graph_bandwidth(g.csr(), ip.data());
  CHECK(bw < bw0 / 10);
  CHECK(bw <= h + 2);  // a w x h grid has an ordering of bandwidth min(w, h)
  CHECK(ffseg::graph_envelope(g.csr(), ip.data()) < ffseg::graph_envelope(g.csr(), nullptr) / 10);
  // Deterministic.
  CHECK(rcm(g) == perm);
}

TEST_CASE("rcm: disconnected graphs, isolated nodes, empty and malformed input") {
  // Two grids with interleaved labels plus isolated nodes.
  std::vector<std::pair<uint32_t, uint32_t>> e;
  const uint32_t n = 2 * 40 + 5;
  for (uint32_t c = 0; c < 2; ++c)
    for (uint32_t y = 0; y < 5; ++y)
      for (uint32_t x = 0; x < 8; ++x) {
        auto id = [&](uint32_t xx, uint32_t yy) { return 2 * (yy * 8 + xx) + c; };
        if (x + 1 < 8) e.push_back({id(x, y), id(x + 1, y)});
        if (y + 1 < 5) e.push_back({id(x, y), id(x, y + 1)});
      }
  const Graph g = make_graph(n, e);
  const std::vector<uint32_t> perm = rcm(g);
  REQUIRE(is_permutation(perm));
  const std::vector<uint32_t> ip = inverse(perm);
  CHECK(ffseg::graph_bandwidth(g.csr(), ip.data()) <= 7);
  // Each component occupies a contiguous range of new indices.
  for (uint32_t c = 0; c < 2; ++c) {
    uint32_t lo = n, hi = 0;
    for (uint32_t v = c; v < 80; v += 2) {
      lo = std::min(lo, ip[v]);
      hi = std::max(hi, ip[v]);
    }
    CHECK(hi - lo == 39);
  }

  Graph empty;
  empty.row_ptr = {0};
  std::vector<uint32_t> none;
  CHECK(ffseg::rcm_order(empty.csr(), none.data(), none.data()));

  Graph bad = make_graph(3, {{0, 1}, {1, 2}});
  bad.cols[0] = 9;
  std::vector<uint32_t> p(3), s(ffseg::rcm_scratch_words(3));
  CHECK_FALSE(ffseg::rcm_order(bad.csr(), p.data(), s.data()));
}

TEST_CASE("cholesky: 2-ring graph of the cube sphere") {
  Mesh mesh(6);
  const Graph g = two_ring(mesh.m);
  uint32_t n12 = 0;
  for (uint32_t v = 0; v < g.n; ++v) {
    const uint32_t deg = g.row_ptr[v + 1] - g.row_ptr[v];
    CHECK(deg <= 12);
    CHECK(deg >= 9);
    n12 += deg == 12;
    for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e) {
      const uint32_t w = g.cols[e];
      CHECK(w != v);
      if (e > g.row_ptr[v]) CHECK(g.cols[e - 1] < w);
      // Symmetric.
      CHECK(std::binary_search(g.cols.begin() + g.row_ptr[w], g.cols.begin() + g.row_ptr[w + 1], v));
    }
    for (int k = 0; k < 4; ++k)
      CHECK(std::binary_search(g.cols.begin() + g.row_ptr[v], g.cols.begin() + g.row_ptr[v + 1],
                               mesh.m.nbr[4 * v + k]));
  }
  CHECK(n12 > g.n / 2);
}

TEST_CASE("cholesky: cube-sphere system matches Eigen SimplicialLLT, all kernels") {
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (uint32_t n : {2u, 3u, 5u, 8u, 13u}) {
    Mesh mesh(n);
    const uint32_t nv = mesh.m.nv;
    const Graph g = two_ring(mesh.m);
    std::vector<double> w(nv, 0.0);
    for (uint32_t i = 0; i < nv; ++i)
      if (U(rng) < 0.4) w[i] = 0.1 + U(rng);
    w[nv / 2] = 1.0;  // at least one positive weight
    const double lL = 0.1 + 2 * U(rng), lP = 0.1 + 2 * U(rng), lU = 2 * U(rng);
    const std::vector<Entry> t = cube_sphere_system(mesh.m, lL, lP, lU, w);

    const Eigen::SparseMatrix<double> A = to_eigen(nv, t);
    Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(A);
    REQUIRE(llt.info() == Eigen::Success);
    Eigen::MatrixXd B = Eigen::MatrixXd::Random(nv, 3);
    const Eigen::MatrixXd X = llt.solve(B);

    Solver s(g.csr());
    REQUIRE(s.ok);
    CHECK(s.used == s.measured);
    CHECK(s.chol.size() == nv);
    CHECK(s.chol.bandwidth() == ffseg::graph_bandwidth(g.csr(), s.chol.iperm()));
    CHECK(s.chol.envelope_entries() == ffseg::graph_envelope(g.csr(), s.chol.iperm()));
    for (Kernel k : kernels()) {
      CAPTURE(n);
      CAPTURE(CpuDispatch::name(k));
      ffseg::EnvelopeCholeskyTesting::use(s.chol, k);
      s.chol.clear();
      for (const Entry& e : t) s.chol.add(e.i, e.j, e.v);
      CHECK(s.chol.get(0, 0) == doctest::Approx(A.coeff(0, 0)));
      REQUIRE(s.chol.factor() == EnvelopeCholesky::kOk);
      Eigen::MatrixXd Y = B;
      REQUIRE(s.chol.solve(Y.data(), 3, std::size_t(nv)) == EnvelopeCholesky::kOk);
      CHECK(rel_diff(Y, X) < 1e-10);
      CHECK((A * Y - B).norm() / B.norm() < 1e-10);
    }
  }
}

TEST_CASE("cholesky: random SPD envelope matrices match Eigen, any nrhs and ld") {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int trial = 0; trial < 40; ++trial) {
    const uint32_t n = 1 + uint32_t(rng() % 150);
    const uint32_t band = 1 + uint32_t(rng() % 40);
    // Random variable-band pattern, scrambled labels.
    std::vector<uint32_t> label(n);
    for (uint32_t i = 0; i < n; ++i) label[i] = i;
    std::shuffle(label.begin(), label.end(), rng);
    std::vector<std::pair<uint32_t, uint32_t>> edges;
    std::vector<Entry> t;
    std::vector<double> rowsum(n, 0.0);
    for (uint32_t i = 0; i < n; ++i) {
      const uint32_t first = i >= band ? i - uint32_t(rng() % (band + 1)) : uint32_t(rng() % (i + 1));
      for (uint32_t j = first; j < i; ++j) {
        if (j != first && rng() % 3 == 0) continue;  // sparse inside the envelope
        const double v = U(rng);
        edges.push_back({label[i], label[j]});
        t.push_back({std::max(label[i], label[j]), std::min(label[i], label[j]), v});
        rowsum[label[i]] += std::fabs(v);
        rowsum[label[j]] += std::fabs(v);
      }
    }
    // Diagonal dominance in half of the trials; otherwise B B^T-like scaling
    // with a weaker diagonal that is still SPD (checked by Eigen).
    const bool dominant = trial % 2 == 0;
    for (uint32_t i = 0; i < n; ++i)
      t.push_back({i, i, (dominant ? rowsum[i] : 0.6 * rowsum[i]) + 0.5 + std::fabs(U(rng))});
    const Graph g = make_graph(n, edges);
    const Eigen::SparseMatrix<double> A = to_eigen(n, t);
    Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(A);
    if (llt.info() != Eigen::Success) continue;  // not SPD: skip this draw

    const int nrhs = 1 + int(rng() % 5);
    const std::size_t ld = n + (rng() % 3);
    Eigen::MatrixXd B = Eigen::MatrixXd::Random(Eigen::Index(ld), nrhs);
    const Eigen::MatrixXd X = llt.solve(B.topRows(n));
    Solver s(g.csr());
    REQUIRE(s.ok);
    CHECK(s.used == s.measured);
    for (Kernel k : kernels()) {
      CAPTURE(trial);
      CAPTURE(CpuDispatch::name(k));
      ffseg::EnvelopeCholeskyTesting::use(s.chol, k);
      s.chol.clear();
      for (const Entry& e : t) s.chol.add(e.i, e.j, e.v);
      REQUIRE(s.chol.factor() == EnvelopeCholesky::kOk);
      Eigen::MatrixXd Y = B;
      REQUIRE(s.chol.solve(Y.data(), nrhs, ld) == EnvelopeCholesky::kOk);
      CHECK(rel_diff(Y.topRows(n), X) < 1e-10);
      // Rows beyond n (ld padding) are untouched.
      if (ld > n) CHECK((Y.bottomRows(Eigen::Index(ld - n)) - B.bottomRows(Eigen::Index(ld - n))).norm() == 0.0);
    }
  }
}

// The matrix t, freshly assembled into c.
static void load(EnvelopeCholesky& c, const std::vector<Entry>& t) {
  c.clear();
  for (const Entry& e : t) c.add(e.i, e.j, e.v);
}

// The cube-sphere system of resolution n with weights in [0.25, 3.25) from
// rng, for the tests of the step's fused calls.
struct SphereSystem {
  Mesh mesh;
  uint32_t nv;
  Graph g;
  std::vector<Entry> t;
  SphereSystem(uint32_t n, std::mt19937_64& rng) : mesh(n), nv(mesh.m.nv), g(two_ring(mesh.m)) {
    std::uniform_real_distribution<double> U(0.0, 1.0);
    std::vector<double> w(nv);
    for (uint32_t i = 0; i < nv; ++i) w[i] = 0.25 + 3 * U(rng);
    t = cube_sphere_system(mesh.m, 1.0, 1.0, 0.25, w);
  }
};

TEST_CASE("cholesky: factor_forward + solve_forwarded equal factor + solve bit for bit, all kernels") {
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (uint32_t n : {2u, 5u, 12u, 21u}) {
    const SphereSystem sys(n, rng);
    const uint32_t nv = sys.nv;
    const Graph& g = sys.g;
    const std::vector<Entry>& t = sys.t;
    const std::size_t ld = nv + 3;  // a leading dimension larger than nv
    std::vector<double> B(3 * ld);
    for (double& b : B) b = 200 * U(rng) - 100;
    Solver s(g.csr());
    REQUIRE(s.ok);
    for (Kernel k : kernels()) {
      CAPTURE(n);
      CAPTURE(CpuDispatch::name(k));
      ffseg::EnvelopeCholeskyTesting::use(s.chol, k);
      load(s.chol, t);
      REQUIRE(s.chol.factor() == EnvelopeCholesky::kOk);
      std::vector<double> ref = B;
      REQUIRE(s.chol.solve(ref.data(), 3, ld) == EnvelopeCholesky::kOk);
      // Not forwarded: the plain solve left nothing for solve_forwarded.
      std::vector<double> x(3 * ld, -7.0);
      CHECK(s.chol.solve_forwarded(x.data(), ld) == EnvelopeCholesky::kNotReady);

      load(s.chol, t);
      const std::vector<double> b_before = B;
      REQUIRE(s.chol.factor_forward(B.data(), ld) == EnvelopeCholesky::kOk);
      CHECK(B == b_before);  // read only
      REQUIRE(s.chol.solve_forwarded(x.data(), ld) == EnvelopeCholesky::kOk);
      for (int q = 0; q < 3; ++q)
        for (uint32_t i = 0; i < nv; ++i) REQUIRE(x[q * ld + i] == ref[q * ld + i]);  // bit for bit
      for (std::size_t i = nv; i < ld; ++i) CHECK(x[i] == -7.0);  // beyond nv untouched
      // Once only; and a clear() in between drops the forward result.
      CHECK(s.chol.solve_forwarded(x.data(), ld) == EnvelopeCholesky::kNotReady);
      load(s.chol, t);
      REQUIRE(s.chol.factor_forward(B.data(), ld) == EnvelopeCholesky::kOk);
      s.chol.clear();
      CHECK(s.chol.solve_forwarded(x.data(), ld) == EnvelopeCholesky::kNotReady);
    }
  }
}

TEST_CASE("cholesky: assign_factor_forward equals assign_sorted + factor_forward bit for bit, all kernels") {
  std::mt19937_64 rng(91);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (uint32_t n : {2u, 5u, 13u, 21u}) {
    const SphereSystem sys(n, rng);
    const uint32_t nv = sys.nv;
    const Graph& g = sys.g;
    const std::vector<Entry>& t = sys.t;
    Solver s(g.csr());
    REQUIRE(s.ok);
    // The matrix as sorted storage offsets, summed in add()'s order.
    std::vector<std::pair<uint64_t, double>> acc;
    for (const Entry& e : t) {
      const int64_t o = s.chol.offset_of(e.i, e.j);
      REQUIRE(o >= 0);
      acc.push_back({uint64_t(o), 0.0});
    }
    std::sort(acc.begin(), acc.end());
    acc.erase(std::unique(acc.begin(), acc.end()), acc.end());
    std::vector<uint64_t> off;
    for (const auto& a : acc) off.push_back(a.first);
    std::vector<double> val(off.size(), 0.0);
    for (const Entry& e : t) {
      const uint64_t o = uint64_t(s.chol.offset_of(e.i, e.j));
      val[std::size_t(std::lower_bound(off.begin(), off.end(), o) - off.begin())] += e.v;
    }
    const std::size_t ld = nv + 2;
    std::vector<double> B(3 * ld);
    for (double& b : B) b = 200 * U(rng) - 100;
    for (Kernel k : kernels()) {
      CAPTURE(n);
      CAPTURE(CpuDispatch::name(k));
      ffseg::EnvelopeCholeskyTesting::use(s.chol, k);
      // Reference: assembled by add(), then the two calls.
      load(s.chol, t);
      REQUIRE(s.chol.factor_forward(B.data(), ld) == EnvelopeCholesky::kOk);
      std::vector<double> ref(3 * ld, -7.0);
      REQUIRE(s.chol.solve_forwarded(ref.data(), ld) == EnvelopeCholesky::kOk);
      std::vector<double> lref;
      for (uint32_t i = 0; i < nv; ++i)
        for (uint32_t j = 0; j <= i; ++j) lref.push_back(s.chol.get(i, j));
      // Fused, on a storage left dirty by the factor above.
      std::vector<double> x(3 * ld, -7.0);
      REQUIRE(s.chol.assign_factor_forward(off.data(), val.data(), off.size(), B.data(), ld) ==
              EnvelopeCholesky::kOk);
      REQUIRE(s.chol.solve_forwarded(x.data(), ld) == EnvelopeCholesky::kOk);
      CHECK(x == ref);  // bit for bit, and beyond nv untouched (-7)
      std::vector<double> lfused;
      for (uint32_t i = 0; i < nv; ++i)
        for (uint32_t j = 0; j <= i; ++j) lfused.push_back(s.chol.get(i, j));
      CHECK(lfused == lref);
      // A matrix that is not positive definite fails as factor() does, with
      // the same row; an offset past the storage is refused.
      std::vector<double> bad = val;
      const std::size_t d = std::size_t(std::lower_bound(off.begin(), off.end(),
                                                         uint64_t(s.chol.offset_of(nv / 2, nv / 2))) - off.begin());
      bad[d] = -1.0;
      CHECK(s.chol.assign_factor_forward(off.data(), bad.data(), off.size(), B.data(), ld) ==
            EnvelopeCholesky::kNotPositiveDefinite);
      const int64_t failed = s.chol.failed_row();
      CHECK(s.chol.solve_forwarded(x.data(), ld) == EnvelopeCholesky::kNotReady);
      s.chol.assign_sorted(off.data(), bad.data(), off.size());
      CHECK(s.chol.factor() == EnvelopeCholesky::kNotPositiveDefinite);
      CHECK(s.chol.failed_row() == failed);
      std::vector<uint64_t> past = off;
      past.back() = s.chol.stored_entries();
      CHECK(s.chol.assign_factor_forward(past.data(), val.data(), past.size(), B.data(), ld) ==
            EnvelopeCholesky::kOutOfPattern);
    }
  }
}

TEST_CASE("cholesky: portable, AVX2 and AVX-512 kernels agree on the factor") {
  Mesh mesh(11);
  const Graph g = two_ring(mesh.m);
  std::vector<double> w(mesh.m.nv, 0.0);
  for (uint32_t i = 0; i < mesh.m.nv; i += 3) w[i] = 1.0 + 0.01 * (i % 7);
  const std::vector<Entry> t = cube_sphere_system(mesh.m, 1.0, 0.7, 0.5, w);
  Solver s(g.csr());
  REQUIRE(s.ok);
  std::vector<std::vector<double>> L;
  std::vector<Kernel> used;
  for (Kernel k : kernels()) {
    ffseg::EnvelopeCholeskyTesting::use(s.chol, k);
    used.push_back(s.chol.kernel());
    s.chol.clear();
    for (const Entry& e : t) s.chol.add(e.i, e.j, e.v);
    REQUIRE(s.chol.factor() == EnvelopeCholesky::kOk);
    std::vector<double> l;
    for (uint32_t v = 0; v < g.n; ++v) {
      l.push_back(s.chol.get(v, v));
      for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e) l.push_back(s.chol.get(v, g.cols[e]));
    }
    L.push_back(l);
  }
  CHECK(used[0] == Kernel::portable);
  std::string names;
  for (Kernel k : used) names += std::string(names.empty() ? "" : ", ") + CpuDispatch::name(k);
  MESSAGE("kernels exercised: " << names);
  for (std::size_t k = 1; k < L.size(); ++k) {
    double maxd = 0, maxv = 0;
    for (std::size_t i = 0; i < L[0].size(); ++i) {
      maxd = std::max(maxd, std::fabs(L[k][i] - L[0][i]));
      maxv = std::max(maxv, std::fabs(L[0][i]));
    }
    CHECK(maxd <= 1e-12 * maxv);
  }
}

TEST_CASE("cholesky: indefinite, singular, NaN and infinite matrices give error codes") {
  const Graph g = grid_graph(9, 7, nullptr);
  Solver s(g.csr());
  REQUIRE(s.ok);
  auto laplacian = [&](double shift) {
    s.chol.clear();
    for (uint32_t v = 0; v < g.n; ++v) {
      s.chol.add(v, v, double(g.row_ptr[v + 1] - g.row_ptr[v]) + shift);
      for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e)
        if (g.cols[e] < v) s.chol.add(v, g.cols[e], -1.0);
    }
  };
  for (Kernel k : kernels()) {
    CAPTURE(CpuDispatch::name(k));
    ffseg::EnvelopeCholeskyTesting::use(s.chol, k);
    laplacian(0.1);
    CHECK(s.chol.factor() == EnvelopeCholesky::kOk);

    laplacian(-0.5);  // indefinite
    CHECK(s.chol.factor() == EnvelopeCholesky::kNotPositiveDefinite);
    CHECK(s.chol.failed_row() >= 0);
    std::vector<double> b(g.n, 1.0);
    CHECK(s.chol.solve(b.data(), 1, g.n) == EnvelopeCholesky::kNotReady);

    laplacian(0.1);
    s.chol.add(5, 5, -100.0);  // negative pivot early
    CHECK(s.chol.factor() == EnvelopeCholesky::kNotPositiveDefinite);

    laplacian(0.1);
    s.chol.add(20, 20, std::numeric_limits<double>::quiet_NaN());
    CHECK(s.chol.factor() == EnvelopeCholesky::kNonFinite);

    laplacian(0.1);
    s.chol.add(30, 29, std::numeric_limits<double>::quiet_NaN());  // off-diagonal NaN
    const int rc = s.chol.factor();
    CHECK(rc == EnvelopeCholesky::kNonFinite);

    laplacian(0.1);
    s.chol.add(40, 40, std::numeric_limits<double>::infinity());
    CHECK(s.chol.factor() == EnvelopeCholesky::kNonFinite);

    laplacian(0.1);
    s.chol.add(41, 40, std::numeric_limits<double>::infinity());  // off-diagonal inf
    CHECK(s.chol.factor() == EnvelopeCholesky::kNonFinite);

    laplacian(0.1);
    s.chol.add(0, 62, 1.0);  // far outside the envelope
    CHECK(s.chol.factor() == EnvelopeCholesky::kOutOfPattern);
    laplacian(0.1);
    s.chol.add(0, 1000, 1.0);  // bad index
    CHECK(s.chol.factor() == EnvelopeCholesky::kOutOfPattern);
    laplacian(0.1);  // clear() resets the flag
    CHECK(s.chol.factor() == EnvelopeCholesky::kOk);
  }
  EnvelopeCholesky fresh;
  CHECK(fresh.factor() == EnvelopeCholesky::kNotReady);
}

TEST_CASE("cholesky: measuring pass is exact and writes nothing") {
  Mesh mesh(7);
  const Graph g = two_ring(mesh.m);
  std::vector<uint32_t> scratch(EnvelopeCholesky::measure_scratch_words(g.n));

  // Exact mode.
  EnvelopeCholesky a;
  Arena probe;
  probe.alloc<char>(3);  // something carved before
  REQUIRE(a.init(probe, g.csr(), kCpu, 0, scratch.data()));
  Block blk(probe.used());
  std::memset(blk.p, 0xAB, probe.used());
  Arena real(blk.p, probe.used());
  real.alloc<char>(3);
  REQUIRE(a.init(real, g.csr(), kCpu));
  CHECK(real.used() == probe.used());
  CHECK(real.ok());

  uint64_t stored = 0;
  uint32_t bw = 0;
  REQUIRE(EnvelopeCholesky::stored_entries_for(g.csr(), scratch.data(), &stored, &bw));
  CHECK(stored == a.stored_entries());
  CHECK(bw == a.bandwidth());

  // Without graph or scratch the measuring pass needs a capacity.
  EnvelopeCholesky c;
  Arena p2;
  CHECK_FALSE(c.init(p2, CsrGraph{g.n, nullptr, nullptr}, kCpu, 0, nullptr));

  // Capacity mode: the measuring pass needs neither graph nor scratch.
  const uint64_t cap = stored + 100;
  EnvelopeCholesky b;
  Arena p3;
  REQUIRE(b.init(p3, CsrGraph{g.n, nullptr, nullptr}, kCpu, cap));
  Block blk3(p3.used());
  Arena r3(blk3.p, p3.used());
  REQUIRE(b.init(r3, g.csr(), kCpu, cap));
  CHECK(r3.used() == p3.used());

  // Too small a capacity or a too small buffer fail cleanly.
  EnvelopeCholesky d;
  Arena p4;
  REQUIRE(d.init(p4, CsrGraph{g.n, nullptr, nullptr}, kCpu, stored - 1));
  Block blk4(p4.used());
  Arena r4(blk4.p, p4.used());
  CHECK_FALSE(d.init(r4, g.csr(), kCpu, stored - 1));
  CHECK(d.factor() == EnvelopeCholesky::kNotReady);
  EnvelopeCholesky e;
  Arena r5(blk4.p, probe.used() / 2);
  CHECK_FALSE(e.init(r5, g.csr(), kCpu));
  CHECK(e.factor() == EnvelopeCholesky::kNotReady);
}

#include "laplacian_system.h"

TEST_CASE("assembly program: the same matrix, bit for bit, as the plain assembly") {
  for (uint32_t n : {2u, 3u, 5u, 12u, 21u}) {
    ffseg::CubeSphere mesh;
    Arena mp;
    mesh.carve(mp, n);
    Block mb(mp.used());
    Arena ma(mb.p, mp.used());
    mesh.carve(ma, n);
    mesh.build();
    const uint32_t nv = mesh.nv;
    ffseg::TwoRingGraph graph;
    Arena gp;
    graph.carve(gp, nv);
    Block gb(gp.used());
    Arena ga(gb.p, gp.used());
    graph.carve(ga, nv);
    REQUIRE(graph.build(mesh.nbr));
    std::vector<uint32_t> ms(EnvelopeCholesky::measure_scratch_words(nv));
    EnvelopeCholesky chol;
    Arena sp;
    REQUIRE(chol.init(sp, graph.graph(), kCpu, 0, ms.data()));
    Block sb(sp.used());
    Arena sa(sb.p, sp.used());
    REQUIRE(chol.init(sa, graph.graph(), kCpu));
    ffseg::LaplacianProgram prog;
    Arena pp;
    prog.carve(pp, nv);
    Block pb(pp.used());
    Arena pa(pb.p, pp.used());
    prog.carve(pa, nv);
    prog.build(mesh, chol);
    REQUIRE(prog.ok);
    std::vector<double> w(nv);
    for (uint32_t i = 0; i < nv; ++i) w[i] = i % 3 ? 0.3 + (i % 7) * 0.1371 : 0.0;
    const double lams[3][2] = {{1.0, 0.25}, {0.37, 0.0}, {2.9, 0.013}};
    for (const auto& L : lams) {
      std::vector<double> plain, fast;
      ffseg::assemble_laplacian(mesh, L[0], L[1], w.data(), chol, nullptr);
      for (uint32_t i = 0; i < nv; ++i)
        for (uint32_t j = 0; j < nv; ++j) plain.push_back(chol.get(i, j));
      ffseg::assemble_laplacian(mesh, L[0], L[1], w.data(), chol, &prog);
      for (uint32_t i = 0; i < nv; ++i)
        for (uint32_t j = 0; j < nv; ++j) fast.push_back(chol.get(i, j));
      REQUIRE(plain.size() == fast.size());
      CHECK(std::memcmp(plain.data(), fast.data(), plain.size() * sizeof(double)) == 0);
      CHECK(chol.factor() == EnvelopeCholesky::kOk);
      // The same lambdas again with other weights: the program's cached
      // off-diagonal values and diagonal sums, still the plain values.
      std::vector<double> w2(w);
      for (uint32_t i = 0; i < nv; ++i) w2[i] = i % 5 ? 1.7 - (i % 11) * 0.093 : 0.0;
      CHECK(prog.cached);
      std::vector<double> plain2, fast2;
      ffseg::assemble_laplacian(mesh, L[0], L[1], w2.data(), chol, nullptr);
      for (uint32_t i = 0; i < nv; ++i)
        for (uint32_t j = 0; j < nv; ++j) plain2.push_back(chol.get(i, j));
      ffseg::assemble_laplacian(mesh, L[0], L[1], w2.data(), chol, &prog);
      for (uint32_t i = 0; i < nv; ++i)
        for (uint32_t j = 0; j < nv; ++j) fast2.push_back(chol.get(i, j));
      CHECK(plain2 != plain);
      CHECK(std::memcmp(plain2.data(), fast2.data(), plain2.size() * sizeof(double)) == 0);
    }
  }
}
