// Feature stage of thesis chapter 5: Perona-Malik smoothing of a crop (5.2.1),
// the intensity model (adaptive binning + EM, 5.2.2) and the grey-level
// correspondence search (5.3), on synthetic volumes with known answers.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "arena.h"
#include "exp_block.h"
#include "intensity_model.h"
#include "intensity_search.h"
#include "smoothing.h"
#include "testing.h"
#include "volume.h"

using namespace ffseg;

namespace {

// The kernels an engine on this CPU runs, and each kernel of one family
// alone (the portable one first), the others as detected.
const CpuDispatch kCpu = CpuDispatch::detect();
std::vector<CpuDispatch> each_kernel(KernelFamily f) {
  std::vector<CpuDispatch> out;
  for (Isa k : {Isa::portable, Isa::sse2, Isa::avx2, Isa::avx512})
    if (CpuDispatch::supports(f, k)) out.push_back(CpuDispatchTesting::with(kCpu, f, k));
  return out;
}

// Deterministic normal deviates (splitmix64 + Box-Muller).
struct Rng {
  uint64_t s;
  explicit Rng(uint64_t seed) : s(seed) {}
  uint64_t next() {
    uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return (double(next() >> 11) + 0.5) / 9007199254740992.0; }
  double normal() {
    const double u = uniform(), v = uniform();
    return std::sqrt(-2 * std::log(u)) * std::cos(6.283185307179586 * v);
  }
};

// A contiguous volume (i fastest) of T with a diagonal affine.
template <class T>
struct TestVolume {
  std::vector<T> data;
  int64_t dims[3];
  double spacing[3];
  VolumeView view;
  TestVolume(int64_t nx, int64_t ny, int64_t nz, double sx, double sy, double sz)
      : data(size_t(nx * ny * nz)), dims{nx, ny, nz}, spacing{sx, sy, sz} {}
  T& at(int64_t i, int64_t j, int64_t k) { return data[size_t(i + dims[0] * (j + dims[1] * k))]; }
  void world(int64_t i, int64_t j, int64_t k, double w[3]) const {
    w[0] = i * spacing[0];
    w[1] = j * spacing[1];
    w[2] = k * spacing[2];
  }
  bool finish(VoxelType type, double slope = 1, double intercept = 0) {
    VolumeDesc d;
    std::memset(&d, 0, sizeof d);
    d.type = uint32_t(type);
    d.data = data.data();
    d.data_bytes = data.size() * sizeof(T);
    d.offset = 0;
    for (int a = 0; a < 3; ++a) d.dims[a] = dims[a];
    d.strides[0] = sizeof(T);
    d.strides[1] = int64_t(sizeof(T)) * dims[0];
    d.strides[2] = int64_t(sizeof(T)) * dims[0] * dims[1];
    double A[16] = {spacing[0], 0, 0, 0, 0, spacing[1], 0, 0, 0, 0, spacing[2], 0, 0, 0, 0, 1};
    std::memcpy(d.index_to_world, A, sizeof A);
    d.slope = slope;
    d.intercept = intercept;
    char msg[256];
    return view.assign(d, msg, sizeof msg);
  }
};

// Runs carve(Arena&) twice, measuring then over real memory, like the engine.
struct Carved {
  void* mem = nullptr;
  size_t measured = 0, real = 0;
  bool ok = false;
  template <class F>
  explicit Carved(F carve) {
    Arena m;
    carve(m);
    measured = m.used();
    mem = std::aligned_alloc(64, measured + 64);
    Arena r(mem, measured);
    carve(r);
    real = r.used();
    ok = r.ok() && m.ok();
  }
  ~Carved() { std::free(mem); }
  Carved(const Carved&) = delete;
  Carved& operator=(const Carved&) = delete;
};

std::vector<float> mixture_samples(uint32_t n, const std::vector<Gaussian1>& comps, uint64_t seed) {
  Rng rng(seed);
  std::vector<float> x;
  x.reserve(n);
  for (uint32_t j = 0; j < n; ++j) {
    double u = rng.uniform(), acc = 0;
    size_t c = 0;
    for (; c + 1 < comps.size(); ++c) {
      acc += comps[c].weight;
      if (u < acc) break;
    }
    x.push_back(float(comps[c].mean + std::sqrt(comps[c].var) * rng.normal()));
  }
  return x;
}

// Edge phantom: 0 | 100 across the plane at index 31.5 of `axis`, plus noise sigma 10.
TestVolume<float> edge_volume(int axis, uint64_t seed) {
  TestVolume<float> v(64, 64, 12, 0.7, 0.7, 5.0);
  Rng rng(seed);
  const int64_t mid = axis == 2 ? 6 : 32;
  for (int64_t k = 0; k < 12; ++k)
    for (int64_t j = 0; j < 64; ++j)
      for (int64_t i = 0; i < 64; ++i) {
        const int64_t idx[3] = {i, j, k};
        v.at(i, j, k) = float((idx[axis] >= mid ? 100.0 : 0.0) + 10.0 * rng.normal());
      }
  v.finish(VoxelType::F32);
  return v;
}

double variance_of(const std::vector<double>& x) {
  double m = 0, s = 0;
  for (double v : x) m += v;
  m /= double(x.size());
  for (double v : x) s += (v - m) * (v - m);
  return s / double(x.size());
}

}  // namespace

TEST_CASE("smoothing: Perona-Malik reduces noise in flat regions and keeps a step edge (0.7 x 0.7 x 5 mm)") {
  for (int axis : {0, 2}) {
    CAPTURE(axis);
    TestVolume<float> v = edge_volume(axis, 7 + uint64_t(axis));
    SmoothedRoi roi;
    Carved mem([&](Arena& a) { roi.carve(a, 64 * 64 * 12, kCpu); });
    REQUIRE(mem.ok);
    const int64_t lo[3] = {0, 0, 0}, hi[3] = {64, 64, 12};
    SmoothingSettings s;
    s.iterations = 10;
    REQUIRE(roi.compute(v.view, lo, hi, s) == RoiStatus::ok);
    // The robust noise estimate finds the noise (structure only touches one axis).
    CHECK(roi.noise_sigma() == doctest::Approx(10).epsilon(0.15));
    CHECK(roi.kappa() == doctest::Approx(2 * roi.noise_sigma() / 0.7));
    CHECK(roi.time_step() == doctest::Approx(0.75 / (2 * (2 / 0.49 + 1 / 25.0))));

    const int64_t mid = axis == 2 ? 6 : 32;
    // Flat regions: at least 3 voxels away from the edge and from the crop's faces along the edge axis.
    std::vector<double> before, after;
    for (int64_t k = 0; k < 12; ++k)
      for (int64_t j = 0; j < 64; ++j)
        for (int64_t i = 0; i < 64; ++i) {
          const int64_t idx[3] = {i, j, k};
          const int64_t e = idx[axis];
          if (std::llabs(e - mid) < 3 || std::llabs(e - (mid - 1)) < 3) continue;
          if (axis == 2) {
            if (k == 0 || k == 11) continue;
          }
          before.push_back(v.at(i, j, k) - (e >= mid ? 100 : 0));
          after.push_back(roi.at(i, j, k) - (e >= mid ? 100 : 0));
        }
    const double vb = variance_of(before), va = variance_of(after);
    MESSAGE("axis " << axis << ": noise variance " << vb << " -> " << va);
    CHECK(va < 0.25 * vb);  // mostly in-plane: diffusion across 5 mm slices is slow (dt / h_z^2 = 0.004)
    // Edge position: the 50 crossing along the edge axis, per line, nearest the true edge.
    const int64_t n_edge = axis == 2 ? 12 : 64;
    const double truth = double(mid) - 0.5;
    int lines = 0, within = 0;
    double sum = 0;
    for (int64_t a = 0; a < 64; ++a)
      for (int64_t b = 0; b < (axis == 2 ? 64 : 12); ++b) {
        double best = 1e9;
        for (int64_t e = 0; e + 1 < n_edge; ++e) {
          const float f0 = axis == 2 ? roi.at(a, b, e) : roi.at(e, a, b);
          const float f1 = axis == 2 ? roi.at(a, b, e + 1) : roi.at(e + 1, a, b);
          if ((f0 - 50) * (f1 - 50) <= 0 && f0 != f1) {
            const double c = double(e) + (50 - f0) / (f1 - f0);
            if (std::fabs(c - truth) < std::fabs(best - truth)) best = c;
          }
        }
        ++lines;
        sum += best;
        within += std::fabs(best - truth) < 1.0;
      }
    CHECK(std::fabs(sum / lines - truth) < 0.2);
    CHECK(within >= lines * 99 / 100);
    // Maximum principle: no value leaves the raw range.
    float mn = 1e30f, mx = -1e30f;
    for (int64_t k = 0; k < 12; ++k)
      for (int64_t j = 0; j < 64; ++j)
        for (int64_t i = 0; i < 64; ++i) mn = std::min(mn, roi.at(i, j, k)), mx = std::max(mx, roi.at(i, j, k));
    CHECK(mn >= roi.value_min());
    CHECK(mx <= roi.value_max());
  }
}

TEST_CASE("smoothing: a crop equals smoothing the whole volume inside its box") {
  TestVolume<float> v = edge_volume(0, 11);
  SmoothedRoi full, crop;
  Carved m1([&](Arena& a) { full.carve(a, 64 * 64 * 12, kCpu); });
  Carved m2([&](Arena& a) { crop.carve(a, 40000, kCpu); });
  SmoothingSettings s;
  s.iterations = 6;
  s.kappa = 25;  // fixed: the automatic one depends on the crop's noise sample
  const int64_t glo[3] = {0, 0, 0}, ghi[3] = {64, 64, 12};
  const int64_t lo[3] = {20, 10, 3}, hi[3] = {45, 30, 9};
  REQUIRE(full.compute(v.view, glo, ghi, s) == RoiStatus::ok);
  REQUIRE(crop.compute(v.view, lo, hi, s) == RoiStatus::ok);
  CHECK(crop.needed_voxels() == (25 + 12) * (20 + 12) * 12);  // grown by 6 voxels, clipped along k
  CHECK(crop.contains(lo, hi));
  const int64_t bigger[3] = {19, 10, 3};
  CHECK_FALSE(crop.contains(bigger, hi));
  double worst = 0;
  for (int64_t k = lo[2]; k < hi[2]; ++k)
    for (int64_t j = lo[1]; j < hi[1]; ++j)
      for (int64_t i = lo[0]; i < hi[0]; ++i) worst = std::max(worst, double(std::fabs(crop.at(i, j, k) - full.at(i, j, k))));
  CHECK(worst < 1e-3);
  // Sampling: voxel centres give the stored values; beyond the region, the nearest voxel.
  const double p[3] = {25, 15, 5};
  CHECK(crop.sample_index(p) == doctest::Approx(crop.at(25, 15, 5)));
  const double w[3] = {25 * 0.7, 15 * 0.7, 5 * 5.0};
  CHECK(crop.sample_linear(w) == doctest::Approx(crop.at(25, 15, 5)));
  const double far[3] = {1000, 15, 5};
  CHECK_FALSE(crop.inside_index(far));
  CHECK(crop.sample_index(far) == doctest::Approx(crop.at(crop.data_hi()[0] - 1, 15, 5)));
}

TEST_CASE("smoothing: a crop over max_voxels fails and names the size it needs") {
  TestVolume<float> v = edge_volume(0, 3);
  SmoothedRoi roi;
  Carved mem([&](Arena& a) { roi.carve(a, 1000, kCpu); });
  REQUIRE(mem.ok);
  SmoothingSettings s;
  s.iterations = 2;
  const int64_t lo[3] = {0, 0, 0}, hi[3] = {20, 20, 5};
  char msg[512] = {};
  CHECK(roi.compute(v.view, lo, hi, s, msg, sizeof msg) == RoiStatus::too_large);
  CHECK(roi.needed_voxels() == 22 * 22 * 7);
  CHECK(std::string(msg).find("3388") != std::string::npos);
  CHECK(std::string(msg).find("1000") != std::string::npos);
  CHECK_FALSE(roi.valid());
  // Empty and off-grid boxes.
  const int64_t olo[3] = {70, 0, 0}, ohi[3] = {80, 5, 5};
  CHECK(roi.compute(v.view, olo, ohi, s) == RoiStatus::empty);
  // Not carved over real memory.
  SmoothedRoi bare;
  CHECK(bare.compute(v.view, lo, hi, s) == RoiStatus::too_large);
  const int64_t tiny_hi[3] = {1, 1, 1};
  SmoothingSettings none;
  none.iterations = 0;
  CHECK(bare.compute(v.view, lo, tiny_hi, none) == RoiStatus::too_large);  // max_voxels 0
}

