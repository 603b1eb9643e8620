// Benchmark of ffseg's fast marching (src/image/fast_marching) on Colin27 (1 mm,
// 181 x 217 x 181): the whole volume at unit speed and with a Gaussian-likelihood
// speed, and the crop of a structure (AAL left putamen, 73, its bounding box
// grown by 10 mm) with the same speed. When built with ITK 5 (FFSEG_HAVE_ITK,
// Debian libinsighttoolkit5-dev), itk::FastMarchingImageFilter runs on the same
// speed image and trial points in the same process, alternating with ffseg;
// arrival times are compared over the voxels both reach. Single thread.
//
//   bench_fast_marching [--reps R]
//
// Speed: S(x) = max(exp(-(I(x) - mu)^2 / (2 sigma^2)), 1e-6), mu and sigma of
// the T1 voxels inside the putamen's protocol sphere (centre (-20, 14, -4) mm,
// radius 2.92 mm); those voxels are also the seeds (T = 0), as the regions stage
// will seed each object with the voxels inside its mesh. The floor keeps every
// time finite in float (the largest is about 1e6 times a path length).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "arena.h"
#include "fast_marching.h"
#include "nifti.h"

#ifdef FFSEG_HAVE_ITK
#include <itkFastMarchingImageFilter.h>
#include <itkImage.h>
#endif

namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

double voxel_value(const ffseg_tools::NiftiImage& img, size_t v) {
  const uint8_t* p = img.data.data() + v * size_t(img.bytes_per_voxel);
  double x = 0;
  switch (img.voxel_type) {
    case ffseg_tools::kNiftiVoxU8: x = *p; break;
    case ffseg_tools::kNiftiVoxI16: { int16_t t; std::memcpy(&t, p, 2); x = t; } break;
    case ffseg_tools::kNiftiVoxU16: { uint16_t t; std::memcpy(&t, p, 2); x = t; } break;
    case ffseg_tools::kNiftiVoxI32: { int32_t t; std::memcpy(&t, p, 4); x = t; } break;
    case ffseg_tools::kNiftiVoxF32: { float t; std::memcpy(&t, p, 4); x = t; } break;
    default: { double t; std::memcpy(&t, p, 8); x = t; } break;
  }
  return img.scl_slope * x + img.scl_inter;
}

// A crop [lo, lo + n) of the volume: its speed (x fastest) and seeds.
struct Case {
  const char* name;
  int64_t lo[3], n[3];
  std::vector<float> speed;
  std::vector<int64_t> seeds;  // linear indices in the crop
};

struct Result {
  std::vector<double> ms;
  int64_t reached = 0;
  std::vector<float> t;
};

struct Buffer {
  void* p = nullptr;
  explicit Buffer(size_t bytes) { p = std::aligned_alloc(64, ffseg::Arena::round_up(bytes ? bytes : 64)); }
  ~Buffer() { std::free(p); }
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
};

// One ffseg run: begin (clears the crop), seed, march; timed whole.
double run_ffseg(ffseg::FastMarching& fm, const Case& c, const double h[3], Result* r) {
  const auto t0 = Clock::now();
  char msg[160];
  if (fm.begin(c.n, h, msg, sizeof msg) != ffseg::FmStatus::ok) {
    std::printf("ffseg: %s\n", msg);
    std::exit(1);
  }
  for (int64_t s : c.seeds) fm.seed(s);
  fm.march(c.speed.data(), std::numeric_limits<float>::infinity());
  const double ms = ms_since(t0);
  r->reached = fm.accepted();
  return ms;
}

#ifdef FFSEG_HAVE_ITK
using ItkImage = itk::Image<float, 3>;
using ItkFm = itk::FastMarchingImageFilter<ItkImage, ItkImage>;

