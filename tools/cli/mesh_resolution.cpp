#include "mesh_resolution.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

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

std::vector<double> quad_sides_mm(const std::vector<float>& xyz, const std::vector<uint32_t>& tris) {
  std::vector<double> sides;
  sides.reserve(tris.size() / 3 * 2);
  for (size_t t = 0; t + 2 < tris.size(); t += 3) {
    double len[3];
    for (int e = 0; e < 3; ++e) {
      const float* a = &xyz[3 * size_t(tris[t + e])];
      const float* b = &xyz[3 * size_t(tris[t + (e + 1) % 3])];
      const double d[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
      len[e] = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    }
    std::sort(len, len + 3);
    sides.push_back(len[0]);
    sides.push_back(len[1]);
  }
  return sides;
}

double quad_side_quantile_mm(const std::vector<float>& xyz, const std::vector<uint32_t>& tris, double q) {
  std::vector<double> sides = quad_sides_mm(xyz, tris);
  if (sides.empty()) return 0;
  const double qc = q < 0 ? 0 : (q > 1 ? 1 : q);
  const size_t k = size_t(qc * double(sides.size() - 1));
  std::nth_element(sides.begin(), sides.begin() + std::ptrdiff_t(k), sides.end());
  return sides[k];
}

uint32_t resolution_for_sides(double side_mm, uint32_t n_now, double spacing_mm) {
  const double h = kEdgeVoxels * spacing_mm;
  if (!(side_mm > 0) || !(h > 0)) return kFirstResolution;
  const double n = std::ceil(double(n_now) * side_mm / h);
  if (!(n < double(kMaxAutoResolution))) return kMaxAutoResolution;
  return n > double(kFirstResolution) ? uint32_t(n) : kFirstResolution;
}

uint32_t rerun_resolution(uint32_t wanted) {
  return double(wanted) > kRerunFactor * double(kFirstResolution) ? wanted : 0;
}

}  // namespace ffseg_cli