namespace {

// Robust spread (IQR / 1.349) of x.
double robust_sd(std::vector<double> x) {
  std::sort(x.begin(), x.end());
  auto q = [&](double f) { return x[size_t(f * double(x.size() - 1) + 0.5)]; };
  return (q(0.75) - q(0.25)) / 1.349;
}

// White noise (sd 10 about 50) on an nc^3 grid of 3 mm voxels, and the same
// scan trilinearly resampled f[a] times finer along axis a (the shared CT's
// 1 mm grid is made so with f = 3, 3, 3). fine: the resampled values.
struct ResampledNoise {
  TestVolume<float> coarse, fine;
  std::vector<double> values;
  int64_t nf[3];
  ResampledNoise(int64_t nc, const int f[3], uint64_t seed)
      : coarse(nc, nc, nc, 3, 3, 3),
        fine(f[0] * (nc - 1) + 1, f[1] * (nc - 1) + 1, f[2] * (nc - 1) + 1, 3.0 / f[0], 3.0 / f[1], 3.0 / f[2]) {
    Rng rng(seed);
    std::vector<double> c(size_t(nc * nc * nc));
    for (double& x : c) x = 50 + 10 * rng.normal();
    auto c_at = [&](int64_t i, int64_t j, int64_t k) { return c[size_t(i + nc * (j + nc * k))]; };
    for (int64_t k = 0; k < nc; ++k)
      for (int64_t j = 0; j < nc; ++j)
        for (int64_t i = 0; i < nc; ++i) coarse.at(i, j, k) = float(c_at(i, j, k));
    for (int a = 0; a < 3; ++a) nf[a] = f[a] * (nc - 1) + 1;
    for (int64_t k = 0; k < nf[2]; ++k)
      for (int64_t j = 0; j < nf[1]; ++j)
        for (int64_t i = 0; i < nf[0]; ++i) {
          const int64_t p[3] = {i, j, k};
          int64_t b[3];
          double t[3];
          for (int a = 0; a < 3; ++a) {
            b[a] = std::min<int64_t>(p[a] / f[a], nc - 2);
            t[a] = double(p[a] - f[a] * b[a]) / f[a];
          }
          double v = 0;
          for (int q = 0; q < 8; ++q) {
            double w = 1;
            int64_t r[3];
            for (int a = 0; a < 3; ++a) {
              const int bit = (q >> a) & 1;
              w *= bit ? t[a] : 1 - t[a];
              r[a] = b[a] + bit;
            }
            v += w * c_at(r[0], r[1], r[2]);
          }
          fine.at(i, j, k) = float(v);
          values.push_back(v);
        }
    coarse.finish(VoxelType::F32);
    fine.finish(VoxelType::F32);
  }
};

}  // namespace

TEST_CASE("smoothing, intensity: noise resampled onto a finer grid is measured where it decorrelates") {
  const int64_t nc = 22, nf = 3 * (nc - 1) + 1;
  const int f3[3] = {3, 3, 3};
  ResampledNoise scan(nc, f3, 11);
  const TestVolume<float>&c3 = scan.coarse, &f1 = scan.fine;
  const std::vector<double>& fine = scan.values;
  SmoothedRoi roi;
  Carved mem([&](Arena& a) { roi.carve(a, nf * nf * nf, kCpu); });
  REQUIRE(mem.ok);
  IntensityModel model;
  Carved mm([&](Arena& a) { model.carve(a, 65536, kCpu); });
  REQUIRE(mm.ok);

  // The scan's own grid: the lag-1 differences see the noise, and the
  // decorrelated estimate is theirs.
  const int64_t lo[3] = {0, 0, 0}, hic[3] = {nc, nc, nc}, hif[3] = {nf, nf, nf};
  REQUIRE(roi.compute(c3.view, lo, hic, SmoothingSettings()) == RoiStatus::ok);
  CHECK(roi.noise_sigma() == doctest::Approx(10).epsilon(0.15));
  CHECK(roi.decorrelated_noise_sigma() == roi.noise_sigma());
  CHECK(roi.acquisition_gain() == 1.0);
  CHECK(roi.acquisition_scale() == 1.0);

  // Resampled: the lag-1 differences read a fraction of the field's spread;
  // the decorrelated estimate is of its order, and the floor reads it.
  REQUIRE(roi.compute(f1.view, lo, hif, SmoothingSettings()) == RoiStatus::ok);
  const double spread = robust_sd(fine);  // about 6: the weights' average of the noise
  CAPTURE(spread);
  CAPTURE(roi.noise_sigma());
  CAPTURE(roi.decorrelated_noise_sigma());
  CHECK(roi.noise_sigma() < 0.5 * spread);
  CHECK(roi.decorrelated_noise_sigma() > 0.7 * spread);
  CHECK(roi.decorrelated_noise_sigma() < 1.5 * spread);
  // The scanner's noise (sd 10) is more than the resampled grid holds;
  // the acquisition gain (linear interpolation over three axes) takes the
  // estimate most of the way back to it.
  CAPTURE(roi.acquisition_gain());
  CHECK(roi.decorrelated_noise_sigma() < 0.65 * 10);
  CHECK(roi.acquisition_gain() * roi.decorrelated_noise_sigma() > 0.7 * 10);
  CHECK(roi.acquisition_gain() * roi.decorrelated_noise_sigma() < 1.15 * 10);
  // One acquired sample spans the lag's grid samples: 3 mm of 1 mm voxels.
  CAPTURE(roi.noise_lag());
  CHECK(roi.acquisition_scale() == double(roi.noise_lag()));
  CHECK(roi.acquisition_scale() >= 2.0);
  CHECK(roi.acquisition_scale() <= 4.0);
  const double c[3] = {31, 31, 31};
  REQUIRE(model.fit(roi, c, 12, IntensityModelSettings(), nullptr, 0, &f1.view) == ModelStatus::ok);
  CHECK(model.sigma_floor() > 0.7 * spread);
  // The sphere's spread caps it at the acquired samples' own positions (one
  // phase of the resampling), where the noise is whole: the floor reaches
  // the scanner's noise, not the resampled grid's spread (about 6).
  CAPTURE(model.sigma_floor());
  CHECK(model.sigma_floor() > 0.75 * 10);
  // Without the raw volume the sphere's spread is unknown: the lag-1 noise.
  REQUIRE(model.fit(roi, c, 12, IntensityModelSettings()) == ModelStatus::ok);
  CHECK(model.sigma_floor() < 0.5 * spread + 0.04 * (roi.contrast_high() - roi.contrast_low()));
}

TEST_CASE("smoothing: noise resampled along one axis only is measured where it decorrelates") {
  // Thick slices reformatted into thin ones: 3 x 3 x 3 mm voxels resampled
  // to 3 x 3 x 1. Along z the lag-1 differences read a fraction of the
  // noise, along x and y all of it (at the slices' own positions) or most.
  const int64_t nc = 22;
  const int fz[3] = {1, 1, 3};
  ResampledNoise scan(nc, fz, 12);
  SmoothedRoi roi;
  Carved mem([&](Arena& a) { roi.carve(a, scan.nf[0] * scan.nf[1] * scan.nf[2], kCpu); });
  REQUIRE(mem.ok);
  // The box one slice short of the grid: its statistics lattice (step 3
  // here, box_lattice.h) then holds voxels of two of the three phases of
  // the resampling.
  const int64_t lo[3] = {0, 0, 0}, hi[3] = {scan.nf[0], scan.nf[1], scan.nf[2] - 1};
  REQUIRE(roi.compute(scan.fine.view, lo, hi, SmoothingSettings()) == RoiStatus::ok);
  const double spread = robust_sd(scan.values);  // about 8: the slices' weights' average of the noise
  CAPTURE(spread);
  CAPTURE(roi.noise_sigma());
  CAPTURE(roi.decorrelated_noise_sigma());
  CHECK(roi.noise_sigma() < 0.5 * spread);  // the smallest lag-1 scale: z's
  // z decorrelates at lag 2 here (its increments' correlation is -1/2 about
  // a thick slice's own position and +1/2 about the second fine one, 0 in
  // the mix), where its scale is 0.6 of the field's spread; x and y read
  // the spread at lag 1. Before the axes were read one by one (the gate
  // was a median over them), the estimate was the lag-1 one, 0.38 of it.
  CHECK(roi.decorrelated_noise_sigma() > 0.55 * spread);
  CHECK(roi.decorrelated_noise_sigma() > 1.5 * roi.noise_sigma());
  CHECK(roi.decorrelated_noise_sigma() < 1.5 * spread);
  // One axis interpolated: a gain above 1, below the three axes' (above).
  CAPTURE(roi.acquisition_gain());
  CHECK(roi.acquisition_gain() > 1.1);
  CHECK(roi.acquisition_gain() < 1.25);
  // 3 x 3 x 1 mm voxels, z read at lag 2: the finest acquired spacing is
  // z's 2 mm as read, two grid samples.
  CHECK(roi.acquisition_scale() == double(roi.noise_lag()));
  CHECK(roi.acquisition_scale() >= 2.0);
  CHECK(roi.acquisition_scale() <= 3.0);
  // The whole grid: its lattice (step 3 from either end of 64 slices) holds
  // only voxels on the thick slices' own positions, where the increments
  // either side are independent (white noise of a third of the spread to
  // all appearances); the voxels beside them show the interpolation.
  SmoothedRoi whole;
  Carved wmem([&](Arena& a) { whole.carve(a, scan.nf[0] * scan.nf[1] * scan.nf[2], kCpu); });
  REQUIRE(wmem.ok);
  REQUIRE(whole.compute(scan.fine.view, lo, scan.nf, SmoothingSettings()) == RoiStatus::ok);
  CAPTURE(whole.decorrelated_noise_sigma());
  CHECK(whole.noise_sigma() < 0.5 * spread);
  CHECK(whole.decorrelated_noise_sigma() > 0.55 * spread);
  CHECK(whole.decorrelated_noise_sigma() < 1.5 * spread);
  // The same noise stored with its axes permuted reads the same.
  TestVolume<float> perm(scan.nf[2], scan.nf[0], scan.nf[1], 1, 3, 3);
  for (int64_t k = 0; k < scan.nf[2]; ++k)
    for (int64_t j = 0; j < scan.nf[1]; ++j)
      for (int64_t i = 0; i < scan.nf[0]; ++i) perm.at(k, i, j) = scan.fine.at(i, j, k);
  perm.finish(VoxelType::F32);
  const int64_t phi[3] = {scan.nf[2] - 1, scan.nf[0], scan.nf[1]};
  SmoothedRoi proi;
  Carved pmem([&](Arena& a) { proi.carve(a, scan.nf[0] * scan.nf[1] * scan.nf[2], kCpu); });
  REQUIRE(pmem.ok);
  REQUIRE(proi.compute(perm.view, lo, phi, SmoothingSettings()) == RoiStatus::ok);
  CHECK(proi.decorrelated_noise_sigma() == doctest::Approx(roi.decorrelated_noise_sigma()).epsilon(0.05));
  CHECK(proi.acquisition_gain() == doctest::Approx(roi.acquisition_gain()));
}

