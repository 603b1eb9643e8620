// Tests for tools/io/dicom_planes: a grid's slices in DICOM terms (LPS), a
// sheared grid refused, Decimal Strings within 16 characters.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include "dicom_planes.h"
#include "nifti.h"

using namespace ffseg_tools;

TEST_CASE("dicom planes: directions, spacings and positions in LPS; a sheared grid refused") {
  NiftiImage g;
  g.dims[0] = 4, g.dims[1] = 3, g.dims[2] = 5;
  // RAS: i along +x by 0.5 mm, j along +y by 0.7 mm, k along +z by 2 mm, tilted.
  const double m[16] = {0.5, 0, 0, 10, 0, 0.7, 0.2, -20, 0, 0, 2, 30, 0, 0, 0, 1};
  for (int q = 0; q < 16; ++q) g.index_to_world[q] = m[q];
  DicomPlanes p;
  std::string err;
  REQUIRE_MESSAGE(dicom_planes(g, &p, &err), err);
  CHECK(p.row_dir[0] == -1.0);  // RAS +x is LPS -x
  CHECK(p.col_dir[1] == -1.0);
  CHECK(p.col_spacing == doctest::Approx(0.5));
  CHECK(p.row_spacing == doctest::Approx(0.7));
  CHECK(p.slice_thickness == doctest::Approx(2.0));  // the k step's part along the normal
  REQUIRE(p.positions.size() == 5);
  CHECK(p.positions[3][0] == doctest::Approx(-10));
  CHECK(p.positions[3][1] == doctest::Approx(20 - 0.6));
  CHECK(p.positions[3][2] == doctest::Approx(36));
  g.index_to_world[1] = 0.1;  // j leans towards i
  CHECK_FALSE(dicom_planes(g, &p, &err));
  CHECK(err.find("not orthogonal") != std::string::npos);
}

TEST_CASE("dicom planes: Decimal Strings hold at most 16 characters and read back closely") {
  const double values[] = {0, 1, -0.5, 1.0 / 3, -123.456789012345, 1e-7, -9.87654321e12, 65535.25};
  for (double v : values) {
    const std::string s = dicom_ds(v);
    CHECK(s.size() <= 16);
    CHECK(std::strtod(s.c_str(), nullptr) == doctest::Approx(v).epsilon(1e-9));
  }
  const double two[2] = {0.5, -2};
  CHECK(dicom_ds_list(two, 2) == "0.5\\-2");
}