ItkImage::Pointer itk_speed(const Case& c, const double h[3]) {
  ItkImage::Pointer img = ItkImage::New();
  ItkImage::RegionType region;
  ItkImage::SizeType size;
  for (int a = 0; a < 3; ++a) size[a] = itk::SizeValueType(c.n[a]);
  region.SetSize(size);
  img->SetRegions(region);
  ItkImage::SpacingType sp;
  for (int a = 0; a < 3; ++a) sp[a] = h[a];
  img->SetSpacing(sp);
  img->Allocate();
  std::memcpy(img->GetBufferPointer(), c.speed.data(), c.speed.size() * sizeof(float));
  return img;
}

// One ITK run: a new filter on the same speed image and trial points (value 0),
// timed from Update() to the end (ITK allocates and initialises its output and
// label images there, as ffseg's begin() clears its arrays).
double run_itk(const ItkImage::Pointer& speed, const Case& c, Result* r, bool keep) {
  ItkFm::Pointer fm = ItkFm::New();
  fm->SetInput(speed);
  ItkFm::NodeContainer::Pointer trial = ItkFm::NodeContainer::New();
  trial->Initialize();
  unsigned id = 0;
  for (int64_t s : c.seeds) {
    ItkFm::NodeType node;
    ItkImage::IndexType idx;
    idx[0] = s % c.n[0];
    idx[1] = (s / c.n[0]) % c.n[1];
    idx[2] = s / (c.n[0] * c.n[1]);
    node.SetIndex(idx);
    node.SetValue(0.0f);
    trial->InsertElement(id++, node);
  }
  fm->SetTrialPoints(trial);
  fm->SetNormalizationFactor(1.0);
  const auto t0 = Clock::now();
  fm->Update();
  const double ms = ms_since(t0);
  const float* out = fm->GetOutput()->GetBufferPointer();
  const size_t N = c.speed.size();
  // ITK marks unreached voxels with its "large value" (max / 2 of the pixel type).
  const float large = std::numeric_limits<float>::max() / 2;
  int64_t reached = 0;
  for (size_t v = 0; v < N; ++v) reached += out[v] < large;
  r->reached = reached;
  if (keep) r->t.assign(out, out + N);
  return ms;
}
#endif

}  // namespace