TEST_CASE("smoothing, intensity: non-finite voxels neither spread nor reach the model") {
  TestVolume<float> v = edge_volume(0, 5);
  v.at(10, 10, 5) = NAN;
  v.at(40, 20, 6) = INFINITY;
  v.at(41, 20, 6) = -INFINITY;
  v.finish(VoxelType::F32);
  SmoothedRoi roi;
  Carved mem([&](Arena& a) { roi.carve(a, 64 * 64 * 12, kCpu); });
  const int64_t lo[3] = {0, 0, 0}, hi[3] = {64, 64, 12};
  REQUIRE(roi.compute(v.view, lo, hi, SmoothingSettings()) == RoiStatus::ok);
  bool finite = true;
  for (int64_t k = 0; k < 12; ++k)
    for (int64_t j = 0; j < 64; ++j)
      for (int64_t i = 0; i < 64; ++i) finite = finite && std::isfinite(roi.at(i, j, k));
  CHECK(finite);
  CHECK(roi.noise_sigma() == doctest::Approx(10).epsilon(0.15));
  IntensityModel model;
  Carved mm([&](Arena& a) { model.carve(a, 4096, kCpu); });
  const double c[3] = {12 * 0.7, 10 * 0.7, 5 * 5.0};
  REQUIRE(model.fit(roi, c, 6, IntensityModelSettings()) == ModelStatus::ok);
  CHECK(std::isfinite(model.component(0).mean));
  std::vector<float> x = {1, NAN, 2, 3, INFINITY};
  REQUIRE(model.fit_samples(x.data(), 5, 1.0, IntensityModelSettings()) == ModelStatus::ok);
  CHECK(model.component(0).mean == doctest::Approx(2));
}

TEST_CASE("intensity: a finite sphere whose index box overflows is refused, not converted") {
  // Centre and radius near DBL_MAX: in index units both are infinite, the
  // box's bounds NaN (inf - inf). Found by fuzz_calls' soak (UBSan: NaN
  // converted to int64_t); the box is now compared before any conversion.
  TestVolume<float> v = edge_volume(0, 5);
  v.finish(VoxelType::F32);
  SmoothedRoi roi;
  Carved mem([&](Arena& a) { roi.carve(a, 64 * 64 * 12, kCpu); });
  const int64_t lo[3] = {0, 0, 0}, hi[3] = {64, 64, 12};
  REQUIRE(roi.compute(v.view, lo, hi, SmoothingSettings()) == RoiStatus::ok);
  IntensityModel model;
  Carved mm([&](Arena& a) { model.carve(a, 4096, kCpu); });
  char msg[160] = "";
  for (double s : {1.0, -1.0}) {
    const double c[3] = {s * 1.7e308, 7, 25};
    CHECK(model.fit(roi, c, 1.7e308, IntensityModelSettings(), msg, sizeof msg) == ModelStatus::no_samples);
    CHECK(std::string(msg).find("does not meet") != std::string::npos);
    CHECK_FALSE(model.valid());
  }
  const double c[3] = {12 * 0.7, 10 * 0.7, 5 * 5.0};
  CHECK(model.fit(roi, c, 6, IntensityModelSettings()) == ModelStatus::ok);  // the model still fits afterwards
}

TEST_CASE("smoothing, intensity: measuring pass and real pass carve the same bytes") {
  for (int64_t maxv : {int64_t(1), int64_t(1000), int64_t(123457), int64_t(1) << 22}) {
    for (uint32_t cap : {1u, 4096u, 65536u}) {
      SmoothedRoi roi;
      IntensityModel model;
      Carved c([&](Arena& a) {
        roi.carve(a, maxv, kCpu);
        model.carve(a, cap, kCpu);
      });
      CHECK(c.ok);
      CHECK(c.measured == c.real);
      CHECK(c.measured >= size_t(maxv) * 4 + size_t(cap) * 4 + IntensityModel::kLutMax * 4);
    }
  }
  // Plane capacity bounds every plane of every region that fits.
  for (int64_t maxv : {int64_t(8), int64_t(1000), int64_t(999999)}) {
    const int64_t cap = SmoothedRoi::plane_capacity(maxv);
    for (int64_t a = 1; a <= 200; ++a)
      for (int64_t b = a; b <= 200; ++b) {
        const int64_t c = maxv / (a * b);
        if (c < b) break;
        CHECK(a * b <= cap);
      }
  }
}

TEST_CASE("binning: Algorithm 2 finds 1, 2 and 3 components") {
  const uint32_t n = 6000;
  BinningSettings s;
  s.radius = 10;
  s.separation = 20;
  s.min_count = 60;
  Bin bins[16];
  {
    auto x = mixture_samples(n, {{1.0, 100, 25}}, 1);
    CHECK(adaptive_binning(kCpu, x.data(), n, s, bins, 16, mixing_stride(n)) == 1);
    CHECK(bins[0].centroid == doctest::Approx(100).epsilon(0.02));
    // Visiting order matters for Algorithm 2: the mixing stride also copes with sorted input.
    std::sort(x.begin(), x.end());
    CHECK(adaptive_binning(kCpu, x.data(), n, s, bins, 16, mixing_stride(n)) == 1);
  }
  {
    auto x = mixture_samples(n, {{0.5, 100, 25}, {0.5, 160, 25}}, 2);
    REQUIRE(adaptive_binning(kCpu, x.data(), n, s, bins, 16, mixing_stride(n)) == 2);
    CHECK(bins[0].centroid == doctest::Approx(100).epsilon(0.03));
    CHECK(bins[1].centroid == doctest::Approx(160).epsilon(0.03));
  }
  {
    auto x = mixture_samples(n, {{0.3, 50, 16}, {0.4, 100, 25}, {0.3, 170, 36}}, 3);
    REQUIRE(adaptive_binning(kCpu, x.data(), n, s, bins, 16, mixing_stride(n)) == 3);
    CHECK(bins[0].centroid == doctest::Approx(50).epsilon(0.05));
    CHECK(bins[1].centroid == doctest::Approx(100).epsilon(0.05));
    CHECK(bins[2].centroid == doctest::Approx(170).epsilon(0.05));
    // N_m removes a small cluster: 0.5% of the samples (about 30) far away.
    auto y = mixture_samples(n, {{0.995, 100, 25}, {0.005, 200, 25}}, 4);
    CHECK(adaptive_binning(kCpu, y.data(), n, s, bins, 16, mixing_stride(n)) == 1);
    s.min_count = 15;
    CHECK(adaptive_binning(kCpu, y.data(), n, s, bins, 16, mixing_stride(n)) == 2);
  }
  // The model's automatic settings (R = 2, S = 4 sigma_floor) on the same mixtures.
  IntensityModel model;
  Carved mem([&](Arena& a) { model.carve(a, 1024, kCpu); });
  IntensityModelSettings ms;
  for (int k = 1; k <= 3; ++k) {
    std::vector<Gaussian1> c;
    for (int i = 0; i < k; ++i) c.push_back({1.0 / k, 100.0 + 60.0 * i, 16});
    auto x = mixture_samples(n, c, 10 + uint64_t(k));
    REQUIRE(model.fit_samples(x.data(), n, 4.0, ms) == ModelStatus::ok);
    CHECK(model.bins_found() == uint32_t(k));
    CHECK(model.components() == uint32_t(k));
  }
}

TEST_CASE("EM: recovers the means, variances and weights of known mixtures") {
  const uint32_t n = 40000;
  {
    auto x = mixture_samples(n, {{0.6, 100, 64}, {0.4, 140, 36}}, 21);
    Gaussian1 c[2] = {{0.5, 90, 100}, {0.5, 150, 100}};
    uint32_t m = 2;
    EmResult r = em_fit(kCpu, x.data(), n, c, &m, 500, 0);
    REQUIRE(m == 2);
    CHECK(r.iterations > 1);
    CHECK(c[0].mean == doctest::Approx(100).epsilon(0.005));
    CHECK(c[1].mean == doctest::Approx(140).epsilon(0.005));
    CHECK(c[0].var == doctest::Approx(64).epsilon(0.06));
    CHECK(c[1].var == doctest::Approx(36).epsilon(0.06));
    CHECK(c[0].weight == doctest::Approx(0.6).epsilon(0.03));
    CHECK(c[1].weight == doctest::Approx(0.4).epsilon(0.03));
  }
  {
    // Through the model: binning initialises EM, no floor.
    auto x = mixture_samples(n, {{0.25, 40, 9}, {0.5, 80, 25}, {0.25, 130, 49}}, 22);
    IntensityModel model;
    Carved mem([&](Arena& a) { model.carve(a, 16, kCpu); });
    IntensityModelSettings s;
    s.bin_radius = 8;
    s.bin_separation = 18;
    s.em_iterations = 500;
    REQUIRE(model.fit_samples(x.data(), n, 0.0, s) == ModelStatus::ok);
    REQUIRE(model.components() == 3);
    const double mu[3] = {40, 80, 130}, var[3] = {9, 25, 49}, w[3] = {0.25, 0.5, 0.25};
    for (uint32_t i = 0; i < 3; ++i) {
      CHECK(model.component(i).mean == doctest::Approx(mu[i]).epsilon(0.01));
      CHECK(model.component(i).var == doctest::Approx(var[i]).epsilon(0.08));
      CHECK(model.component(i).weight == doctest::Approx(w[i]).epsilon(0.04));
    }
    // g is the peak-normalised mixture: 1 at the main mode, small far away.
    CHECK(model.g(80) == doctest::Approx(1).epsilon(0.02));
    CHECK(model.g(300) < 1e-6);
  }
  {
    // The variance floor: a narrow sample (sd 1) is widened to the floor (sd 5).
    auto x = mixture_samples(5000, {{1.0, 50, 1}}, 23);
    IntensityModel model;
    Carved mem([&](Arena& a) { model.carve(a, 16, kCpu); });
    REQUIRE(model.fit_samples(x.data(), 5000, 5.0, IntensityModelSettings()) == ModelStatus::ok);
    REQUIRE(model.components() == 1);
    CHECK(model.component(0).var == doctest::Approx(25));
    CHECK(model.g(50 + 2 * 5.0) == doctest::Approx(std::exp(-2.0)).epsilon(0.01));
  }
}

TEST_CASE("EM over binned samples (the scene fit) agrees with EM over the samples; the bins keep count and moments") {
  const uint32_t n = 16384;
  auto x = mixture_samples(n, {{0.3, 40, 16}, {0.5, 80, 25}, {0.2, 130, 49}}, 31);
  x[17] = NAN;  // non-finite samples are skipped by both
  x[900] = INFINITY;
  std::vector<double> hist(3 * size_t(IntensityModel::kCompressBins));
  {
    // The bins: every finite sample counted once, means and sums of squares
    // giving back the samples' first and second moments.
    const double shift = 80, width = 0.2;
    double* v = hist.data();
    double* w = v + IntensityModel::kCompressBins;
    double* ss = w + IntensityModel::kCompressBins;
    const uint32_t nb = compress_samples(x.data(), n, shift, width, v, w, ss);
    REQUIRE(nb > 100);
    REQUIRE(nb <= IntensityModel::kCompressBins);
    double count = 0, s1 = 0, s2 = 0, e1 = 0, e2 = 0;
    for (uint32_t b = 0; b < nb; ++b) {
      count += w[b];
      s1 += w[b] * v[b];
      s2 += w[b] * v[b] * v[b] + ss[b];
      CHECK(ss[b] >= 0);
      CHECK(ss[b] <= w[b] * width * width / 4 + 1e-9);  // the spread of a bin's samples about their mean
      if (b) CHECK(v[b] > v[b - 1]);
    }
    for (uint32_t j = 0; j < n; ++j)
      if (std::isfinite(x[j])) e1 += x[j] - shift, e2 += (x[j] - shift) * (x[j] - shift);
    CHECK(count == n - 2);
    CHECK(s1 == doctest::Approx(e1).epsilon(1e-9));
    CHECK(s2 == doctest::Approx(e2).epsilon(1e-9));
    // Too fine a width for the bins there are: wider bins, all samples kept.
    const uint32_t nc = compress_samples(x.data(), n, shift, 1e-6, v, w, ss);
    double c2 = 0;
    for (uint32_t b = 0; b < nc; ++b) c2 += w[b];
    CHECK(nc <= IntensityModel::kCompressBins);
    CHECK(c2 == n - 2);
  }
  // EM from the same start, 200 iterations, a floor of sd 3: bins a 32nd of
  // the floor wide move no parameter by more than a thousandth of the floor.
  const Gaussian1 start[3] = {{0.3, 35, 30}, {0.4, 85, 30}, {0.3, 120, 30}};
  Gaussian1 a[3] = {start[0], start[1], start[2]}, b[3] = {start[0], start[1], start[2]};
  uint32_t ma = 3, mb = 3;
  em_fit(kCpu, x.data(), n, a, &ma, 200, 9.0);
  const uint32_t nb = em_fit_compressed(kCpu, x.data(), n, b, &mb, 200, 9.0, 3.0 / 32, hist.data());
  CHECK(nb < n / 4);
  REQUIRE(ma == 3);
  REQUIRE(mb == 3);
  for (int i = 0; i < 3; ++i) {
    CHECK(std::fabs(a[i].mean - b[i].mean) < 3e-3);
    CHECK(std::fabs(a[i].var - b[i].var) < 9e-3 * a[i].var);
    CHECK(std::fabs(a[i].weight - b[i].weight) < 1e-4);
  }
  CHECK(b[1].mean == doctest::Approx(80).epsilon(0.01));
  // Bins as wide as the gaps between the classes do move them (keeping each
  // bin's spread makes bins up to a few floors wide nearly as good): the
  // comparison can tell.
  Gaussian1 c[3] = {start[0], start[1], start[2]};
  uint32_t mc = 3;
  em_fit_compressed(kCpu, x.data(), n, c, &mc, 200, 9.0, 30.0, hist.data());
  double worst = 0;
  for (uint32_t i = 0; i < mc && i < 3; ++i) worst = std::max(worst, std::fabs(c[i].var - a[i].var) / a[i].var);
  CHECK(worst > 9e-3);
}

