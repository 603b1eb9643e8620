// A u8 VolumeView over a test's voxels (i fastest) with a given affine, for
// the tests that call the core below the C API.
#pragma once
#include <cstdint>
#include <vector>

#include <doctest/doctest.h>

#include "ffseg.h"
#include "volume.h"

namespace ffseg_test {

inline ffseg::VolumeView u8_view(const std::vector<uint8_t>& vox, const int64_t dims[3], const double A[16]) {
  ffseg::VolumeDesc d{};
  d.type = FFSEG_U8;
  d.data = vox.data();
  d.data_bytes = vox.size();
  for (int a = 0; a < 3; ++a) d.dims[a] = dims[a];
  d.strides[0] = 1;
  d.strides[1] = dims[0];
  d.strides[2] = dims[0] * dims[1];
  for (int q = 0; q < 16; ++q) d.index_to_world[q] = A[q];
  d.slope = 1;
  ffseg::VolumeView view;
  char msg[256];
  REQUIRE(view.assign(d, msg, sizeof msg));
  return view;
}

}  // namespace ffseg_test
