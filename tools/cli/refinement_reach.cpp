#include "refinement_reach.h"

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
  const std::vector<double> sides = quad_sides_mm(xyz, tris);
  double sum = 0;
  for (size_t i = 0; i + 1 < sides.size(); i += 2) sum += sides[i] + sides[i + 1];  // a triangle's pair at once
  return sides.empty() ? 0.0 : sum / double(sides.size());
}

double refinement_reach_mm3(const std::vector<float>& xyz, const std::vector<uint32_t>& tris) {
  return enclosed_volume_mm3(xyz, tris) + mesh_area_mm2(xyz, tris) * mean_quad_side_mm(xyz, tris);
}

}  // namespace ffseg_cli