TEST_CASE("intensity: the table gives the direct g, and the same g whatever the scale of the values") {
  IntensityModel model;
  Carved mem([&](Arena& a) { model.carve(a, 16, kCpu); });
  IntensityModelSettings s;
  auto worst_error = [&](double lo, double hi, double step) {
    double worst = 0;
    for (double v = lo; v <= hi; v += step) worst = std::max(worst, std::fabs(model.g(v) - model.g_direct(v)));
    return worst;
  };
  {
    auto x = mixture_samples(5000, {{0.7, 120, 100}, {0.3, 160, 64}}, 31);
    REQUIRE(model.fit_samples(x.data(), 5000, 3.0, s) == ModelStatus::ok);
    CHECK(model.has_lut());
    CHECK(worst_error(0, 255, 0.37) < 1e-3);
    CHECK(model.g(-500) == 0.0);  // beyond the table: 0, where g_direct is negligible
    CHECK(model.g_direct(-500) < 1e-40);
    CHECK(model.g(NAN) == 0.0);
  }
  {
    // CT: one class at 60 HU, sd 15.
    auto x = mixture_samples(5000, {{1.0, 60, 225}}, 32);
    REQUIRE(model.fit_samples(x.data(), 5000, 0.0, s) == ModelStatus::ok);
    CHECK(model.has_lut());
    CHECK(worst_error(-1100, 2000, 0.23) < 1e-3);
    CHECK(model.g(60) > 0.95);
    CHECK(model.g(-100) < 1e-6);
  }
  {
    // A narrow float class (sd 0.1) is tabulated finely enough too.
    auto x = mixture_samples(100, {{1.0, 0.5, 0.01}}, 33);
    REQUIRE(model.fit_samples(x.data(), 100, 0.0, s) == ModelStatus::ok);
    CHECK(model.has_lut());
    CHECK(worst_error(-1, 2, 0.0013) < 1e-3);
  }
}

namespace {

// CT-like ball: 60 HU inside radius 15 mm, -100 HU outside, noise sigma 15 HU,
// stored as i16 raw = HU + 1024 (slope 1, intercept -1024), 0.8 x 0.8 x 1.6 mm.
struct CtBall {
  TestVolume<int16_t> v{64, 64, 32, 0.8, 0.8, 1.6};
  double c[3] = {25.6, 25.6, 25.6};
  double R = 15;
  CtBall() {
    Rng rng(99);
    for (int64_t k = 0; k < 32; ++k)
      for (int64_t j = 0; j < 64; ++j)
        for (int64_t i = 0; i < 64; ++i) {
          double w[3];
          v.world(i, j, k, w);
          const double d = std::sqrt((w[0] - c[0]) * (w[0] - c[0]) + (w[1] - c[1]) * (w[1] - c[1]) +
                                     (w[2] - c[2]) * (w[2] - c[2]));
          const double hu = (d <= R ? 60.0 : -100.0) + 15.0 * rng.normal();
          v.at(i, j, k) = int16_t(std::lround(hu + 1024));
        }
    v.finish(VoxelType::I16, 1.0, -1024.0);
  }
};

// n points on a sphere (Fibonacci), with outward unit normals.
void fibonacci(const double c[3], double r, uint32_t n, std::vector<double>* x, std::vector<double>* nrm) {
  x->resize(3 * n);
  nrm->resize(3 * n);
  for (uint32_t i = 0; i < n; ++i) {
    const double z = 1 - 2 * (i + 0.5) / n, rho = std::sqrt(1 - z * z);
    const double phi = 2.399963229728653 * i;
    const double d[3] = {rho * std::cos(phi), rho * std::sin(phi), z};
    for (int a = 0; a < 3; ++a) {
      (*nrm)[3 * i + a] = d[a];
      (*x)[3 * i + a] = c[a] + r * d[a];
    }
  }
}

}  // namespace

TEST_CASE("intensity: search finds a noisy CT ball's boundary from inside (outward) and outside (inward)") {
  CtBall ball;
  SmoothedRoi roi;
  IntensityModel model;
  Carved mem([&](Arena& a) {
    roi.carve(a, int64_t(1) << 20, kCpu);
    model.carve(a, 4096, kCpu);
  });
  REQUIRE(mem.ok);
  const double range = 12;
  int64_t lo[3], hi[3];
  roi_box_for_ball(ball.v.view, ball.c, 20 + range, lo, hi);
  SmoothingSettings ss;
  char msg[256] = {};
  REQUIRE(roi.compute(ball.v.view, lo, hi, ss, msg, sizeof msg) == RoiStatus::ok);
  CHECK(roi.noise_sigma() == doctest::Approx(15).epsilon(0.2));
  REQUIRE(model.fit(roi, ball.c, 8, IntensityModelSettings(), msg, sizeof msg) == ModelStatus::ok);
  CHECK(model.has_lut());
  CHECK(model.sample_count() <= 4096);
  CHECK(model.components() == 1);
  CHECK(model.component(0).mean == doctest::Approx(60).epsilon(0.05));
  MESSAGE("model: mean " << model.component(0).mean << " sd " << std::sqrt(model.component(0).var) << " floor "
                         << model.sigma_floor() << " kappa " << roi.kappa());
  CHECK(model.g(60) > 0.9);
  CHECK(model.g(-100) < 0.05);

  IntensitySearchSettings s;
  s.gamma = 0.05;  // a low level: these cases test the search, not the model's threshold
  s.range_mm = range;
  for (double r0 : {10.0, 20.0}) {
    CAPTURE(r0);
    const uint32_t nv = 600;
    std::vector<double> x, nrm, target(3 * nv);
    std::vector<uint8_t> has(nv);
    fibonacci(ball.c, r0, nv, &x, &nrm);
    const uint32_t found = search_intensity(roi, model, nv, x.data(), nrm.data(), s, target.data(), has.data());
    CHECK(found >= nv * 98 / 100);
    double sum = 0, worst = 0;
    uint32_t within = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      if (!has[v]) continue;
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += (target[3 * v + a] - ball.c[a]) * (target[3 * v + a] - ball.c[a]);
      const double err = std::fabs(std::sqrt(d2) - ball.R);
      sum += err;
      worst = std::max(worst, err);
      within += err <= 0.8;
    }
    MESSAGE("from r = " << r0 << ": found " << found << "/" << nv << ", mean |error| " << sum / found
                        << " mm, worst " << worst << " mm");
    CHECK(sum / found < 0.4);
    CHECK(within >= found * 95 / 100);  // within the finest voxel
    CHECK(worst <= 1.6);                // within the coarsest voxel
  }
  // Out of range: from r = 2 a 6 mm search cannot reach the boundary.
  {
    std::vector<double> x, nrm, target(3 * 50);
    std::vector<uint8_t> has(50);
    fibonacci(ball.c, 2, 50, &x, &nrm);
    IntensitySearchSettings shortr = s;
    shortr.range_mm = 6;
    CHECK(search_intensity(roi, model, 50, x.data(), nrm.data(), shortr, target.data(), has.data()) == 0);
  }
}

// A ball 6 mm across at 100 (noise sd 10, 1 mm voxels) in a box whose
// other voxels are given by outside(i), noise drawn from seed: the model
// fitted from a sphere 2.5 mm in radius at its centre.
struct BoxFit {
  TestVolume<float> v{41, 41, 41, 1.0, 1.0, 1.0};
  SmoothedRoi roi;
  IntensityModel model;
  // The crop's and the model's memory, held as long as the model is read.
  Carved mem{[this](Arena& a) {
    roi.carve(a, 41 * 41 * 41, kCpu);
    model.carve(a, 4096, kCpu);
  }};
  template <class Outside>
  explicit BoxFit(Outside outside, uint64_t seed = 78) {
    Rng rng(seed);
    for (int64_t k = 0; k < 41; ++k)
      for (int64_t j = 0; j < 41; ++j)
        for (int64_t i = 0; i < 41; ++i) {
          const double d2 = double((i - 20) * (i - 20) + (j - 20) * (j - 20) + (k - 20) * (k - 20));
          v.at(i, j, k) = float((d2 <= 9.0 ? 100.0 : outside(i)) + 10.0 * rng.normal());
        }
    REQUIRE(v.finish(VoxelType::F32));
    REQUIRE(mem.ok);
    const int64_t lo[3] = {0, 0, 0}, hi[3] = {41, 41, 41};
    SmoothingSettings ss;
    ss.stats_lo = lo;
    ss.stats_hi = hi;
    REQUIRE(roi.compute(v.view, lo, hi, ss) == RoiStatus::ok);
    const double c[3] = {20, 20, 20};
    REQUIRE(model.fit(roi, c, 2.5, IntensityModelSettings()) == ModelStatus::ok);
  }
};

TEST_CASE("intensity: a small object's class, too rare for a bin of the scene, still has the background as its rival") {
  // A ball 6 mm across at 100 in a flat background at 0 (noise sd 10), 1 mm
  // voxels: in the statistics box (20 mm around the centre) the ball is
  // 0.2% of the voxels, below binning's minimum share, so the scene fit finds
  // the background alone. That class does not explain the object's mean (it
  // would not accept 100), so it competes: the Bayes cut and the
  // partial-volume level see it. (It was counted as the object's own class,
  // leaving no competitor.)
  BoxFit fit([](int64_t) { return 0.0; }, 77);
  const IntensityModel& model = fit.model;
  REQUIRE(model.components() == 1);
  CHECK(model.component(0).mean == doctest::Approx(100).epsilon(0.1));
  REQUIRE(model.competitors() == 1);
  CHECK(std::fabs(model.competitor(0).mean) < 5);
  double rival = -1;
  CHECK(model.rival_mean(2.0, &rival));
  CHECK(std::fabs(rival) < 5);
  // The object's scene weight is binning's minimum share (5% of the scene's
  // samples, rounded up), not the background's.
  CHECK(model.object_scene_weight() < 0.051);
  CHECK(model.g(100) > 0.9);
  CHECK(model.g(50) < 0.2);  // past the densities' crossing the background wins
}

