// Small helpers shared by the tests: an engine in an owned workspace, volume
// descriptors, mesh extraction into vectors.
#pragma once
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "arena.h"
#include "cubesphere.h"
#include "ffseg.h"

namespace ffseg_test {

// Owned, 64-byte aligned memory for core structures carved from an Arena:
// carve(arena) runs once measuring and once on the memory (so every pointer
// it stores points into mem).
class ArenaBox {
 public:
  template <class F>
  explicit ArenaBox(F&& carve) {
    ffseg::Arena probe;
    carve(probe);
    mem_.resize(probe.used() + 64);
    void* base = reinterpret_cast<void*>((reinterpret_cast<uintptr_t>(mem_.data()) + 63) & ~uintptr_t(63));
    ffseg::Arena a(base, probe.used());
    carve(a);
    ok_ = a.ok();
  }
  bool ok() const { return ok_; }

 private:
  std::vector<unsigned char> mem_;
  bool ok_ = false;
};

struct EngineBox {
  void* ws = nullptr;
  size_t bytes = 0;
  ffseg_engine* e = nullptr;
  EngineBox(uint32_t objects, uint32_t n, int64_t max_roi = int64_t(1) << 22, int64_t max_region = 0) {
    ffseg_config c;
    ffseg_config_init_default(&c);
    c.max_objects = objects;
    c.mesh_resolution = n;
    c.max_roi_voxels = max_roi;
    c.max_region_voxels = max_region;
    if (ffseg_workspace_size(&c, &bytes) != FFSEG_OK) return;
    ws = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
    if (ffseg_create(&c, ws, bytes, &e) != FFSEG_OK) e = nullptr;
  }
  ~EngineBox() {
    ffseg_destroy(e);
    std::free(ws);
  }
  EngineBox(const EngineBox&) = delete;
  EngineBox& operator=(const EngineBox&) = delete;
};

inline size_t type_size(uint32_t t) {
  switch (t) {
    case FFSEG_U8: return 1;
    case FFSEG_I16: case FFSEG_U16: return 2;
    case FFSEG_I32: case FFSEG_F32: return 4;
    default: return 8;
  }
}

// A contiguous volume (i fastest) over data.
inline ffseg_volume make_volume(const void* data, uint32_t type, const int64_t dims[3], const double A[16]) {
  ffseg_volume v;
  std::memset(&v, 0, sizeof v);
  v.struct_size = sizeof v;
  v.voxel_type = type;
  v.data = data;
  const int64_t es = int64_t(type_size(type));
  v.data_bytes = uint64_t(dims[0] * dims[1] * dims[2] * es);
  for (int a = 0; a < 3; ++a) v.dims[a] = dims[a];
  v.strides[0] = es;
  v.strides[1] = es * dims[0];
  v.strides[2] = es * dims[0] * dims[1];
  std::memcpy(v.index_to_world, A, sizeof v.index_to_world);
  v.rescale_slope = 1;
  return v;
}

inline bool extract(ffseg_engine* e, uint32_t object, std::vector<float>* xyz, std::vector<uint32_t>* tris) {
  size_t nv = 0, nt = 0;
  if (ffseg_extract_mesh(e, object, nullptr, 0, nullptr, 0, &nv, &nt) != FFSEG_OK) return false;
  xyz->resize(3 * nv);
  tris->resize(3 * nt);
  return ffseg_extract_mesh(e, object, xyz->data(), nv, tris->data(), nt, &nv, &nt) == FFSEG_OK;
}

void triangles_of(const ffseg::CubeSphere& m, uint32_t* tris);

// The worst mesh defects over the meshes it is shown (after each step): pairs
// of crossing triangles (disjoint or sharing one vertex, mesh_check.h) and
// normal flips (neighbouring triangles with cos < -0.5). xyz and tris keep the
// last mesh extracted.
struct MeshWatch {
  size_t intersections = 0, flips = 0;
  size_t last_flips = 0;  // of the last mesh
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  // Extracts `object`'s mesh and counts its defects; false if extraction failed.
  bool look(ffseg_engine* e, uint32_t object);
};

template <class P>
double signed_volume(const P* xyz, const std::vector<uint32_t>& tris) {
  double v = 0;
  for (size_t t = 0; t < tris.size() / 3; ++t) {
    const P* a = xyz + 3 * tris[3 * t];
    const P* b = xyz + 3 * tris[3 * t + 1];
    const P* c = xyz + 3 * tris[3 * t + 2];
    v += double(a[0]) * (double(b[1]) * c[2] - double(b[2]) * c[1]) -
         double(a[1]) * (double(b[0]) * c[2] - double(b[2]) * c[0]) +
         double(a[2]) * (double(b[0]) * c[1] - double(b[1]) * c[0]);
  }
  return v / 6.0;
}
template <class P>
double signed_volume(const std::vector<P>& xyz, const std::vector<uint32_t>& tris) {
  return signed_volume(xyz.data(), tris);
}

}  // namespace ffseg_test
