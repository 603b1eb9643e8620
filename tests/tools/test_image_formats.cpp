// Tests for tools/io/nrrd, tools/io/metaimage and tools/io/image_io: the writers' output
// read back bit for bit (every voxel type, an oblique anisotropic affine), the
// in-memory readers the fuzz target can call, and their refusals.
#include <doctest/doctest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "image_io.h"
#include "metaimage.h"
#include "nifti.h"
#include "nrrd.h"

using namespace ffseg_tools;

namespace {

struct TmpDir {
  std::string path;
  TmpDir() {
    char t[] = "/tmp/ffseg_formats_XXXXXX";
    REQUIRE(mkdtemp(t) != nullptr);
    path = t;
  }
  ~TmpDir() {
    const std::string cmd = "rm -rf '" + path + "'";
    if (std::system(cmd.c_str()) != 0) {
    }
  }
};

// A 7 x 5 x 4 image of `type` with distinct values, voxel axes rotated 30
// degrees about z and 0.7 / 1.3 / 2.1 mm long, origin off the grid.
NiftiImage oblique(int type) {
  NiftiImage im;
  im.dims[0] = 7, im.dims[1] = 5, im.dims[2] = 4;
  im.voxel_type = type;
  im.bytes_per_voxel = nifti_voxel_type_size(type);
  im.data.resize(size_t(im.voxel_count()) * size_t(im.bytes_per_voxel));
  for (size_t i = 0; i < size_t(im.voxel_count()); ++i) {
    const int64_t k = int64_t(i % 97);  // 0..96: every stored value in its type's range
    const double v = double(k) * 3 - 40 + 0.25;
    uint8_t* p = im.data.data() + i * size_t(im.bytes_per_voxel);
    switch (type) {
      case kNiftiVoxU8: { const uint8_t x = uint8_t(2 * k); std::memcpy(p, &x, 1); break; }
      case kNiftiVoxI16: { const int16_t x = int16_t(3 * k - 40); std::memcpy(p, &x, 2); break; }
      case kNiftiVoxU16: { const uint16_t x = uint16_t(600 * k); std::memcpy(p, &x, 2); break; }
      case kNiftiVoxI32: { const int32_t x = int32_t(300000 * k - 4000000); std::memcpy(p, &x, 4); break; }
      case kNiftiVoxF32: { const float x = float(v); std::memcpy(p, &x, 4); break; }
      default: { const double x = v / 3.0; std::memcpy(p, &x, 8); break; }
    }
  }
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6), L[3] = {0.7, 1.3, 2.1};
  const double R[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) im.index_to_world[4 * r + k] = R[3 * r + k] * L[k];
  im.index_to_world[3] = -12.3456789;
  im.index_to_world[7] = 45.6;
  im.index_to_world[11] = -0.1;
  return im;
}

}  // namespace

TEST_CASE("formats: NRRD and MetaImage writers read back every voxel type bit for bit") {
  TmpDir t;
  for (int type = kNiftiVoxU8; type <= kNiftiVoxF64; ++type) {
    const NiftiImage im = oblique(type);
    for (const ImageFormat f : {ImageFormat::Nrrd, ImageFormat::MetaImage, ImageFormat::Nifti}) {
      const std::string path = t.path + "/x" + std::to_string(type) + "." +
                               (f == ImageFormat::Nrrd ? "nrrd" : f == ImageFormat::MetaImage ? "mha" : "nii.gz");
      std::string err;
      REQUIRE_MESSAGE(image_write_file(path, f, im, &err), err);
      NiftiImage back;
      ImageFormat got;
      REQUIRE_MESSAGE(image_read_file(path, &back, &got, &err), err);
      CHECK(got == f);
      CHECK(back.voxel_type == type);
      CHECK(back.data == im.data);
      for (int a = 0; a < 3; ++a) CHECK(back.dims[a] == im.dims[a]);
      for (int k = 0; k < 16; ++k) {
        // NRRD keeps the axis vectors exactly; MetaImage splits them into a unit
        // direction and a spacing; NIfTI stores floats.
        const double tol = f == ImageFormat::Nrrd ? 0.0 : f == ImageFormat::MetaImage ? 1e-14 : 1e-5;
        CHECK_MESSAGE(std::fabs(back.index_to_world[k] - im.index_to_world[k]) <= tol, "format ", int(f), " k ", k);
      }
      CHECK(std::fabs(back.spacing[2] - 2.1) < 1e-6);
    }
  }
}