TEST_CASE("intensity: the boundary is in view where the object's grey level is rare in its box and no rival overlaps it") {
  // A small ball of its own contrast (a tube's or a horn's case): in view.
  BoxFit alone([](int64_t) { return 0.0; });
  CHECK(alone.model.rival_share(0.2) < 0.01);
  CHECK(alone.model.boundary_in_view());
  // The object's grey level fills the box (an organ of soft tissue among
  // others of its level): nothing outside it is seen.
  BoxFit filled([](int64_t) { return 100.0; });
  CHECK(filled.model.object_scene_weight() > 0.9);
  CHECK_FALSE(filled.model.boundary_in_view());
  // Rare, but half the box lies three noise sd away (a nucleus beside white
  // matter): the rivals hold much of what the object accepts.
  BoxFit near([](int64_t i) { return i < 20 ? 0.0 : 130.0; });
  CHECK(near.model.object_scene_weight() < IntensityModel::kRareShare);
  CHECK(near.model.g(100) > 0.5);
  CHECK(near.model.rival_share(0.2) > IntensityModel::kRivalShare);
  CHECK_FALSE(near.model.boundary_in_view());
  // Two and a half sd away the half box's class would be more probable than
  // the object at the object's own mean (the object's scene weight is only
  // binning's minimum share): it counts as the object's own instead, so the
  // object still accepts its own grey level, and is not rare.
  BoxFit nearer([](int64_t i) { return i < 20 ? 0.0 : 125.0; });
  CHECK(nearer.model.object_scene_weight() > 0.5);
  CHECK(nearer.model.g(100) > 0.5);
  CHECK_FALSE(nearer.model.boundary_in_view());
  // Without a scene (fit_samples) nothing is in view.
  IntensityModel bare;
  Carved mem([&](Arena& a) { bare.carve(a, 64, kCpu); });
  REQUIRE(mem.ok);
  const float x[4] = {99, 100, 101, 100};
  REQUIRE(bare.fit_samples(x, 4, 10.0, IntensityModelSettings()) == ModelStatus::ok);
  CHECK_FALSE(bare.boundary_in_view());
}

TEST_CASE("intensity: a few percent of air in the box does not widen the model (the contrast within Tukey's fences)") {
  // A CT-like scene at 3 mm: a fluid ball of 5 HU (radius 12 mm) in a 45 HU
  // organ, a -100 HU fat slab, and a gas pocket of -1000 HU holding about 6%
  // of the statistics box; noise sigma 12 HU. The floor must follow the soft
  // tissues' contrast (about 150 HU), not the air's (1,000 HU): with the old
  // p1..p99 range the floor was about 42 HU and g(45) read above 0.6, so the
  // fluid took the organ around it (the gallbladder of issue 30).
  TestVolume<int16_t> v(40, 40, 40, 3, 3, 3);
  const double c[3] = {60, 60, 60};
  Rng rng(7);
  for (int64_t k = 0; k < 40; ++k)
    for (int64_t j = 0; j < 40; ++j)
      for (int64_t i = 0; i < 40; ++i) {
        double w[3];
        v.world(i, j, k, w);
        const double d = std::sqrt((w[0] - c[0]) * (w[0] - c[0]) + (w[1] - c[1]) * (w[1] - c[1]) +
                                   (w[2] - c[2]) * (w[2] - c[2]));
        double hu = d <= 12 ? 5 : 45;
        if (w[0] > 75) hu = -100;
        if (w[1] > 72 && w[2] > 72 && w[0] < 60) hu = -1000;
        v.at(i, j, k) = int16_t(std::lround(hu + 12 * rng.normal() + 1024));
      }
  REQUIRE(v.finish(VoxelType::I16, 1.0, -1024.0));
  SmoothedRoi roi;
  IntensityModel model;
  Carved mem([&](Arena& a) {
    roi.carve(a, int64_t(1) << 18, kCpu);
    model.carve(a, 4096, kCpu);
  });
  REQUIRE(mem.ok);
  int64_t lo[3], hi[3], slo[3], shi[3];
  roi_box_for_ball(v.view, c, 6 + 20, lo, hi);
  roi_box_for_ball(v.view, c, 20, slo, shi);
  SmoothingSettings ss;
  ss.stats_lo = slo;
  ss.stats_hi = shi;
  REQUIRE(roi.compute(v.view, lo, hi, ss) == RoiStatus::ok);
  // The box's p1 is air; the fenced range is the soft tissues'.
  CHECK(roi.robust_low() < -500);
  CHECK(roi.contrast_low() > -200);
  CHECK(roi.contrast_high() - roi.contrast_low() < 250);
  REQUIRE(model.fit(roi, c, 6, IntensityModelSettings()) == ModelStatus::ok);
  MESSAGE("floor " << model.sigma_floor() << ", box p1..p99 " << roi.robust_low() << ".." << roi.robust_high()
                   << ", fenced " << roi.contrast_low() << ".." << roi.contrast_high() << ", g(45) " << model.g(45));
  CHECK(model.sigma_floor() < 20);
  CHECK(model.g(5) > 0.8);
  CHECK(model.g(45) < 0.2);  // the organ around the fluid is not the fluid
}

namespace {

// A 64^3 u8 volume of 1 mm voxels around (32, 32, 32): value(d, i) at voxel
// (i, j, k), d its distance from the centre, plus Gaussian noise sigma 0.5;
// returns v.finish().
template <class F>
bool fill_u8_around_centre(TestVolume<uint8_t>& v, uint32_t seed, F value) {
  Rng rng(seed);
  for (int64_t k = 0; k < 64; ++k)
    for (int64_t j = 0; j < 64; ++j)
      for (int64_t i = 0; i < 64; ++i) {
        const double d = std::sqrt(double((i - 32) * (i - 32) + (j - 32) * (j - 32) + (k - 32) * (k - 32)));
        v.at(i, j, k) = uint8_t(std::lround(value(d, i) + 0.5 * rng.normal()));
      }
  return v.finish(VoxelType::U8);
}

}  // namespace

TEST_CASE("intensity: on near noise-free data the variance floor lets the search reach the structure's boundary") {
  // Colin27-like (PEERS.md): a u8 ball (radius 15 mm, 1 mm voxels) whose
  // intensity ramps 88..112 across it, in a 160 background with a dark 30 slab
  // nearby; noise sigma 0.5. A 4 mm sphere sees a spread of about 1.4 grey levels.
  TestVolume<uint8_t> v(64, 64, 64, 1, 1, 1);
  const double c[3] = {32, 32, 32}, R = 15;
  REQUIRE(fill_u8_around_centre(v, 5, [&](double d, int64_t i) {
    return d <= R ? 100 + 0.8 * (double(i) - 32) : (i < 12 ? 30 : 160);
  }));
  SmoothedRoi roi;
  IntensityModel model;
  Carved mem([&](Arena& a) {
    roi.carve(a, int64_t(1) << 19, kCpu);
    model.carve(a, IntensityModel::kDefaultSamples, kCpu);
  });
  int64_t lo[3], hi[3];
  roi_box_for_ball(v.view, c, 28, lo, hi);
  REQUIRE(roi.compute(v.view, lo, hi, SmoothingSettings()) == RoiStatus::ok);
  const uint32_t nv = 400;
  std::vector<double> x, nrm, target(3 * nv);
  std::vector<uint8_t> has(nv);
  fibonacci(c, 8, nv, &x, &nrm);
  IntensitySearchSettings s;
  s.gamma = 0.05;  // a low level: these cases test the search, not the model's threshold
  s.range_mm = 12;
  auto reached = [&]() {
    search_intensity(roi, model, nv, x.data(), nrm.data(), s, target.data(), has.data());
    uint32_t ok = 0;
    for (uint32_t q = 0; q < nv; ++q) {
      if (!has[q]) continue;
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += (target[3 * q + a] - c[a]) * (target[3 * q + a] - c[a]);
      ok += std::fabs(std::sqrt(d2) - R) <= 1.0;
    }
    return ok;
  };
  IntensityModelSettings ms;
  REQUIRE(model.fit(roi, c, 4, ms) == ModelStatus::ok);
  const double sd = std::sqrt(model.component(0).var);
  MESSAGE("floored model: sd " << sd << " (floor " << model.sigma_floor() << ", range " << roi.robust_low() << ".."
                               << roi.robust_high() << ")");
  const uint32_t with_floor = reached();
  CHECK(with_floor >= nv * 95 / 100);
  // Taking the sphere's spread at face value stops the mesh inside the structure.
  ms.sigma_floor_fraction = 0;
  REQUIRE(model.fit(roi, c, 4, ms) == ModelStatus::ok);
  MESSAGE("face-value model: sd " << std::sqrt(model.component(0).var));
  const uint32_t face_value = reached();
  MESSAGE("vertices reaching the boundary: " << with_floor << " with the floor, " << face_value << " without");
  CHECK(face_value < nv / 2);
}

TEST_CASE("intensity: the sphere's samples are trimmed to its main classes: a clipped neighbour's rim is left out") {
  // A u8 organ (100) beside a brighter neighbour (160) at i >= 37, dark (30)
  // beyond i < 12; noise sigma 0.5, 1 mm voxels. The 6 mm seed sphere at
  // i = 32 clips the neighbour: about 4% of its voxels read 160.
  // 'split' gives the organ two classes inside the sphere (100 for i < 32,
  // 130 beyond, about half each): both must survive the trim.
  for (bool split : {false, true}) {
    CAPTURE(split);
    TestVolume<uint8_t> v(64, 64, 64, 1, 1, 1);
    REQUIRE(fill_u8_around_centre(v, 11, [&](double, int64_t i) {
      return i >= 37 ? 160 : (i < 12 ? 30 : (split && i >= 32 ? 130 : 100));
    }));
    SmoothedRoi roi;
    IntensityModel model;
    Carved mem([&](Arena& a) {
      roi.carve(a, int64_t(1) << 19, kCpu);
      model.carve(a, IntensityModel::kDefaultSamples, kCpu);
    });
    const double c[3] = {32, 32, 32};
    int64_t lo[3], hi[3];
    roi_box_for_ball(v.view, c, 28, lo, hi);
    REQUIRE(roi.compute(v.view, lo, hi, SmoothingSettings()) == RoiStatus::ok);
    IntensityModelSettings ms;
    ms.scene_competitors = false;  // the object model alone: the trim is what is tested
    auto widest_sd = [&]() {
      double w = 0;
      for (uint32_t i = 0; i < model.components(); ++i) w = std::max(w, std::sqrt(model.component(i).var));
      return w;
    };
    REQUIRE(model.fit(roi, c, 6, ms) == ModelStatus::ok);
    const uint32_t trimmed_n = model.sample_count();
    const double trimmed_sd = widest_sd(), floor = model.sigma_floor();
    const double g_rim = model.g(160), g100 = model.g(100), g120 = model.g(120), g130 = model.g(130);
    MESSAGE("trimmed: " << trimmed_n << " samples, " << model.components() << " classes, widest sd " << trimmed_sd
                        << " (floor " << floor << "), g(100) " << g100 << " g(120) " << g120 << " g(130) " << g130 << " g(160) " << g_rim);
    ms.trim_sds = 0;  // every sample of the sphere
    REQUIRE(model.fit(roi, c, 6, ms) == ModelStatus::ok);
    const uint32_t all_n = model.sample_count();
    const double all_sd = widest_sd();
    MESSAGE("untrimmed: " << all_n << " samples, " << model.components() << " classes, widest sd " << all_sd
                          << ", g(120) " << model.g(120) << " g(160) " << model.g(160));
    CHECK(g100 > 0.5);
    if (split) {
      // Two classes of half the sphere each: the quartiles span both, the
      // trim window (median +- 2.5 robust sd) is wide and keeps every
      // sample, the rim included (binning's N_m leaves it out of the classes).
      CHECK(g130 > 0.5);
      CHECK(trimmed_n == all_n);
      continue;
    }
    // The rim, and only the rim, went: a few percent of the samples.
    CHECK(all_n > trimmed_n);
    CHECK(double(all_n - trimmed_n) < 0.08 * all_n);
    CHECK(g_rim < 1e-5);
    CHECK(trimmed_sd <= 1.05 * floor);  // no class stretched towards the neighbour
    CHECK(all_sd > 1.5 * floor);        // without the trim the rim widens the model
    // At the engine's Gamma (0.2) 120 is not organ; the untrimmed model,
    // stretched by the rim, would take it (a leak of 20 grey levels).
    CHECK(g120 < 0.2);
    CHECK(model.g(120) > 0.2);
  }
  TestVolume<uint8_t> v(64, 64, 64, 1, 1, 1);
  REQUIRE(fill_u8_around_centre(v, 11, [](double, int64_t) { return 100.0; }));
  SmoothedRoi roi;
  IntensityModel model;
  Carved mem([&](Arena& a) {
    roi.carve(a, int64_t(1) << 19, kCpu);
    model.carve(a, 4096, kCpu);
  });
  const double c[3] = {32, 32, 32};
  int64_t lo[3], hi[3];
  roi_box_for_ball(v.view, c, 20, lo, hi);
  REQUIRE(roi.compute(v.view, lo, hi, SmoothingSettings()) == RoiStatus::ok);
  IntensityModelSettings ms;
  for (double bad : {-1.0, double(NAN), double(INFINITY)}) {
    ms.trim_sds = bad;
    CHECK(model.fit(roi, c, 6, ms) == ModelStatus::bad_settings);
  }
}

