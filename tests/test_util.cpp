#include "test_util.h"

#include "rasterize.h"

namespace ffseg_test {

void triangles_of(const ffseg::CubeSphere& m, uint32_t* tris) { ffseg::triangulate(m, m.unit, tris); }

}  // namespace ffseg_test
