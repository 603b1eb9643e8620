// Benchmark of the deformation-step linear solver on the real cube-sphere
// matrix  lambda_L A^T A + lambda_p W + lambda_u C^T C  (3 right-hand sides):
// ffseg EnvelopeCholesky (RCM) vs Eigen SimplicialLLT (AMD) vs LAPACK dpbtrf/
// dpbtrs on the RCM band (when built with FFSEG_HAVE_LAPACK). Single thread.
//
//   bench_solver [--reps R] [--sizes 21,33,49,65] [--kernel auto|portable|avx2|avx512]
#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "../tests/support/system_entries.h"

#include "arena.h"
#include "envelope_cholesky.h"
#include "cubesphere.h"
#include "rcm.h"
#include "testing_hooks.h"

#ifdef FFSEG_HAVE_LAPACK
extern "C" {
void dpbtrf_(const char* uplo, const int* n, const int* kd, double* ab, const int* ldab, int* info,
             std::size_t uplo_len);
void dpbtrs_(const char* uplo, const int* n, const int* kd, const int* nrhs, const double* ab,
             const int* ldab, double* b, const int* ldb, int* info, std::size_t uplo_len);
void openblas_set_num_threads(int) __attribute__((weak));
}
#endif

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

struct Buffer {
  void* p = nullptr;
  explicit Buffer(std::size_t bytes) { p = std::aligned_alloc(64, ffseg::Arena::round_up(bytes ? bytes : 64)); }
  ~Buffer() { std::free(p); }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
};

using ffseg_test::Entry;

std::vector<Entry> assemble(uint32_t nv, const uint32_t* nbr, double lL, double lP, double lU,
                            const std::vector<double>& w) {
  return ffseg_test::cube_sphere_system(nv, nbr, lL, lP, lU, w);
}

}  // namespace

int main(int argc, char** argv) {
  ffseg::CpuDispatch cpu = ffseg::CpuDispatch::detect();
  int reps = 7;
  std::vector<uint32_t> sizes = {21, 33, 49, 65};
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--reps") && a + 1 < argc) {
      reps = std::atoi(argv[++a]);
    } else if (!std::strcmp(argv[a], "--sizes") && a + 1 < argc) {
      sizes.clear();
      for (char* s = argv[++a]; *s;) {
        sizes.push_back(uint32_t(std::strtoul(s, &s, 10)));
        if (*s == ',') ++s;
      }
    } else if (!std::strcmp(argv[a], "--kernel") && a + 1 < argc) {
      const char* k = argv[++a];
      using ffseg::Isa;
      const Isa want = !std::strcmp(k, "portable") ? Isa::portable
                       : !std::strcmp(k, "avx2")   ? Isa::avx2
                       : !std::strcmp(k, "avx512") ? Isa::avx512
                                                   : cpu.kernel(ffseg::KernelFamily::cholesky);
      cpu = ffseg::CpuDispatchTesting::with(cpu, ffseg::KernelFamily::cholesky, want);
    }
  }
  if (reps < 1) reps = 1;
#ifdef FFSEG_HAVE_LAPACK
  if (openblas_set_num_threads) openblas_set_num_threads(1);
