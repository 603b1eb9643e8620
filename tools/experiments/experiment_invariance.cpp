// Experiment (not a test): does a Colin27 result depend on how the volume is
// stored (issue 19)? The protocol sphere's structure segmented from ch2 as
// stored (u8), flipped along each axis (affine adjusted: the same anatomy in
// world space), with its axes permuted (i, j, k) -> (j, k, i), and as f32
// holding the same values; each mask mapped back to the stored grid, Dice
// against the stored run.
//
//   FFSEG_N=12 build/experiment_invariance [FFSEG_ONLY=73,...]
#include <array>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "metrics.h"
#include "support/colin27_run.h"
#include "support/phantoms.h"
#include "test_util.h"

#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

using namespace ffseg_test;

namespace {

// A stored variant: voxel (i, j, k) of the variant is voxel src(i, j, k) of the original.
struct Variant {
  const char* name;
  int dims[3];
  double A[16];
  std::vector<uint8_t> data;  // bytes, the variant's voxel type
  uint32_t type;
  std::vector<size_t> to_original;  // variant voxel -> original voxel
};

std::vector<uint8_t> segment(const Variant& v, const double c[3], double r, uint32_t n) {
  EngineBox eb(1, n, int64_t(1) << 23);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  const int64_t dims[3] = {v.dims[0], v.dims[1], v.dims[2]};
  ffseg_volume vol = make_volume(v.data.data(), v.type, dims, v.A);
  REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
  for (int s = 0; s < 100; ++s) {
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    REQUIRE(st >= 0);
    if (st == FFSEG_CONVERGED) break;
  }
  std::vector<uint8_t> mask(size_t(dims[0] * dims[1] * dims[2]));
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  return mask;
}

}  // namespace

TEST_CASE("invariance experiment") {
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27T1, &t1, &err), err);
  REQUIRE_MESSAGE(ffseg_tools::nifti_read_file(kColin27Aal, &aal, &err), err);
  REQUIRE(t1.bytes_per_voxel == 1);
  const int* d = t1.dims;
  const size_t N = t1.data.size();
  auto idx = [&](int i, int j, int k) { return size_t(i) + size_t(d[0]) * (size_t(j) + size_t(d[1]) * size_t(k)); };
  std::vector<Variant> vars;
  auto make = [&](const char* name, const int vd[3], std::function<void(int, int, int, int*)> src,
                  std::function<void(double*)> affine, bool f32) {
    Variant v;
    v.name = name;
    for (int a = 0; a < 3; ++a) v.dims[a] = vd[a];
    affine(v.A);
    v.type = f32 ? FFSEG_F32 : FFSEG_U8;
    v.data.assign(N * (f32 ? 4 : 1), 0);
    v.to_original.resize(N);
    size_t q = 0;
    for (int k = 0; k < vd[2]; ++k)
      for (int j = 0; j < vd[1]; ++j)
        for (int i = 0; i < vd[0]; ++i, ++q) {
          int o[3];
          src(i, j, k, o);
          const size_t oq = idx(o[0], o[1], o[2]);
          v.to_original[q] = oq;
          if (f32) {
            const float x = float(t1.data[oq]);
            std::memcpy(&v.data[4 * q], &x, 4);
          } else {
            v.data[q] = t1.data[oq];
          }
        }
    vars.push_back(std::move(v));
  };
  const double* A0 = t1.index_to_world;
  auto same = [&](double* A) { std::memcpy(A, A0, 16 * sizeof(double)); };
  make("stored u8", d, [](int i, int j, int k, int* o) { o[0] = i, o[1] = j, o[2] = k; }, same, false);
  make("f32", d, [](int i, int j, int k, int* o) { o[0] = i, o[1] = j, o[2] = k; }, same, true);
  for (int ax = 0; ax < 3; ++ax) {
    static const char* names[3] = {"flip i", "flip j", "flip k"};
    make(names[ax], d,
         [&, ax](int i, int j, int k, int* o) {
           o[0] = i, o[1] = j, o[2] = k;
           o[ax] = d[ax] - 1 - o[ax];
         },
         [&, ax](double* A) {
           // world = A0 (i') with i' = D - 1 - i: column ax negated, origin moved.
           std::memcpy(A, A0, 16 * sizeof(double));
           for (int r = 0; r < 3; ++r) {
             A[4 * r + 3] += A0[4 * r + ax] * (d[ax] - 1);
             A[4 * r + ax] = -A0[4 * r + ax];
           }
         },
         false);
  }
  {
    // Variant axes (a, b, c) = original (j, k, i): variant voxel (a, b, c) is original (c, a, b).
    const int pd[3] = {d[1], d[2], d[0]};
    make("permute (j,k,i)", pd, [](int a, int b, int c, int* o) { o[0] = c, o[1] = a, o[2] = b; },
         [&](double* A) {
           std::memset(A, 0, 16 * sizeof(double));
           for (int r = 0; r < 3; ++r) {
             A[4 * r + 0] = A0[4 * r + 1];
             A[4 * r + 1] = A0[4 * r + 2];
             A[4 * r + 2] = A0[4 * r + 0];
             A[4 * r + 3] = A0[4 * r + 3];
           }
           A[15] = 1;
         },
         false);
  }
  const std::pair<int, const char*> structures[] = {{73, "putamen L"}, {74, "putamen R"}, {77, "thalamus L"},
                                                    {78, "thalamus R"}, {71, "caudate L"}, {72, "caudate R"},
                                                    {37, "hippocampus L"}, {38, "hippocampus R"}};
  const uint32_t n = std::getenv("FFSEG_N") ? uint32_t(std::atoi(std::getenv("FFSEG_N"))) : 12;
  const char* only = std::getenv("FFSEG_ONLY");
  std::printf("| structure |");
  for (size_t v = 1; v < vars.size(); ++v) std::printf(" %s |", vars[v].name);
  std::printf("\n|---|");
  for (size_t v = 1; v < vars.size(); ++v) std::printf("---|");
  std::printf("\n");
  for (auto& st : structures) {
    if (only && std::string(only).find(std::to_string(st.first)) == std::string::npos) continue;
    std::vector<uint8_t> truth(N);
    for (size_t i = 0; i < N; ++i) truth[i] = aal.data[i] == st.first;
    std::array<int, 3> ijk{};
    double depth = 0;
    REQUIRE(ffseg_tools::find_deepest_voxel(truth.data(), aal.dims, aal.spacing, &ijk, &depth));
    double c[3];
    for (int r = 0; r < 3; ++r)
      c[r] = A0[4 * r] * ijk[0] + A0[4 * r + 1] * ijk[1] + A0[4 * r + 2] * ijk[2] + A0[4 * r + 3];
    std::vector<uint8_t> ref;
    std::printf("| %s |", st.second);
    for (size_t v = 0; v < vars.size(); ++v) {
      const std::vector<uint8_t> m = segment(vars[v], c, depth / 2, n);
      std::vector<uint8_t> back(N, 0);
      for (size_t q = 0; q < N; ++q) back[vars[v].to_original[q]] = m[q];
      if (v == 0) {
        ref = back;
        continue;
      }
      std::printf(" %.4f |", dice(ref, back));
    }
    std::printf("\n");
  }
}
