#include "test_util.h"

#include "rasterize.h"
#include "triangulation.h"
#include "support/mesh_check.h"

namespace ffseg_test {

void triangles_of(const ffseg::CubeSphere& m, uint32_t* tris) { ffseg::triangulate(m, m.unit, tris); }

bool MeshWatch::look(ffseg_engine* e, uint32_t object) {
  if (!extract(e, object, &xyz, &tris)) return false;
  const size_t nv = xyz.size() / 3, nt = tris.size() / 3;
  const SelfIntersectionReport rep = check_self_intersections(xyz.data(), nv, tris.data(), nt);
  const size_t crossing = rep.disjoint_pairs + rep.shared_vertex_pairs;
  last_flips = count_normal_flips(xyz.data(), nv, tris.data(), nt, -0.5);
  if (crossing > intersections) intersections = crossing;
  if (last_flips > flips) flips = last_flips;
  return true;
}

}  // namespace ffseg_test