#endif
  std::printf("kernel: %s, %d repetitions (median), single thread\n\n",
              ffseg::CpuDispatch::name(cpu.kernel(ffseg::KernelFamily::cholesky)), reps);

  std::printf(
      "| n | unknowns | RCM bw | envelope | stored | ffseg clear ms | ffseg add ms | ffseg factor ms | ffseg solve ms | "
      "Eigen LLT factor ms | Eigen solve ms | nnz(L) Eigen |"
#ifdef FFSEG_HAVE_LAPACK
      " dpbtrf ms | dpbtrs ms |"
#endif
      " Eigen/ffseg factor |"
#ifdef FFSEG_HAVE_LAPACK
      " dpbtrf/ffseg factor |"
#endif
      " max rel diff | fused factor+forward ms | backward ms | fused / (factor + solve) | fused bit-identical |"
      " assign ms | factor+forward after assign ms | assign+factor+forward fused ms | fused / (assign + factor+forward) |"
      " assign fused bit-identical |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|"
#ifdef FFSEG_HAVE_LAPACK
              "---|---|---|"
#endif
              "---|---|---|---|---|---|---|---|---|---|---|\n");

  for (uint32_t n : sizes) {
    // Mesh.
    ffseg::CubeSphere mesh;
    ffseg::Arena probe;
    mesh.carve(probe, n);
    Buffer mbuf(probe.used());
    ffseg::Arena ma(mbuf.p, probe.used());
    mesh.carve(ma, n);
    mesh.build();
    const uint32_t nv = mesh.nv;

    // Matrix: lambda_L = 1, lambda_p on about half of the vertices, lambda_u = 0.5.
    std::mt19937_64 rng(12345 + n);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    std::vector<double> w(nv, 0.0);
    for (uint32_t i = 0; i < nv; ++i)
      if (U(rng) < 0.5) w[i] = 0.5 + U(rng);
    const std::vector<Entry> trip = assemble(nv, mesh.nbr, 1.0, 1.0, 0.5, w);

    // ffseg solver: graph + factor storage in one arena, measured first.
    ffseg::TwoRingGraph graph;
    ffseg::EnvelopeCholesky chol;
    std::vector<uint32_t> mscratch(ffseg::EnvelopeCholesky::measure_scratch_words(nv));
    // The graph is needed for the exact measuring pass: build it in its own arena.
    ffseg::Arena gprobe;
    graph.carve(gprobe, nv);
    Buffer gbuf(gprobe.used());
    ffseg::Arena ga(gbuf.p, gprobe.used());
    graph.carve(ga, nv);
    if (!graph.build(mesh.nbr)) {
      std::fprintf(stderr, "2-ring failed\n");
      return 1;
    }
    ffseg::Arena sprobe;
    if (!chol.init(sprobe, graph.graph(), cpu, 0, mscratch.data())) {
      std::fprintf(stderr, "measure failed\n");
      return 1;
    }
    Buffer sbuf(sprobe.used());
    ffseg::Arena sa(sbuf.p, sprobe.used());
    if (!chol.init(sa, graph.graph(), cpu) || sa.used() != sprobe.used()) {
      std::fprintf(stderr, "init failed\n");
      return 1;
    }

    // Right-hand sides.
    std::vector<double> rhs(3 * std::size_t(nv));
    for (double& x : rhs) x = U(rng) * 2 - 1;

    std::vector<double> t_fac, t_sol, t_clr, t_asm;
    std::vector<double> x_ff;
    for (int r = 0; r < reps; ++r) {
      auto t0 = Clock::now();
      chol.clear();
      t_clr.push_back(ms_since(t0));
      t0 = Clock::now();
      for (const Entry& e : trip) chol.add(e.i, e.j, e.v);
      t_asm.push_back(ms_since(t0));
      t0 = Clock::now();
      const int rc = chol.factor();
      t_fac.push_back(ms_since(t0));
      if (rc != 0) {
        std::fprintf(stderr, "factor failed %d\n", rc);
        return 1;
      }
      x_ff = rhs;
      t0 = Clock::now();
      chol.solve(x_ff.data(), 3, nv);
      t_sol.push_back(ms_since(t0));
    }
    // The step's path: the factorisation with the forward substitution fused
    // in, then the backward half; the same matrix and right-hand sides.
    std::vector<double> t_ffac, t_fback;
    bool fused_same = true;
    for (int r = 0; r < reps; ++r) {
      chol.clear();
      for (const Entry& e : trip) chol.add(e.i, e.j, e.v);
      std::vector<double> x = rhs;
      auto t0 = Clock::now();
      const int rc = chol.factor_forward(x.data(), nv);
      t_ffac.push_back(ms_since(t0));
      t0 = Clock::now();
      const int rb = chol.solve_forwarded(x.data(), nv);
      t_fback.push_back(ms_since(t0));
      fused_same = fused_same && rc == 0 && rb == 0 && x == x_ff;
    }

    // The step's path since the storage is written by the factorisation:
    // the matrix as sorted storage offsets and values (summed in add()'s
    // order), stored either by assign_sorted() ahead of factor_forward() or
    // group by group inside assign_factor_forward(); alternated, same inputs.
    std::vector<double> dense(chol.stored_entries(), 0.0);
    std::vector<uint8_t> used(chol.stored_entries(), 0);
    for (const Entry& e : trip) {
      const int64_t o = chol.offset_of(e.i, e.j);
      if (o < 0) return 1;
      dense[std::size_t(o)] += e.v;
      used[std::size_t(o)] = 1;
    }
    std::vector<uint64_t> offs;
    std::vector<double> vals;
    for (std::size_t o = 0; o < dense.size(); ++o)
      if (used[o]) {
        offs.push_back(o);
        vals.push_back(dense[o]);
      }
    std::vector<double> t_assign, t_after, t_afused;
    bool afused_same = true;
    for (int r = 0; r < reps; ++r) {
      std::vector<double> x = rhs, y = rhs;
      auto t0 = Clock::now();
      chol.assign_sorted(offs.data(), vals.data(), offs.size());
      t_assign.push_back(ms_since(t0));
      t0 = Clock::now();
      int rc = chol.factor_forward(x.data(), nv);
      t_after.push_back(ms_since(t0));
      rc |= chol.solve_forwarded(x.data(), nv);
      t0 = Clock::now();
      rc |= chol.assign_factor_forward(offs.data(), vals.data(), offs.size(), y.data(), nv);
      t_afused.push_back(ms_since(t0));
      rc |= chol.solve_forwarded(y.data(), nv);
      afused_same = afused_same && rc == 0 && x == x_ff && y == x_ff;
    }

    // Eigen.
    using SpMat = Eigen::SparseMatrix<double>;
    std::vector<Eigen::Triplet<double>> et;
    et.reserve(trip.size() * 2);
    for (const Entry& e : trip) {
      et.emplace_back(int(e.i), int(e.j), e.v);
      if (e.i != e.j) et.emplace_back(int(e.j), int(e.i), e.v);
    }
    SpMat A(nv, nv);
    A.setFromTriplets(et.begin(), et.end());
    Eigen::SimplicialLLT<SpMat, Eigen::Lower, Eigen::AMDOrdering<int>> llt;
    llt.analyzePattern(A);
    std::vector<double> t_efac, t_esol;
    Eigen::MatrixXd B = Eigen::Map<const Eigen::MatrixXd>(rhs.data(), nv, 3), X;
    for (int r = 0; r < reps; ++r) {
      auto t0 = Clock::now();
      llt.factorize(A);
      t_efac.push_back(ms_since(t0));
      if (llt.info() != Eigen::Success) {
        std::fprintf(stderr, "eigen failed\n");
        return 1;
      }
      t0 = Clock::now();
      X = llt.solve(B);
      t_esol.push_back(ms_since(t0));
    }
    const double nnzL = double(llt.matrixL().nestedExpression().nonZeros());

    double maxrel = 0;
    for (int q = 0; q < 3; ++q) {
      double num = 0, den = 0;
      for (uint32_t i = 0; i < nv; ++i) {
        const double d = x_ff[std::size_t(q) * nv + i] - X(i, q);
        num += d * d;
        den += X(i, q) * X(i, q);
      }
      maxrel = std::max(maxrel, std::sqrt(num / den));
    }

#ifdef FFSEG_HAVE_LAPACK
    // LAPACK band Cholesky on the same RCM-ordered matrix, kd = RCM bandwidth.
    const int N = int(nv), kd = int(chol.bandwidth()), ldab = kd + 1, nrhs = 3;
    std::vector<double> band0(std::size_t(ldab) * N, 0.0), band;
    const uint32_t* ip = chol.iperm();
    for (const Entry& e : trip) {
      uint32_t a = ip[e.i], b = ip[e.j];
      if (a < b) std::swap(a, b);
      band0[std::size_t(b) * ldab + (a - b)] += e.v;  // AB(1 + i - j, j)
    }
    std::vector<double> t_lfac, t_lsol, xb(3 * std::size_t(nv));
    for (int r = 0; r < reps; ++r) {
      band = band0;
      int info = 0;
      auto t0 = Clock::now();
      dpbtrf_("L", &N, &kd, band.data(), &ldab, &info, 1);
      t_lfac.push_back(ms_since(t0));
      if (info != 0) {
        std::fprintf(stderr, "dpbtrf info %d\n", info);
        return 1;
      }
      for (int q = 0; q < 3; ++q)
        for (uint32_t i = 0; i < nv; ++i) xb[std::size_t(q) * nv + ip[i]] = rhs[std::size_t(q) * nv + i];
      t0 = Clock::now();
      dpbtrs_("L", &N, &kd, &nrhs, band.data(), &ldab, xb.data(), &N, &info, 1);
      t_lsol.push_back(ms_since(t0));
    }
    for (int q = 0; q < 3; ++q) {
      double num = 0, den = 0;
      for (uint32_t i = 0; i < nv; ++i) {
        const double d = xb[std::size_t(q) * nv + ip[i]] - X(i, q);
        num += d * d;
        den += X(i, q) * X(i, q);
      }
      maxrel = std::max(maxrel, std::sqrt(num / den));
    }
#endif

    const double f = median(t_fac), s = median(t_sol), ef = median(t_efac), es = median(t_esol);
    std::printf("| %u | %u | %u | %llu | %llu | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.0f |", n, nv,
                chol.bandwidth(), (unsigned long long)chol.envelope_entries(),
                (unsigned long long)chol.stored_entries(), median(t_clr), median(t_asm), f, s, ef, es, nnzL);
#ifdef FFSEG_HAVE_LAPACK
    const double lf = median(t_lfac), ls = median(t_lsol);
    std::printf(" %.2f | %.2f |", lf, ls);
#endif
    std::printf(" %.2fx |", ef / f);
#ifdef FFSEG_HAVE_LAPACK
    std::printf(" %.2fx |", lf / f);
#endif
    const double ff = median(t_ffac), fb = median(t_fback);
    std::printf(" %.1e | %.2f | %.2f | %.2fx | %s |", maxrel, ff, fb, (ff + fb) / (f + s), fused_same ? "yes" : "NO");
    const double ta = median(t_assign), tf = median(t_after), taf = median(t_afused);
    std::printf(" %.2f | %.2f | %.2f | %.2fx | %s |\n", ta, tf, taf, taf / (ta + tf), afused_same ? "yes" : "NO");
    std::fflush(stdout);
  }
  return 0;
}