namespace {

// A u8 ball of 90 in a background of 30 on a 1 mm grid (dims^3 voxels,
// centred), its edge a linear ramp `ramp` mm wide centred on radius R; the
// crop of the search range `box` mm around the centre is smoothed and the
// model fitted to a sphere of radius `sphere` mm.
struct RampedBall {
  TestVolume<uint8_t> v;
  double c[3];
  double R;
  SmoothedRoi roi;
  IntensityModel model;
  Carved mem;
  RampedBall(int64_t dims, double R_, double ramp, uint64_t seed)
      : v(dims, dims, dims, 1, 1, 1),
        c{double(dims / 2), double(dims / 2), double(dims / 2)},
        R(R_),
        mem([&](Arena& a) {
          roi.carve(a, int64_t(1) << 19, kCpu);
          model.carve(a, IntensityModel::kDefaultSamples, kCpu);
        }) {
    const double h = 0.5 * ramp;
    fill_ok = fill_u8_around_centre(
        v, seed, [&](double d, int64_t) { return 30 + 60 * std::min(1.0, std::max(0.0, (R + h - d) / ramp)); });
  }
  bool fill_ok = false;
  bool prepare(double box, double sphere, const IntensityModelSettings& ms) {
    int64_t lo[3], hi[3];
    roi_box_for_ball(v.view, c, box, lo, hi);
    return mem.ok && fill_ok && roi.compute(v.view, lo, hi, SmoothingSettings()) == RoiStatus::ok &&
           model.fit(roi, c, sphere, ms) == ModelStatus::ok;
  }
  // Mean signed distance from the sphere of radius R of the targets (3 per
  // vertex) that have one; count: how many.
  double offset(const std::vector<double>& t, const std::vector<uint8_t>& has, uint32_t* count = nullptr) const {
    double sum = 0;
    uint32_t n = 0;
    for (size_t q = 0; q < has.size(); ++q) {
      if (!has[q]) continue;
      double d2 = 0;
      for (int a = 0; a < 3; ++a) d2 += (t[3 * q + a] - c[a]) * (t[3 * q + a] - c[a]);
      sum += std::sqrt(d2) - R;
      ++n;
    }
    if (count) *count = n;
    return n ? sum / n : 0.0;
  }
};

}  // namespace

TEST_CASE("intensity: partial-volume boundaries sit at the half-way level of a blurred edge, from inside and outside") {
  // A u8 ball of 90 in a background of 30 (1 mm voxels, noise sigma 0.5); the
  // edge is a linear ramp 2 mm wide centred on R = 12 mm, so the half-way level
  // 60 lies at R while g gives up about 0.6 mm inside it. (With a 3 mm ramp
  // the crop's subsampled mixture came out as a single class, mean 36, and
  // nothing competed: the rule then leaves every target where it is.)
  RampedBall ball(64, 12, 2, 11);
  const double* c = ball.c;
  SmoothedRoi& roi = ball.roi;
  IntensityModel& model = ball.model;
  IntensityModelSettings ms;
  REQUIRE(ball.prepare(17, 5, ms));  // the ball is a sixth of the crop: a class of the scene
  REQUIRE(model.competitors() >= 1);
  double rival = 0;
  CHECK(model.rival_mean(30, &rival));
  CHECK(rival == doctest::Approx(30).epsilon(0.1));
  CHECK_FALSE(model.rival_mean(90, &rival));
  CHECK(model.class_mean(85) == doctest::Approx(90).epsilon(0.05));

  const uint32_t nv = 400;
  std::vector<double> x, nrm, target(3 * nv), plain(3 * nv);
  std::vector<uint8_t> has(nv), plain_has(nv);
  IntensitySearchSettings s;
  s.gamma = 0.05;  // a low level: these cases test the search, not the model's threshold
  s.range_mm = 12;
  for (double r0 : {7.0, 15.0}) {  // inside: outward search; outside: inward search
    CAPTURE(r0);
    fibonacci(c, r0, nv, &x, &nrm);
    s.partial_volume = false;
    search_intensity(roi, model, nv, x.data(), nrm.data(), s, plain.data(), plain_has.data());
    s.partial_volume = true;
    search_intensity(roi, model, nv, x.data(), nrm.data(), s, target.data(), has.data());
    uint32_t n_plain = 0, n_pv = 0;
    const double off_plain = ball.offset(plain, plain_has, &n_plain), off_pv = ball.offset(target, has, &n_pv);
    MESSAGE("target offset from R: g crossing " << off_plain << " mm, partial-volume level " << off_pv << " mm");
    CHECK(n_plain >= nv * 98 / 100);
    CHECK(n_pv == n_plain);
    CHECK(off_plain < -0.4);                        // g gives up inside the edge
    CHECK(std::fabs(off_pv) < 0.15);                // the half-way level is the edge's centre
    for (uint32_t q = 0; q < nv; ++q) {             // moved away from the object only
      if (!has[q]) continue;
      double dp = 0, dv = 0;
      for (int a = 0; a < 3; ++a) {
        dp += (plain[3 * q + a] - c[a]) * (plain[3 * q + a] - c[a]);
        dv += (target[3 * q + a] - c[a]) * (target[3 * q + a] - c[a]);
      }
      CHECK(std::sqrt(dv) >= std::sqrt(dp) - 1e-9);
    }
  }
  // Without competing classes there is no class to be half-way to: the
  // targets stay on the g crossings, bit for bit.
  ms.scene_competitors = false;
  REQUIRE(model.fit(roi, c, 5, ms) == ModelStatus::ok);
  REQUIRE(model.competitors() == 0);
  fibonacci(c, 7, nv, &x, &nrm);
  s.partial_volume = false;
  search_intensity(roi, model, nv, x.data(), nrm.data(), s, plain.data(), plain_has.data());
  s.partial_volume = true;
  search_intensity(roi, model, nv, x.data(), nrm.data(), s, target.data(), has.data());
  CHECK(has == plain_has);
  CHECK(std::memcmp(target.data(), plain.data(), sizeof(double) * 3 * nv) == 0);
}

TEST_CASE("intensity: the partial-volume level of an edge as wide as a coarser acquisition made it is sought in acquired samples") {
  // A ball of 90 in 30 whose edge ramps over 6 mm on a 1 mm grid, as an
  // edge of a 3 mm scan resampled to 1 mm does. The g crossing lies near the
  // ramp's inner end; N = 3 grid samples (1.5 mm) beyond it the value is
  // still nearer the object's class, so no rival claims it and the rule
  // leaves the target there, more than 2 mm inside the edge's centre.
  // Counted in the acquisition's samples (scale 3: 4.5 mm) a rival class
  // claims the sample beyond and the target moves out to the half-way level
  // (the scene's mixture holds a class within the long ramp too, so the
  // level lies short of the centre), never past the centre.
  RampedBall ball(72, 16, 6, 13);
  const double* c = ball.c;
  const SmoothedRoi& roi = ball.roi;
  const IntensityModel& model = ball.model;
  REQUIRE(ball.prepare(24, 8, IntensityModelSettings()));
  CHECK(roi.acquisition_scale() == 1.0);  // noise-free: nothing reads as oversampled
  REQUIRE(model.competitors() >= 1);
  const uint32_t nv = 400;
  std::vector<double> x, nrm, plain(3 * nv), grid(3 * nv), acquired(3 * nv);
  std::vector<uint8_t> plain_has(nv), grid_has(nv), acquired_has(nv);
  IntensitySearchSettings s;  // the engine's Gamma and N
  s.range_mm = 12;
  fibonacci(c, 10, nv, &x, &nrm);
  search_intensity(roi, model, nv, x.data(), nrm.data(), s, plain.data(), plain_has.data());
  s.partial_volume = true;
  search_intensity(roi, model, nv, x.data(), nrm.data(), s, grid.data(), grid_has.data());
  s.acquisition_scale = 3;
  search_intensity(roi, model, nv, x.data(), nrm.data(), s, acquired.data(), acquired_has.data());
  const double off_plain = ball.offset(plain, plain_has), off_grid = ball.offset(grid, grid_has),
               off_acq = ball.offset(acquired, acquired_has);
  MESSAGE("target offset from the edge's centre: g crossing " << off_plain << " mm, level sought in 3 grid samples "
                                                               << off_grid << ", in 3 acquired samples " << off_acq);
  CHECK(plain_has == grid_has);
  CHECK(plain_has == acquired_has);
  CHECK(off_plain < -2.0);
  CHECK(off_grid == doctest::Approx(off_plain).epsilon(1e-9));  // nothing claims 1.5 mm beyond: no move
  CHECK(off_acq > off_plain + 2.0);                              // most of the way out
  CHECK(off_acq < 0.3);                                          // never past the centre
}

namespace {

// The plain EM (per-sample log-likelihood summed in sample order, the stopping
// test on it): the reference em_fit must reproduce bit for bit, iteration
// count included, although it sums logs by chunks and certifies the test.
EmResult reference_em(const float* x, uint32_t n, Gaussian1* comp, uint32_t* m_io, uint32_t max_it, double var_floor,
                      double tol, std::vector<double>* diffs = nullptr) {
  EmResult r;
  uint32_t m = *m_io;
  double shift = 0, lo = INFINITY, hi = -INFINITY;
  uint32_t nf = 0;
  for (uint32_t j = 0; j < n; ++j) {
    if (!std::isfinite(x[j])) continue;
    ++nf;
    shift += x[j];
    lo = std::min(lo, double(x[j]));
    hi = std::max(hi, double(x[j]));
  }
  shift /= nf;
  const double scale = hi > lo ? hi - lo : std::max(1.0, std::fabs(shift));
  const double vmin = std::max(var_floor, 1e-12 * scale * scale);
  double a[8], mu[8], v[8];
  for (uint32_t i = 0; i < m; ++i) {
    a[i] = comp[i].weight > 0 ? comp[i].weight : 1.0 / m;
    mu[i] = comp[i].mean - shift;
    v[i] = std::max(comp[i].var, vmin);
  }
  const double half_log_2pi = 0.5 * std::log(6.283185307179586);
  double ll_prev = -INFINITY;
  uint32_t it = 0;
  while (it < max_it) {
    ++it;
    double la[8], ih[8], Z[8] = {}, Zx[8] = {}, Zxx[8] = {};
    for (uint32_t i = 0; i < m; ++i) {
      la[i] = std::log(a[i]) - 0.5 * std::log(v[i]);
      ih[i] = 0.5 / v[i];
    }
    double ll = 0;
    for (uint32_t j = 0; j < n; ++j) {
      if (!std::isfinite(x[j])) continue;
      const double xj = double(x[j]) - shift;
      double l[8], mx = -INFINITY;
      for (uint32_t i = 0; i < m; ++i) {
        const double d = xj - mu[i];
        l[i] = la[i] - d * d * ih[i];
        mx = l[i] > mx ? l[i] : mx;
      }
      double s = 0;
      for (uint32_t i = 0; i < m; ++i) {
        const double e = l[i] - mx;
        s += (l[i] = e == 0 ? 1.0 : std::exp(e));
      }
      ll += mx + std::log(s);
      const double inv = 1.0 / s;
      for (uint32_t i = 0; i < m; ++i) {
        const double z = l[i] * inv;
        Z[i] += z;
        Zx[i] += z * xj;
        Zxx[i] += z * xj * xj;
      }
    }
    ll = ll / nf - half_log_2pi;
    uint32_t k = 0;
    for (uint32_t i = 0; i < m; ++i) {
      if (Z[i] < 1e-4 * nf) continue;
      a[k] = Z[i] / nf;
      mu[k] = Zx[i] / Z[i];
      v[k] = std::max(Zxx[i] / Z[i] - mu[k] * mu[k], vmin);
      ++k;
    }
    if (k == 0) break;
    if (k < m) {
      double t = 0;
      for (uint32_t i = 0; i < k; ++i) t += a[i];
      for (uint32_t i = 0; i < k; ++i) a[i] /= t;
      m = k;
    }
    r.log_likelihood = ll;
    if (diffs && it > 1) diffs->push_back(ll - ll_prev);
    if (ll - ll_prev < tol && it > 1) break;
    ll_prev = ll;
  }
  r.iterations = it;
  for (uint32_t i = 0; i < m; ++i) {
    comp[i].weight = a[i];
    comp[i].mean = mu[i] + shift;
    comp[i].var = v[i];
  }
  *m_io = m;
  return r;
}

}  // namespace

