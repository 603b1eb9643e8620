// Test hooks of the mesh layer (engine/testing.h gathers every layer's): the
// self-intersection test's certificate switch and the counters that show
// which path answered.
#pragma once
#include <cstdint>

#include "mesh_intersection.h"

namespace ffseg {

struct TriangleScratchTesting {
  // false: every yes/no query takes the plain grid path.
  static void use_certificate(TriangleScratch& s, bool on) { s.use_certificate_ = on; }
  // Yes/no queries the patch certificate decided.
  static uint32_t certified_calls(const TriangleScratch& s) { return s.certified_calls_; }
  // Guard steps that swapped the last step's fold-test cache in.
  static uint32_t reused_old_cache(const TriangleScratch& s) { return s.reused_old_cache_; }
};

}  // namespace ffseg
