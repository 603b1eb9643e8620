#include "mesh_resolution.h"

#include <cmath>

namespace ffseg_cli {

double mesh_area_mm2(const std::vector<float>& xyz, const std::vector<uint32_t>& tris) {
  double area = 0;
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    const float* a = &xyz[3 * size_t(tris[t])];
    const float* b = &xyz[3 * size_t(tris[t + 1])];
    const float* c = &xyz[3 * size_t(tris[t + 2])];
    const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
    const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
    const double w[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    area += 0.5 * std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  }
  return area;
}

uint32_t resolution_for_area(double area_mm2, double spacing_mm) {
  const double h = kEdgeVoxels * spacing_mm;
  if (!(area_mm2 > 0) || !(h > 0)) return kFirstResolution;
  const double n = std::ceil(std::sqrt(area_mm2 / 6.0) / h);
  if (!(n < double(kMaxAutoResolution))) return kMaxAutoResolution;
  return n > double(kFirstResolution) ? uint32_t(n) : kFirstResolution;
}

uint32_t rerun_resolution(uint32_t wanted) {
  return double(wanted) > kRerunFactor * double(kFirstResolution) ? wanted : 0;
}

}  // namespace ffseg_cli
