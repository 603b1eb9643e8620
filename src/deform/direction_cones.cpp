#include "direction_cones.h"

#include <cmath>

namespace ffseg {

void DirectionCones::carve(Arena& a, uint32_t max_points) { cone = a.alloc<double>(size_t(4) * max_points); }

void DirectionCones::build(const SpatialGrid& grid, uint32_t nv, const double* d, const double* len,
                           const uint8_t* has) {
  grid.for_each_bucket([&](uint32_t first, uint32_t end) {
    // The members' unit directions go to their own slots (u[3] = 1 for a
    // member, 0 for a point the rule passes over), their sum is the axis;
    // the cone, written last, takes the first slot.
    double s[3] = {0, 0, 0};
    bool any = false;
    for (uint32_t k = first; k < end; ++k) {
      double* u = cone + 4 * size_t(k);
      const uint32_t id = grid.id_at(k);
      const uint32_t j = id < nv ? id : id - nv;
      u[3] = 0;
      if (!has[j] || !(len[j] > 0)) continue;
      if (!bounded(len[j])) {
        cone[4 * size_t(first) + 3] = -1;
        return;
      }
      any = true;
      u[3] = 1;
      const double r = 1 / len[j];
      for (int a = 0; a < 3; ++a) {
        u[a] = d[3 * size_t(j) + a] * r;
        s[a] += u[a];
      }
    }
    double* c = cone + 4 * size_t(first);
    if (!any) {
      c[3] = kNoMember;
      return;
    }
    const double n = std::sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    if (!(n > 0)) {
      c[3] = -1;
      return;
    }
    for (int a = 0; a < 3; ++a) s[a] /= n;
    // The least cosine of a member to the axis.
    double least = 1;
    for (uint32_t k = first; k < end; ++k) {
      const double* u = cone + 4 * size_t(k);
      if (u[3] == 0) continue;
      const double cj = s[0] * u[0] + s[1] * u[1] + s[2] * u[2];
      least = cj < least ? cj : least;
    }
    for (int a = 0; a < 3; ++a) c[a] = s[a];
    c[3] = least;
  });
}

}  // namespace ffseg