int main(int argc, char** argv) {
  int reps = 5;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--reps") && a + 1 < argc) {
      reps = std::max(1, std::atoi(argv[++a]));
    } else {
      std::fprintf(stderr, "usage: bench_fast_marching [--reps R]\n");
      return 2;
    }
  }
  const char* kCh2 = "/usr/share/mricron/templates/ch2.nii.gz";
  const char* kAal = "/usr/share/mricron/templates/aal.nii.gz";
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  if (!ffseg_tools::nifti_read_file(kCh2, &t1, &err) || !ffseg_tools::nifti_read_file(kAal, &aal, &err)) {
    std::printf("bench_fast_marching: Colin27 not found (%s); install mricron-data (make deps)\n", err.c_str());
    return 0;
  }
  const int64_t dims[3] = {t1.dims[0], t1.dims[1], t1.dims[2]};
  for (int a = 0; a < 3; ++a)
    if (aal.dims[a] != t1.dims[a]) {
      std::printf("bench_fast_marching: AAL and ch2 grids differ\n");
      return 1;
    }
  // Spacing: the column norms of the index-to-world matrix (as VolumeView does).
  const double* M = t1.index_to_world;
  double h[3];
  for (int a = 0; a < 3; ++a) h[a] = std::sqrt(M[a] * M[a] + M[4 + a] * M[4 + a] + M[8 + a] * M[8 + a]);
  const int64_t N = dims[0] * dims[1] * dims[2];

  // Seeds: voxel centres inside the protocol sphere of the left putamen.
  const double centre[3] = {-20, 14, -4}, radius = 2.92;
  std::vector<int64_t> seeds;
  double sum = 0, sum2 = 0;
  for (int64_t k = 0; k < dims[2]; ++k)
    for (int64_t j = 0; j < dims[1]; ++j)
      for (int64_t i = 0; i < dims[0]; ++i) {
        double d2 = 0;
        for (int r = 0; r < 3; ++r) {
          const double w = M[4 * r] * double(i) + M[4 * r + 1] * double(j) + M[4 * r + 2] * double(k) + M[4 * r + 3];
          d2 += (w - centre[r]) * (w - centre[r]);
        }
        if (d2 > radius * radius) continue;
        const int64_t v = i + dims[0] * (j + dims[1] * k);
        seeds.push_back(v);
        const double x = voxel_value(t1, size_t(v));
        sum += x;
        sum2 += x * x;
      }
  const double mu = sum / double(seeds.size());
  const double sigma = std::sqrt(std::max(sum2 / double(seeds.size()) - mu * mu, 1e-6));
  std::vector<float> gauss(static_cast<size_t>(N));
  for (int64_t v = 0; v < N; ++v) {
    const double z = (voxel_value(t1, size_t(v)) - mu) / sigma;
    gauss[size_t(v)] = float(std::max(std::exp(-0.5 * z * z), 1e-6));
  }

  std::vector<Case> cases(3);
  cases[0].name = "whole volume, unit speed";
  cases[1].name = "whole volume, Gaussian speed";
  for (int c = 0; c < 2; ++c) {
    for (int a = 0; a < 3; ++a) { cases[c].lo[a] = 0; cases[c].n[a] = dims[a]; }
    cases[c].seeds = seeds;
  }
  cases[0].speed.assign(size_t(N), 1.0f);
  cases[1].speed = gauss;
  // The putamen's crop: AAL 73's bounding box grown by 10 mm.
  {
    Case& c = cases[2];
    c.name = "putamen L crop (AAL 73 box + 10 mm), Gaussian speed";
    int64_t lo[3] = {dims[0], dims[1], dims[2]}, hi[3] = {-1, -1, -1};
    for (int64_t k = 0; k < dims[2]; ++k)
      for (int64_t j = 0; j < dims[1]; ++j)
        for (int64_t i = 0; i < dims[0]; ++i) {
          if (std::lround(voxel_value(aal, size_t(i + dims[0] * (j + dims[1] * k)))) != 73) continue;
          const int64_t q[3] = {i, j, k};
          for (int a = 0; a < 3; ++a) { lo[a] = std::min(lo[a], q[a]); hi[a] = std::max(hi[a], q[a]); }
        }
    for (int a = 0; a < 3; ++a) {
      const int64_t g = int64_t(std::ceil(10.0 / h[a]));
      c.lo[a] = std::max<int64_t>(0, lo[a] - g);
      c.n[a] = std::min<int64_t>(dims[a] - 1, hi[a] + g) - c.lo[a] + 1;
    }
    c.speed.resize(size_t(c.n[0] * c.n[1] * c.n[2]));
    for (int64_t k = 0; k < c.n[2]; ++k)
      for (int64_t j = 0; j < c.n[1]; ++j)
        for (int64_t i = 0; i < c.n[0]; ++i)
          c.speed[size_t(i + c.n[0] * (j + c.n[1] * k))] =
              gauss[size_t((c.lo[0] + i) + dims[0] * ((c.lo[1] + j) + dims[1] * (c.lo[2] + k)))];
    for (int64_t s : seeds) {
      const int64_t q[3] = {s % dims[0], (s / dims[0]) % dims[1], s / (dims[0] * dims[1])};
      bool in = true;
      for (int a = 0; a < 3; ++a) in = in && q[a] >= c.lo[a] && q[a] < c.lo[a] + c.n[a];
      if (in) c.seeds.push_back((q[0] - c.lo[0]) + c.n[0] * ((q[1] - c.lo[1]) + c.n[1] * (q[2] - c.lo[2])));
    }
  }

  // ffseg's workspace: one carve for the largest crop (the whole volume).
  ffseg::FastMarching fm;
  ffseg::Arena probe;
  fm.carve(probe, N, false);
  Buffer mem(probe.used());
  ffseg::Arena arena(mem.p, probe.used());
  fm.carve(arena, N, false);
  std::printf("Colin27 %lld x %lld x %lld, spacing %.3g x %.3g x %.3g mm; %zu seeds (putamen L sphere); "
              "workspace %.1f MB for %lld voxels; %d alternating runs each, single thread\n",
              (long long)dims[0], (long long)dims[1], (long long)dims[2], h[0], h[1], h[2], seeds.size(),
              double(probe.used()) / 1e6, (long long)N, reps);
