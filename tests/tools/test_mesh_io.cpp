// Tests for tools/io/mesh_io.{h,cpp}: every format written and read back.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <unistd.h>

#include "mesh_io.h"

using namespace ffseg_tools;

namespace {

// An octahedron with awkward coordinates (negative, tiny, large).
struct Octa {
  std::vector<float> xyz = {1.5f, 0, 0, -1.25f, 0, 0, 0, 2.0e-7f, 0, 0, -3.75f, 0, 0, 0, 123456.78f, 0, 0, -0.1f};
  std::vector<uint32_t> tris = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
};

std::string temp_path(const char* ext) {
  char dir[] = "/tmp/ffseg_mesh_io_XXXXXX";
  REQUIRE(mkdtemp(dir) != nullptr);
  return std::string(dir) + "/mesh." + ext;
}

void remove_with_dir(const std::string& p) {
  std::remove(p.c_str());
  rmdir(p.substr(0, p.rfind('/')).c_str());
}

}  // namespace

TEST_CASE("mesh_io: format names") {
  MeshFormat f;
  CHECK((mesh_format_from_name("PLY", &f) && f == MeshFormat::Ply));
  CHECK((mesh_format_from_name("stl", &f) && f == MeshFormat::Stl));
  CHECK((mesh_format_from_name("obj", &f) && f == MeshFormat::Obj));
  CHECK((mesh_format_from_name("Vtk", &f) && f == MeshFormat::Vtk));
  CHECK_FALSE(mesh_format_from_name("off", &f));
  CHECK(std::string(mesh_format_extension(MeshFormat::Stl)) == "stl");
}

TEST_CASE("mesh_io: round trip of every format through a file") {
  const Octa m;
  for (MeshFormat f : {MeshFormat::Ply, MeshFormat::Stl, MeshFormat::Obj, MeshFormat::Vtk}) {
    CAPTURE(mesh_format_extension(f));
    const std::string path = temp_path(mesh_format_extension(f));
    std::string err;
    REQUIRE_MESSAGE(mesh_write_file(path, f, m.xyz.data(), 6, m.tris.data(), 8, "SPACE=RAS", &err), err);
    MeshData back;
    REQUIRE_MESSAGE(mesh_read_file(path, f, &back, &err), err);
    remove_with_dir(path);
    CHECK(back.triangle_count() == 8);
    CHECK(back.comment.find("SPACE=RAS") != std::string::npos);
    if (f == MeshFormat::Stl) {
      // No shared vertices in STL: three per triangle, in triangle order.
      REQUIRE(back.vertex_count() == 24);
      for (size_t t = 0; t < 8; ++t)
        for (int c = 0; c < 3; ++c)
          for (int k = 0; k < 3; ++k)
            CHECK(back.xyz[3 * back.tris[3 * t + c] + k] == m.xyz[3 * m.tris[3 * t + c] + k]);
    } else {
      REQUIRE(back.vertex_count() == 6);
      CHECK(back.tris == m.tris);
      // Binary PLY is bit exact; the text formats print 9 significant digits,
      // which read back to the same float.
      for (size_t i = 0; i < m.xyz.size(); ++i) CHECK(back.xyz[i] == m.xyz[i]);
    }
  }
}

TEST_CASE("mesh_io: PLY header and binary layout") {
  const Octa m;
  std::vector<uint8_t> bytes;
  std::string err;
  REQUIRE(mesh_encode(MeshFormat::Ply, m.xyz.data(), 6, m.tris.data(), 8, "hello", &bytes, &err));
  const std::string text(bytes.begin(), bytes.end());
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment hello\nelement vertex 6\nproperty float x\n"
      "property float y\nproperty float z\nelement face 8\nproperty list uchar int vertex_indices\nend_header\n";
  REQUIRE(text.compare(0, header.size(), header) == 0);
  CHECK(bytes.size() == header.size() + 6 * 12 + 8 * 13);
  // First vertex x = 1.5f little endian: 00 00 c0 3f.
  CHECK(bytes[header.size() + 2] == 0xc0);
  CHECK(bytes[header.size() + 3] == 0x3f);
}

TEST_CASE("mesh_io: STL normals are unit and outward for a CCW triangle") {
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint32_t tri[3] = {0, 1, 2};
  std::vector<uint8_t> bytes;
  std::string err;
  REQUIRE(mesh_encode(MeshFormat::Stl, xyz, 3, tri, 1, "", &bytes, &err));
  REQUIRE(bytes.size() == 84 + 50);
  CHECK(std::string(bytes.begin(), bytes.begin() + 5) != "solid");
  float n[3];
  std::memcpy(n, bytes.data() + 84, 12);
  CHECK(n[0] == 0.0f);
  CHECK(n[1] == 0.0f);
  CHECK(n[2] == 1.0f);
}

TEST_CASE("mesh_io: bad input is refused, not misread") {
  const Octa m;
  std::vector<uint8_t> bytes;
  std::string err;
  // Out-of-range index on write.
  std::vector<uint32_t> bad = m.tris;
  bad[5] = 6;
  CHECK_FALSE(mesh_encode(MeshFormat::Obj, m.xyz.data(), 6, bad.data(), 8, "", &bytes, &err));
  CHECK(err.find("vertex 6") != std::string::npos);

  // A truncated PLY.
  REQUIRE(mesh_encode(MeshFormat::Ply, m.xyz.data(), 6, m.tris.data(), 8, "", &bytes, &err));
  MeshData back;
  CHECK_FALSE(mesh_decode(MeshFormat::Ply, bytes.data(), bytes.size() - 1, &back, &err));
  // ASCII PLY is not read.
  const std::string ascii = "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n";
  CHECK_FALSE(mesh_decode(MeshFormat::Ply, reinterpret_cast<const uint8_t*>(ascii.data()), ascii.size(), &back, &err));
  // STL whose size does not match its count.
  REQUIRE(mesh_encode(MeshFormat::Stl, m.xyz.data(), 6, m.tris.data(), 8, "", &bytes, &err));
  bytes.push_back(0);
  CHECK_FALSE(mesh_decode(MeshFormat::Stl, bytes.data(), bytes.size(), &back, &err));
  // OBJ with a quad and with index 0.
  const std::string quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
  CHECK_FALSE(mesh_decode(MeshFormat::Obj, reinterpret_cast<const uint8_t*>(quad.data()), quad.size(), &back, &err));
  const std::string zero = "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 0 1 2\n";
  CHECK_FALSE(mesh_decode(MeshFormat::Obj, reinterpret_cast<const uint8_t*>(zero.data()), zero.size(), &back, &err));
  // VTK polygon index beyond the points.
  const std::string vtk =
      "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n"
      "POLYGONS 1 4\n3 0 1 3\n";
  CHECK_FALSE(mesh_decode(MeshFormat::Vtk, reinterpret_cast<const uint8_t*>(vtk.data()), vtk.size(), &back, &err));
}
