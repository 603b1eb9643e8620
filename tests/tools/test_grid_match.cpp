// Tests for tools/geometry/grid_match: the same voxel centres in any axis
// order and direction are found and re-indexed exactly; grids that truly
// differ are refused naming what differs; nearest-neighbour resampling.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "grid_match.h"
#include "nifti.h"

using namespace ffseg_tools;

namespace {

// A 6 x 5 x 4 int16 image with value 100 i + 10 j + k at voxel (i, j, k),
// axes rotated 25 degrees about z, 0.8 / 1.1 / 2.0 mm.
NiftiImage reference() {
  NiftiImage im;
  im.dims[0] = 6, im.dims[1] = 5, im.dims[2] = 4;
  im.voxel_type = kNiftiVoxI16;
  im.bytes_per_voxel = 2;
  im.datatype = kNiftiDtInt16;
  im.data.resize(6 * 5 * 4 * 2);
  int16_t* d = reinterpret_cast<int16_t*>(im.data.data());
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 6; ++i) d[i + 6 * (j + 5 * k)] = int16_t(100 * i + 10 * j + k);
  const double a = 25 * M_PI / 180, s[3] = {0.8, 1.1, 2.0};
  const double m[16] = {std::cos(a) * s[0], -std::sin(a) * s[1], 0, 12.5, std::sin(a) * s[0], std::cos(a) * s[1], 0,
                        -40, 0, 0, s[2], 7.25, 0, 0, 0, 1};
  std::memcpy(im.index_to_world, m, sizeof m);
  for (int c = 0; c < 3; ++c) im.spacing[c] = s[c];
  im.which_affine = "sform";
  return im;
}

int16_t at(const NiftiImage& im, int i, int j, int k) {
  return reinterpret_cast<const int16_t*>(im.data.data())[i + im.dims[0] * (j + im.dims[1] * k)];
}

// The same image stored with its axes in order `perm` (new axis a = old axis
// perm[a]), the old axes in `flip` reversed: the voxel centres do not move.
NiftiImage restored(const NiftiImage& ref, const int perm[3], const bool flip[3]) {
  NiftiImage o = ref;
  for (int a = 0; a < 3; ++a) o.dims[a] = ref.dims[perm[a]];
  double m[16] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1};
  for (int r = 0; r < 3; ++r) {
    m[4 * r + 3] = ref.index_to_world[4 * r + 3];
    for (int c = 0; c < 3; ++c)
      if (flip[c]) m[4 * r + 3] += ref.index_to_world[4 * r + c] * (ref.dims[c] - 1);
    for (int a = 0; a < 3; ++a) m[4 * r + a] = (flip[perm[a]] ? -1 : 1) * ref.index_to_world[4 * r + perm[a]];
  }
  std::memcpy(o.index_to_world, m, sizeof m);
  for (int a = 0; a < 3; ++a) o.spacing[a] = ref.spacing[perm[a]];
  int16_t* d = reinterpret_cast<int16_t*>(o.data.data());
  for (int k = 0; k < ref.dims[2]; ++k)
    for (int j = 0; j < ref.dims[1]; ++j)
      for (int i = 0; i < ref.dims[0]; ++i) {
        int old[3] = {i, j, k}, n[3];
        for (int c = 0; c < 3; ++c) old[c] = flip[c] ? ref.dims[c] - 1 - old[c] : old[c];
        for (int a = 0; a < 3; ++a) n[a] = old[perm[a]];
        d[n[0] + o.dims[0] * (n[1] + o.dims[1] * n[2])] = at(ref, i, j, k);
      }
  return o;
}

}  // namespace

TEST_CASE("grid match: every permutation and reversal of the axes is re-indexed exactly") {
  const NiftiImage ref = reference();
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  int checked = 0;
  for (const auto& p : perms)
    for (int f = 0; f < 8; ++f) {
      const bool flip[3] = {bool(f & 1), bool(f & 2), bool(f & 4)};
      const NiftiImage other = restored(ref, p, flip);
      AxisMap m;
      std::string why;
      REQUIRE_MESSAGE(match_voxel_centres(ref, other, &m, &why), why);
      CHECK(m.identity() == (p[0] == 0 && p[1] == 1 && p[2] == 2 && f == 0));
      const NiftiImage back = reindex_to(ref, other, m);
      CHECK(back.data == ref.data);
      CHECK(std::memcmp(back.index_to_world, ref.index_to_world, sizeof ref.index_to_world) == 0);
      ++checked;
    }
  CHECK(checked == 48);
}

TEST_CASE("grid match: within a small fraction of a voxel, not beyond") {
  const NiftiImage ref = reference();
  const int perm[3] = {0, 1, 2};
  const bool flip[3] = {false, true, false};
  NiftiImage other = restored(ref, perm, flip);
  AxisMap m;
  std::string why;
  other.index_to_world[3] += 0.004;  // 0.005 voxel of the smallest spacing (0.8 mm)
  CHECK(match_voxel_centres(ref, other, &m, &why));
  other.index_to_world[3] += 0.4;  // half a voxel: another grid
  CHECK_FALSE(match_voxel_centres(ref, other, &m, &why));
  CHECK(why.find("voxel centres differ") != std::string::npos);
  CHECK(why.find("mm apart") != std::string::npos);
  NiftiImage smaller = ref;
  smaller.dims[2] = 3;
  CHECK_FALSE(match_voxel_centres(ref, smaller, &m, &why));
  CHECK(why == "dimensions differ (6x5x4 vs 6x5x3)");
}

TEST_CASE("grid match: nearest-neighbour resampling reads each centre's nearest voxel") {
  const NiftiImage ref = reference();
  NiftiImage shifted = ref;
  // Shifted by 0.3 voxel along i: every centre's nearest voxel is the same
  // index, except nothing beyond the grid.
  for (int r = 0; r < 3; ++r) shifted.index_to_world[4 * r + 3] += 0.3 * ref.index_to_world[4 * r];
  size_t outside = 99;
  NiftiImage r = resample_nearest(ref, shifted, &outside);
  CHECK(outside == 0);
  CHECK(r.data == ref.data);
  // Shifted by 1.6 voxels: voxel i reads i - 2, the first two columns are outside (0).
  for (int q = 0; q < 3; ++q) shifted.index_to_world[4 * q + 3] += 1.3 * ref.index_to_world[4 * q];
  r = resample_nearest(ref, shifted, &outside);
  CHECK(outside == size_t(2 * 5 * 4));
  CHECK(at(r, 0, 3, 2) == 0);
  CHECK(at(r, 1, 3, 2) == 0);
  CHECK(at(r, 4, 3, 2) == at(ref, 2, 3, 2));
}