#ifdef FFSEG_HAVE_ITK
  itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(1);
  std::printf("ITK %s, itk::FastMarchingImageFilter<Image<float, 3>> (float output, double arithmetic)\n\n",
              ITK_VERSION_STRING);
  std::printf("| case | voxels | reached | ffseg ms median (range) | ffseg Mvox/s | ITK ms median (range) | "
              "ITK Mvox/s | speed-up | max rel diff | mean rel diff | reached only by one |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
#else
  std::printf("(built without ITK: ffseg alone)\n\n");
  std::printf("| case | voxels | reached | ffseg ms median (range) | ffseg Mvox/s |\n|---|---|---|---|---|\n");
#endif
  double sum_ffseg_rate = 0, sum_itk_rate = 0;
  for (const Case& c : cases) {
    const int64_t cn = c.n[0] * c.n[1] * c.n[2];
    Result rf;
#ifdef FFSEG_HAVE_ITK
    Result ri;
    ItkImage::Pointer sp = itk_speed(c, h);
#endif
    for (int rep = 0; rep < reps; ++rep) {
      rf.ms.push_back(run_ffseg(fm, c, h, &rf));
#ifdef FFSEG_HAVE_ITK
      ri.ms.push_back(run_itk(sp, c, &ri, rep == 0));
#endif
    }
    const double mf = median(rf.ms);
    const double rate_f = double(rf.reached) / mf / 1e3;
    const auto mm_f = std::minmax_element(rf.ms.begin(), rf.ms.end());
#ifdef FFSEG_HAVE_ITK
    // Relative differences over the voxels both reach (|t_ffseg - t_itk| / t_itk, t_itk > 0).
    const float large = std::numeric_limits<float>::max() / 2;  // ITK's "large value"
    double max_rel = 0, sum_rel = 0;
    int64_t both = 0, only_one = 0;
    for (int64_t v = 0; v < cn; ++v) {
      const bool a = fm.states()[v] == ffseg::FastMarching::kAccepted;
      const bool b = ri.t[size_t(v)] < large;
      if (a != b) { ++only_one; continue; }
      if (!a) continue;
      ++both;
      const double ti = ri.t[size_t(v)], tf = fm.times()[v];
      const double rel = ti > 0 ? std::fabs(tf - ti) / ti : std::fabs(tf - ti);
      max_rel = std::max(max_rel, rel);
      sum_rel += rel;
    }
    const double mi = median(ri.ms);
    const double rate_i = double(ri.reached) / mi / 1e3;
    const auto mm_i = std::minmax_element(ri.ms.begin(), ri.ms.end());
    std::printf("| %s | %lld | %lld | %.1f (%.1f-%.1f) | %.2f | %.1f (%.1f-%.1f) | %.2f | %.2fx | %.2e | %.2e | %lld |\n",
                c.name, (long long)cn, (long long)rf.reached, mf, *mm_f.first, *mm_f.second, rate_f, mi, *mm_i.first,
                *mm_i.second, rate_i, rate_f / rate_i, max_rel, both ? sum_rel / double(both) : 0.0,
                (long long)only_one);
    sum_itk_rate += rate_i;
#else
    std::printf("| %s | %lld | %lld | %.1f (%.1f-%.1f) | %.2f |\n", c.name, (long long)cn, (long long)rf.reached, mf,
                *mm_f.first, *mm_f.second, rate_f);
#endif
    sum_ffseg_rate += rate_f;
  }
#ifdef FFSEG_HAVE_ITK
  std::printf("\nfast marching vs ITK FastMarchingImageFilter: %.1fx voxels per second\n", sum_ffseg_rate / sum_itk_rate);
#else
  std::printf("\nfast marching: %.2f M voxels per second (mean of the cases; ITK not built in)\n",
              sum_ffseg_rate / double(cases.size()));
#endif
  return 0;
}
