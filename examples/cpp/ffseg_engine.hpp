// ffseg_engine.hpp - the examples' C++ wrapper over the C ABI: the workspace
// and the engine as one RAII object, errors as exceptions carrying the status
// and ffseg_last_error()'s message. Header-only; not part of the library.
#pragma once
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "ffseg.h"

namespace ffseg_example {

struct Error : std::runtime_error {
  ffseg_status status;
  Error(ffseg_status s, const std::string& what)
      : std::runtime_error(what + ": " + ffseg_status_string(s)), status(s) {}
};

class Engine {
 public:
  explicit Engine(const ffseg_config& cfg) {
    size_t bytes = 0;
    check_free(ffseg_workspace_size(&cfg, &bytes), "workspace_size");
    // aligned_alloc wants a size that is a multiple of the alignment.
    ws_.reset(std::aligned_alloc(64, (bytes + 63) / 64 * 64));
    if (!ws_) throw std::bad_alloc();
    check_free(ffseg_create(&cfg, ws_.get(), bytes, &e_), "create");
  }
  ~Engine() { ffseg_destroy(e_); }
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  ffseg_engine* get() const { return e_; }
  // Turns an error status into an Error with the engine's message; passes
  // FFSEG_OK and positive outcomes (FFSEG_CONVERGED) back.
  ffseg_status check(ffseg_status s, const char* call) const {
    if (s < 0) throw Error(s, std::string(call) + " (" + ffseg_last_error(e_) + ")");
    return s;
  }
  void mesh(uint32_t object, std::vector<float>& xyz, std::vector<uint32_t>& tris) const {
    size_t nv = 0, nt = 0;
    check(ffseg_extract_mesh(e_, object, nullptr, 0, nullptr, 0, &nv, &nt), "extract_mesh");
    xyz.resize(3 * nv);
    tris.resize(3 * nt);
    check(ffseg_extract_mesh(e_, object, xyz.data(), nv, tris.data(), nt, &nv, &nt), "extract_mesh");
  }

 private:
  static void check_free(ffseg_status s, const char* call) {
    if (s < 0) throw Error(s, std::string(call) + " (" + ffseg_last_error(nullptr) + ")");
  }
  struct Free {
    void operator()(void* p) const { std::free(p); }
  };
  std::unique_ptr<void, Free> ws_;
  ffseg_engine* e_ = nullptr;
};

// A contiguous u8/i16/... volume with axis-aligned voxels of the given spacing (mm).
inline ffseg_volume volume(const void* data, uint32_t type, size_t elem, const int64_t dims[3],
                           const double spacing[3]) {
  ffseg_volume v{};
  v.struct_size = sizeof v;
  v.voxel_type = type;
  v.data = data;
  v.data_bytes = uint64_t(dims[0] * dims[1] * dims[2]) * elem;
  for (int a = 0; a < 3; ++a) v.dims[a] = dims[a];
  v.strides[0] = int64_t(elem);
  v.strides[1] = int64_t(elem) * dims[0];
  v.strides[2] = int64_t(elem) * dims[0] * dims[1];
  v.index_to_world[0] = spacing[0];
  v.index_to_world[5] = spacing[1];
  v.index_to_world[10] = spacing[2];
  v.index_to_world[15] = 1.0;
  v.rescale_slope = 1.0;
  return v;
}

}  // namespace ffseg_example