TEST_CASE("EM: bit-identical to the plain per-sample log-likelihood EM (iterations, parameters, log-likelihood)") {
  uint32_t seed = 1;
  auto rnd = [&]() {
    seed = seed * 1664525u + 1013904223u;
    return double(seed >> 8) / double(1u << 24);
  };
  int fallbacks_possible = 0;
  for (int trial = 0; trial < 60; ++trial) {
    const uint32_t k = 1 + trial % 5;
    std::vector<Gaussian1> truth;
    for (uint32_t i = 0; i < k; ++i) truth.push_back({1.0 / k, 100.0 * rnd() + 30.0 * i, 4 + 100 * rnd()});
    const uint32_t n = 500 + uint32_t(rnd() * 20000);
    auto x = mixture_samples(n, truth, 100 + uint64_t(trial));
    if (trial % 7 == 3) x[n / 2] = NAN;  // non-finite samples are skipped by both
    Gaussian1 c1[8], c2[8];
    const uint32_t m0 = 1 + (trial * 3) % 8;
    Gaussian1 start[8];
    for (uint32_t i = 0; i < m0; ++i) start[i] = c1[i] = c2[i] = {1.0 / m0, 40.0 + 150.0 * rnd(), 10 + 200 * rnd()};
    uint32_t m1 = m0, m2 = m0;
    const double floor = (trial % 3) ? 4.0 * rnd() : 0.0;
    double tol = trial % 2 ? 1e-9 : 1e-7;
    const uint32_t its = trial % 4 ? 100 : 300;
    if (trial % 3 == 2) {
      // A tolerance exactly at (or one ulp above) a difference of the run:
      // the chunked sums cannot decide, the exact fallback must.
      std::vector<double> diffs;
      Gaussian1 c3[8];
      for (uint32_t i = 0; i < m0; ++i) c3[i] = c1[i];
      uint32_t m3 = m0;
      reference_em(x.data(), n, c3, &m3, its, floor, 0.0, &diffs);
      if (diffs.size() > 4) {
        const double d = diffs[diffs.size() / 2];
        tol = trial % 2 ? d : std::nextafter(d, INFINITY);
      }
    }
    const EmResult r1 = em_fit(kCpu, x.data(), n, c1, &m1, its, floor, tol);
    const EmResult r2 = reference_em(x.data(), n, c2, &m2, its, floor, tol);
    CAPTURE(trial);
    REQUIRE(m1 == m2);
    CHECK(r1.iterations == r2.iterations);
    CHECK(r1.log_likelihood == r2.log_likelihood);
    fallbacks_possible += r1.iterations < its;
    for (uint32_t i = 0; i < m1; ++i) {
      CHECK(c1[i].weight == c2[i].weight);
      CHECK(c1[i].mean == c2[i].mean);
      CHECK(c1[i].var == c2[i].var);
    }
    for (const CpuDispatch& cpu : each_kernel(KernelFamily::mixture)) {  // every E-step kernel
      CAPTURE(CpuDispatch::name(cpu.kernel(KernelFamily::mixture)));
      Gaussian1 c4[8];
      for (uint32_t i = 0; i < m0; ++i) c4[i] = start[i];
      uint32_t m4 = m0;
      const EmResult r4 = em_fit(cpu, x.data(), n, c4, &m4, its, floor, tol);
      REQUIRE(m4 == m2);
      CHECK(r4.iterations == r2.iterations);
      CHECK(r4.log_likelihood == r2.log_likelihood);
      for (uint32_t i = 0; i < m4; ++i) CHECK(std::memcmp(&c4[i], &c2[i], sizeof c4[i]) == 0);
    }
  }
  CHECK(fallbacks_possible > 10);  // most trials stop on the tolerance, not the cap
}

namespace {

// Plain Perona-Malik (the header's discretisation, faces in the order -i, +i,
// -j, +j, -k, +k, single precision, Jacobi sweep) over the box [lo, hi) with
// zero flux at its faces.
std::vector<float> reference_pm(const VolumeView& vol, const int64_t lo[3], const int64_t hi[3], uint32_t iters,
                                 double kappa, double dt) {
  const int64_t e[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  std::vector<float> a(size_t(e[0] * e[1] * e[2])), b(a.size());
  auto id = [&](int64_t i, int64_t j, int64_t k) { return size_t(i + e[0] * (j + e[1] * k)); };
  for (int64_t k = 0; k < e[2]; ++k)
    for (int64_t j = 0; j < e[1]; ++j)
      for (int64_t i = 0; i < e[0]; ++i) a[id(i, j, k)] = float(vol.at(lo[0] + i, lo[1] + j, lo[2] + k));
  float w[3], ik[3];
  for (int s = 0; s < 3; ++s) {
    const double h = vol.spacing()[s];
    w[s] = float(dt / (h * h));
    ik[s] = float(1.0 / (h * h * kappa * kappa));
  }
  auto flux = [](float d, float ws, float iks) { return ws * d / (1.0f + d * d * iks); };
  for (uint32_t it = 0; it < iters; ++it) {
    for (int64_t k = 0; k < e[2]; ++k)
      for (int64_t j = 0; j < e[1]; ++j)
        for (int64_t i = 0; i < e[0]; ++i) {
          const float c0 = a[id(i, j, k)];
          float acc = 0;
          if (i > 0) acc += flux(a[id(i - 1, j, k)] - c0, w[0], ik[0]);
          if (i + 1 < e[0]) acc += flux(a[id(i + 1, j, k)] - c0, w[0], ik[0]);
          if (j > 0) acc += flux(a[id(i, j - 1, k)] - c0, w[1], ik[1]);
          if (j + 1 < e[1]) acc += flux(a[id(i, j + 1, k)] - c0, w[1], ik[1]);
          if (k > 0) acc += flux(a[id(i, j, k - 1)] - c0, w[2], ik[2]);
          if (k + 1 < e[2]) acc += flux(a[id(i, j, k + 1)] - c0, w[2], ik[2]);
          b[id(i, j, k)] = c0 + acc;
        }
    a.swap(b);
  }
  return a;
}

template <class T>
void check_kernels_bitwise(TestVolume<T>& v, double kappa) {
  // Whole-grid crops (zero flux at the grid = at the crop) of several row
  // lengths: rows shorter than 8, 16 and 32 voxels take the short-row path of
  // the wide kernels, longer ones the edge-lane path. k is the longest axis,
  // so the storage order is i, j, k as in the reference.
  SmoothingSettings s;
  s.iterations = 4;
  s.kappa = kappa;
  for (int64_t nx : {int64_t(2), int64_t(5), int64_t(9), int64_t(17), int64_t(33), int64_t(40)}) {
    const int64_t lo[3] = {0, 0, 0}, hi[3] = {nx, v.dims[1], v.dims[2]};
    const int64_t glo[3] = {0, 0, 0};
    // The reference over the same box (no margin: the crop is the grid's i range when nx = dims[0]).
    for (const CpuDispatch& cpu : each_kernel(KernelFamily::smoothing)) {
      CAPTURE(nx);
      CAPTURE(CpuDispatch::name(cpu.kernel(KernelFamily::smoothing)));
      SmoothedRoi roi;
      Carved mem([&](Arena& a) { roi.carve(a, v.dims[0] * v.dims[1] * v.dims[2], cpu); });
      REQUIRE(mem.ok);
      const int64_t sub_lo[3] = {0, 0, 0};
      // Crop = box [0, nx) x grid x grid, grown by 4 along i (clipped at 0).
      REQUIRE(roi.compute(v.view, sub_lo, hi, s) == RoiStatus::ok);
      const int64_t dh[3] = {roi.data_hi()[0], roi.data_hi()[1], roi.data_hi()[2]};
      const std::vector<float> ref = reference_pm(v.view, glo, dh, s.iterations, roi.kappa(), roi.time_step());
      size_t bad = 0;
      for (int64_t kk = 0; kk < dh[2]; ++kk)
        for (int64_t j = 0; j < dh[1]; ++j)
          for (int64_t i = 0; i < dh[0]; ++i) {
            const float a = roi.at(i, j, kk), b = ref[size_t(i + dh[0] * (j + dh[1] * kk))];
            bad += std::memcmp(&a, &b, sizeof a) != 0;
          }
      CHECK(bad == 0);
    }
    (void)lo;
  }
}

}  // namespace

TEST_CASE("smoothing: every diffusion kernel (4, 8, 16 lanes) equals a plain scalar Perona-Malik bit for bit") {
  Rng rng(5);
  {
    TestVolume<float> v(48, 13, 60, 0.7, 0.9, 1.3);
    for (auto& x : v.data) x = float(100.0 * (rng.uniform() > 0.5) + 10.0 * rng.normal());
    REQUIRE(v.finish(VoxelType::F32));
    check_kernels_bitwise(v, 20.0);
  }
  {
    TestVolume<uint8_t> v(48, 11, 50, 1.0, 1.0, 1.0);
    for (auto& x : v.data) x = uint8_t(rng.uniform() * 255.0);
    REQUIRE(v.finish(VoxelType::U8));
    check_kernels_bitwise(v, 30.0);
  }
  {
    TestVolume<int16_t> v(45, 12, 52, 0.8, 0.8, 2.5);
    for (auto& x : v.data) x = int16_t(1024 + 60.0 * (rng.uniform() > 0.3) + 15.0 * rng.normal());
    REQUIRE(v.finish(VoxelType::I16, 1.0, -1024.0));
    check_kernels_bitwise(v, 25.0);
    // A negative slope: the typed copy's value range comes from the other raw extreme.
    REQUIRE(v.finish(VoxelType::I16, -0.5, 100.0));
    check_kernels_bitwise(v, 25.0);
  }
}

TEST_CASE("exp_block returns std::exp bit for bit (vector kernel certified lanes, fallback for the rest)") {
  Rng rng(77);
  std::vector<double> x;
  const double specials[] = {0.0, -0.0, 1e-300, -1e-300, 4.9e-324, -4.9e-324, 1.0, -1.0, -669.9, -670.0, -700.0,
                             -708.5, -745.0, -745.2, -800.0, 708.9, 709.0, 709.7, 710.0, INFINITY, -INFINITY, NAN};
  for (double v : specials) x.push_back(v);
  const double c = 0.6931471805599453 / 256.0;
  for (int k = -250000; k <= 2000; k += 7) {  // near multiples of ln2/256: the reduction's hard cases
    const double b = k * c;
    x.push_back(b);
    x.push_back(std::nextafter(b, -INFINITY));
    x.push_back(b + 1e-12 * (rng.uniform() - 0.5));
  }
  const struct {
    double lo, hi;
    int count;
  } ranges[] = {{-670, 0, 4000000}, {-40, 0, 4000000}, {-1e-3, 1e-3, 1000000}, {-1e-12, 1e-12, 200000},
                {0, 709, 1000000},  {-2, 2, 2000000}};
  for (const auto& r : ranges)
    for (int i = 0; i < r.count; ++i) x.push_back(r.lo + (r.hi - r.lo) * rng.uniform());
  std::vector<double> y = x, k = x;
  // Odd lengths exercise the tail.
  exp_block(kCpu, y.data(), uint32_t(y.size()));
  exp_block(kCpu, y.data() + 3, 0);
  size_t bad = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double e = std::exp(x[i]);
    bad += std::memcmp(&e, &y[i], sizeof e) != 0 && !(std::isnan(e) && std::isnan(y[i]));
  }
  CHECK(bad == 0);
  {
    // Zeros (and -0) packed out: exp_block_nonzero.
    std::vector<double> w(x.begin(), x.begin() + 3000001);
    for (size_t i = 0; i < w.size(); i += 3) w[i] = (i % 2) ? 0.0 : -0.0;
    std::vector<double> wy = w;
    exp_block_nonzero(kCpu, wy.data(), uint32_t(wy.size()));
    size_t badz = 0;
    for (size_t i = 0; i < w.size(); ++i) {
      const double e = std::exp(w[i]);
      badz += std::memcmp(&e, &wy[i], sizeof e) != 0 && !(std::isnan(e) && std::isnan(wy[i]));
    }
    CHECK(badz == 0);
  }
  for (uint32_t n : {1u, 5u, 7u, 9u, 15u}) {
    std::vector<double> z(x.begin() + 1000, x.begin() + 1000 + n);
    exp_block(kCpu, z.data(), n);
    for (uint32_t i = 0; i < n; ++i) CHECK(z[i] == std::exp(x[1000 + i]));
  }
  if (kCpu.kernel(KernelFamily::exp) == Isa::avx512) {
    // Most lanes are certified by the kernel itself (the others call std::exp).
    ExpBlockTesting::kernel_only(k.data(), uint32_t(k.size()));
    size_t uncertified = 0, wrong = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      if (std::isnan(k[i])) {
        ++uncertified;
        continue;
      }
      const double e = std::exp(x[i]);
      wrong += std::memcmp(&e, &k[i], sizeof e) != 0;
    }
    CHECK(wrong == 0);
    CHECK(double(uncertified) < 0.08 * double(x.size()));
    MESSAGE("exp_block: " << x.size() << " arguments, " << uncertified << " left to std::exp by the kernel");
  }
}

