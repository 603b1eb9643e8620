// roundtrip.cpp - the C API's round trip from C++: an engine in its workspace,
// a volume, a sphere placed, its mesh and voxel mask read back. Checks the
// counts the header promises (6 n^2 vertices; a closed mesh has 2 V - 4
// triangles) and that the mask's volume is near the sphere's.
#include <cmath>
#include <cstdio>
#include <vector>

#include "ffseg_engine.hpp"

int main() try {
  const uint32_t n = 12;
  ffseg_config cfg;
  ffseg_config_init_default(&cfg);
  cfg.mesh_resolution = n;
  ffseg_example::Engine engine(cfg);

  const int64_t dims[3] = {40, 40, 40};
  const double spacing[3] = {1.0, 1.0, 1.0};
  std::vector<float> voxels(size_t(dims[0] * dims[1] * dims[2]), 100.0f);
  const ffseg_volume vol = ffseg_example::volume(voxels.data(), FFSEG_F32, sizeof(float), dims, spacing);
  engine.check(ffseg_set_volume(engine.get(), &vol), "set_volume");
  const double centre[3] = {20.0, 19.5, 20.5}, radius = 9.0;
  engine.check(ffseg_init_sphere(engine.get(), 0, centre, radius), "init_sphere");

  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  engine.mesh(0, xyz, tris);
  double worst = 0;  // every vertex must lie on the sphere (float precision)
  for (size_t v = 0; v < xyz.size() / 3; ++v) {
    const double d = std::hypot(xyz[3 * v] - centre[0], xyz[3 * v + 1] - centre[1], xyz[3 * v + 2] - centre[2]);
    worst = std::fmax(worst, std::fabs(d - radius));
  }
  std::vector<uint8_t> mask(voxels.size());
  engine.check(ffseg_rasterize(engine.get(), 0, mask.data(), nullptr), "rasterize");
  size_t inside = 0;
  for (uint8_t m : mask) inside += m;
  const double ball = 4.0 / 3.0 * M_PI * radius * radius * radius;
  const size_t nv = xyz.size() / 3, nt = tris.size() / 3;
  std::printf("roundtrip (C++): %zu vertices, %zu triangles, off-sphere %.2g mm, %zu voxels inside (ball %.0f mm^3)\n",
              nv, nt, worst, inside, ball);
  const bool ok = nv == 6 * n * n && nt == 2 * nv - 4 && worst < 1e-4 && std::fabs(inside - ball) < 0.1 * ball;
  return ok ? 0 : 1;
} catch (const std::exception& ex) {
  std::fprintf(stderr, "roundtrip: %s\n", ex.what());
  return 1;
}
