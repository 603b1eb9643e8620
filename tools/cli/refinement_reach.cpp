#include "refinement_reach.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "mesh_resolution.h"

namespace ffseg_cli {

double enclosed_volume_mm3(const std::vector<float>& xyz, const std::vector<uint32_t>& tris) {
  double six_v = 0;
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    const float* a = &xyz[3 * size_t(tris[t])];
    const float* b = &xyz[3 * size_t(tris[t + 1])];
    const float* c = &xyz[3 * size_t(tris[t + 2])];
    six_v += double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) +
             double(a[1]) * (double(b[2]) * c[0] - double(b[0]) * c[2]) +
             double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  return six_v / 6.0;
}

double mean_quad_side_mm(const std::vector<float>& xyz, const std::vector<uint32_t>& tris) {
  double sum = 0;
  size_t n = 0;
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    double len[3];
    for (int e = 0; e < 3; ++e) {
      const float* a = &xyz[3 * size_t(tris[t + e])];
      const float* b = &xyz[3 * size_t(tris[t + (e + 1) % 3])];
      const double d[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
      len[e] = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    }
    std::sort(len, len + 3);
    sum += len[0] + len[1];
    n += 2;
  }
  return n ? sum / double(n) : 0.0;
}

double refinement_reach_mm3(const std::vector<float>& xyz, const std::vector<uint32_t>& tris) {
  return enclosed_volume_mm3(xyz, tris) + mesh_area_mm2(xyz, tris) * mean_quad_side_mm(xyz, tris);
}

}  // namespace ffseg_cli