TEST_CASE("intensity: the table follows g_direct across far-apart narrow classes, and is 0 where g_direct is") {
  // Narrow, far-apart components: most of the span lies where every exp
  // underflows to 0.
  IntensityModel model;
  Carved mem([&](Arena& a) { model.carve(a, 16, kCpu); });
  IntensityModelSettings s;
  s.bin_radius = 10;
  s.bin_separation = 20;
  auto x = mixture_samples(6000, {{0.5, -300, 4}, {0.3, 0, 9}, {0.2, 400, 1}}, 41);
  REQUIRE(model.fit_samples(x.data(), 6000, 0.0, s) == ModelStatus::ok);
  REQUIRE(model.components() == 3);
  REQUIRE(model.has_lut());
  for (double slope : {0.5, 1.0, -2.0}) {
    size_t bad = 0, zeros = 0, not_zero = 0;
    for (int raw = -32768; raw <= 32767; ++raw) {
      const double v = slope * raw * 0.0137 + 50;  // -850 .. 950 and beyond
      const double direct = model.g_direct(v);
      bad += std::fabs(model.g(v) - direct) > 1e-3;
      if (float(direct) == 0.0f) {
        ++zeros;
        not_zero += model.g(v) > 1e-30;
      }
    }
    CAPTURE(slope);
    CHECK(bad == 0);
    CHECK(not_zero == 0);
    CHECK(zeros > 10000);
  }
}

TEST_CASE("smoothing: skipping the box statistics (kappa given, integer volume) leaves the crop unchanged") {
  Rng rng(9);
  TestVolume<int16_t> v(40, 30, 20, 0.8, 0.8, 2.5);
  for (auto& x : v.data) x = int16_t(1000 + 80.0 * (rng.uniform() > 0.5) + 15.0 * rng.normal());
  REQUIRE(v.finish(VoxelType::I16, 1.0, -1024.0));
  SmoothedRoi a, b;
  Carved m1([&](Arena& ar) { a.carve(ar, 40 * 30 * 20, kCpu); });
  Carved m2([&](Arena& ar) { b.carve(ar, 40 * 30 * 20, kCpu); });
  SmoothingSettings s;
  s.kappa = 30;
  const int64_t lo[3] = {5, 4, 3}, hi[3] = {33, 25, 15};
  REQUIRE(a.compute(v.view, lo, hi, s) == RoiStatus::ok);
  s.statistics = false;
  REQUIRE(b.compute(v.view, lo, hi, s) == RoiStatus::ok);
  CHECK(a.noise_sigma() > 0);
  CHECK(b.noise_sigma() == 0);
  size_t bad = 0;
  for (int64_t k = b.data_lo()[2]; k < b.data_hi()[2]; ++k)
    for (int64_t j = b.data_lo()[1]; j < b.data_hi()[1]; ++j)
      for (int64_t i = b.data_lo()[0]; i < b.data_hi()[0]; ++i) bad += a.at(i, j, k) != b.at(i, j, k);
  CHECK(bad == 0);
  // Without a given kappa the statistics are still computed.
  s.kappa = 0;
  REQUIRE(b.compute(v.view, lo, hi, s) == RoiStatus::ok);
  CHECK(b.noise_sigma() > 0);
}

namespace {

// Algorithm 2 as a plain loop (the pre-vector code): adaptive_binning must
// give the same bins bit for bit.
uint32_t reference_binning(const float* x, uint32_t n, const BinningSettings& s, Bin* bins, uint32_t max_bins,
                           uint32_t stride) {
  if (n == 0) return 0;
  stride %= n;
  auto gcd = [](uint32_t a, uint32_t b) {
    while (b) {
      const uint32_t t = a % b;
      a = b;
      b = t;
    }
    return a;
  };
  if (stride == 0 || gcd(stride, n) != 1) stride = 1;
  const double R = s.radius, S = s.separation;
  double c[64], sum[64], sum2[64], prev[64];
  uint32_t cnt[64];
  uint32_t K = 0, prevK = 0;
  const double tol = 1e-6 * (R > 0 ? R : 1.0);
  for (uint32_t pass = 0; pass < (s.max_passes ? s.max_passes : 1); ++pass) {
    for (uint32_t k = 0; k < K; ++k) cnt[k] = 0, sum[k] = 0, sum2[k] = 0;
    uint64_t idx = 0;
    for (uint32_t t = 0; t < n; ++t) {
      const double p = x[idx];
      idx += stride;
      if (idx >= n) idx -= n;
      if (!std::isfinite(p)) continue;
      uint32_t best = 0;
      double d = INFINITY;
      for (uint32_t k = 0; k < K; ++k) {
        const double dk = std::fabs(p - c[k]);
        if (dk < d) d = dk, best = k;
      }
      if (K == 0 || d >= S) {
        if (K < 64) {
          c[K] = p, cnt[K] = 1, sum[K] = 0, sum2[K] = 0;
          ++K;
        }
      } else if (d <= R) {
        const double e = p - c[best];
        ++cnt[best];
        sum[best] += e;
        sum2[best] += e * e;
      }
    }
    uint32_t live = 0;
    for (uint32_t k = 0; k < K; ++k) {
      if (cnt[k] == 0) continue;
      const double mean = sum[k] / cnt[k];
      c[live] = c[k] + mean;
      cnt[live] = cnt[k];
      sum[live] = 0;
      sum2[live] = std::max(0.0, sum2[k] / cnt[k] - mean * mean);
      ++live;
    }
    K = live;
    for (;;) {
      if (K < 2) break;
      double bd = INFINITY;
      uint32_t ba = 0, bb = 0;
      for (uint32_t a = 0; a < K; ++a)
        for (uint32_t b = a + 1; b < K; ++b) {
          const double d = std::fabs(c[a] - c[b]);
          if (d < bd) bd = d, ba = a, bb = b;
        }
      if (!(bd < S)) break;
      const double na = cnt[ba], nb = cnt[bb], nt = na + nb;
      const double cm = (na * c[ba] + nb * c[bb]) / nt;
      sum2[ba] = (na * (sum2[ba] + (c[ba] - cm) * (c[ba] - cm)) + nb * (sum2[bb] + (c[bb] - cm) * (c[bb] - cm))) / nt;
      c[ba] = cm;
      cnt[ba] += cnt[bb];
      --K;
      c[bb] = c[K], cnt[bb] = cnt[K], sum2[bb] = sum2[K];
    }
    uint32_t kept = 0;
    for (uint32_t k = 0; k < K; ++k) {
      if (cnt[k] < s.min_count) continue;
      c[kept] = c[k], cnt[kept] = cnt[k], sum2[kept] = sum2[k];
      ++kept;
    }
    K = kept;
    bool same = K == prevK;
    for (uint32_t k = 0; same && k < K; ++k) same = std::fabs(c[k] - prev[k]) <= tol;
    for (uint32_t k = 0; k < K; ++k) prev[k] = c[k];
    prevK = K;
    if (same) break;
  }
  uint32_t order[64];
  for (uint32_t k = 0; k < K; ++k) order[k] = k;
  std::sort(order, order + K, [&](uint32_t a, uint32_t b) { return cnt[a] != cnt[b] ? cnt[a] > cnt[b] : c[a] < c[b]; });
  const uint32_t out = K < max_bins ? K : max_bins;
  std::sort(order, order + out, [&](uint32_t a, uint32_t b) { return c[a] < c[b]; });
  for (uint32_t i = 0; i < out; ++i) {
    bins[i].centroid = c[order[i]];
    bins[i].count = cnt[order[i]];
    bins[i].var = sum2[order[i]];
  }
  return K;
}

}  // namespace

TEST_CASE("binning: bit-identical to the plain Algorithm 2 loop (clusters in vector lanes, more than 8, non-finite samples)") {
  Rng rng(123);
  int many = 0;
  for (int trial = 0; trial < 80; ++trial) {
    const uint32_t k = 1 + uint32_t(trial % 14);  // up to 14 true classes: a 9th cluster opens mid-pass
    std::vector<Gaussian1> comps;
    for (uint32_t i = 0; i < k; ++i) comps.push_back({1.0 / k, 50.0 * i + 10 * rng.uniform(), 4 + 30 * rng.uniform()});
    const uint32_t n = 200 + uint32_t(rng.uniform() * 12000);
    auto x = mixture_samples(n, comps, 500 + uint64_t(trial));
    if (trial % 5 == 1) x[n / 3] = NAN, x[n / 2] = INFINITY;
    if (trial % 7 == 2) x[0] = -0.0f, x[1] = 0.0f;
    BinningSettings s;
    s.radius = 3 + 20 * rng.uniform();
    s.separation = s.radius * (1 + 2 * rng.uniform());
    s.min_count = 1 + uint32_t(rng.uniform() * n / 30);
    s.max_passes = 1 + uint32_t(rng.uniform() * 60);
    const uint32_t stride = (trial % 3) ? mixing_stride(n) : 1;
    Bin b2[16];
    const uint32_t K2 = reference_binning(x.data(), n, s, b2, 16, stride);
    CAPTURE(trial);
    many += K2 > 8;
    for (const CpuDispatch& cpu : each_kernel(KernelFamily::mixture)) {
      CAPTURE(CpuDispatch::name(cpu.kernel(KernelFamily::mixture)));
      Bin b1[16];
      const uint32_t K1 = adaptive_binning(cpu, x.data(), n, s, b1, 16, stride);
      REQUIRE(K1 == K2);
      for (uint32_t i = 0; i < std::min(K1, 16u); ++i) {
        CHECK(b1[i].centroid == b2[i].centroid);
        CHECK(b1[i].count == b2[i].count);
        CHECK(b1[i].var == b2[i].var);
      }
    }
  }
  CHECK(many > 3);
}