TEST_CASE("formats: in-memory NRRD and MetaImage (the fuzz entry points)") {
  const std::string nrrd =
      "NRRD0005\n# c\ntype: unsigned char\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
      "space: RAS\nspace directions: (2,0,0) (0,3,0) (0,0,4)\nspace origin: (1,2,3)\n\n";
  std::vector<uint8_t> buf(nrrd.begin(), nrrd.end());
  for (int i = 0; i < 8; ++i) buf.push_back(uint8_t(10 * i));
  NiftiImage im;
  std::string err;
  REQUIRE_MESSAGE(nrrd_read_memory(buf.data(), buf.size(), &im, &err), err);
  CHECK(im.data[7] == 70);
  CHECK(im.index_to_world[0] == 2.0);  // space RAS: as written
  CHECK(im.index_to_world[5] == 3.0);
  CHECK(im.index_to_world[7] == 2.0);
  // Every prefix of the file is refused, never read past.
  for (size_t n = 0; n + 1 < buf.size(); ++n) {
    NiftiImage x;
    std::string e;
    CHECK_FALSE(nrrd_read_memory(buf.data(), n, &x, &e));
    CHECK_FALSE(e.empty());
  }
  const std::string mha =
      "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\nElementType = MET_SHORT\n"
      "ElementSpacing = 1 1 2\nOffset = 5 6 7\nElementDataFile = LOCAL\n";
  std::vector<uint8_t> m(mha.begin(), mha.end());
  for (int i = 0; i < 8; ++i) {
    const int16_t v = int16_t(-3 * i);
    m.insert(m.end(), reinterpret_cast<const uint8_t*>(&v), reinterpret_cast<const uint8_t*>(&v) + 2);
  }
  REQUIRE_MESSAGE(metaimage_read_memory(m.data(), m.size(), &im, &err), err);
  int16_t last;
  std::memcpy(&last, im.data.data() + 14, 2);
  CHECK(last == -21);
  CHECK(im.index_to_world[3] == -5.0);  // LPS offset -> RAS
  CHECK(im.index_to_world[7] == -6.0);
  CHECK(im.index_to_world[11] == 7.0);
  CHECK(im.index_to_world[10] == 2.0);
  for (size_t n = 0; n + 1 < m.size(); ++n) {
    NiftiImage x;
    std::string e;
    CHECK_FALSE(metaimage_read_memory(m.data(), n, &x, &e));
  }
}

TEST_CASE("formats: writers refuse what they cannot write") {
  TmpDir t;
  NiftiImage im = oblique(kNiftiVoxU8);
  std::string err;
  CHECK_FALSE(nrrd_write_file(t.path + "/x.nhdr", im, &err));
  CHECK(err.find(".nrrd") != std::string::npos);
  CHECK_FALSE(metaimage_write_file(t.path + "/x.mhd", im, &err));
  im.data.pop_back();
  CHECK_FALSE(nrrd_write_file(t.path + "/x.nrrd", im, &err));
  CHECK_FALSE(metaimage_write_file(t.path + "/x.mha", im, &err));
  CHECK(std::string(label_file_name(ImageFormat::Dicom)) == "labels.nii.gz");
  ImageFormat f;
  CHECK(image_format_from_name("mha", &f));
  CHECK(f == ImageFormat::MetaImage);
  CHECK_FALSE(image_format_from_name("png", &f));
}
