// The refactoring check: per-step hashes of the cup's mesh (binary target,
// n = 21 and 33, alpha 0.3 and 0.7) and the final meshes of the eight Colin27
// structures (grey levels, n = 12, the PEERS protocol sphere). Run it before
// and after a change that must not alter behaviour and diff the outputs: the
// hash covers every coordinate bit of the extracted (float) mesh and the
// status of every step. Not a test: floating-point results differ between the
// x86 kernels and the portable code, so there is no one right answer to pin.
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "ffseg.h"
#include "metrics.h"
#include "nifti.h"
#include "../tests/support/phantoms.h"
#include "../tests/test_util.h"

namespace {

uint64_t fnv(const void* p, size_t n, uint64_t h = 1469598103934665603ull) {
  const unsigned char* b = static_cast<const unsigned char*>(p);
  for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}

uint64_t mesh_hash(ffseg_engine* e, uint32_t object, int status) {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  if (!ffseg_test::extract(e, object, &xyz, &tris)) return 0;
  return fnv(&status, sizeof status, fnv(xyz.data(), xyz.size() * sizeof(float)));
}

void cup(uint32_t n, double alpha) {
  const ffseg_test::Phantom ph = ffseg_test::cup_phantom();
  ffseg_test::EngineBox eb(1, n);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.step_size = alpha;
  ffseg_set_params(eb.e, &p);
  ffseg_volume v = ffseg_test::make_volume(ph.mask.data(), FFSEG_U8, ph.dims, ph.affine);
  ffseg_set_volume(eb.e, &v);
  ffseg_init_sphere(eb.e, 0, ph.center, 60);
  uint64_t h = 0;
  int s = 0;
  for (; s < 150; ++s) {
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    const uint64_t hs = mesh_hash(eb.e, 0, st);
    h = fnv(&hs, sizeof hs, h);
    if (st != FFSEG_OK) break;
  }
  std::printf("cup n=%u alpha=%.1f steps %d chain %016llx\n", n, alpha, s + 1, (unsigned long long)h);
}

void colin27() {
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  if (!ffseg_tools::nifti_read_file("/usr/share/mricron/templates/ch2.nii.gz", &t1, &err) ||
      !ffseg_tools::nifti_read_file("/usr/share/mricron/templates/aal.nii.gz", &aal, &err)) {
    std::printf("colin27: %s\n", err.c_str());
    return;
  }
  const int labels[] = {73, 74, 77, 78, 71, 72, 37, 38};
  for (int label : labels) {
    std::vector<uint8_t> truth(aal.data.size());
    for (size_t i = 0; i < truth.size(); ++i) truth[i] = aal.data[i] == label;
    std::array<int, 3> ijk{};
    double depth = 0;
    ffseg_tools::find_deepest_voxel(truth.data(), aal.dims, aal.spacing, &ijk, &depth);
    double c[3];
    for (int r = 0; r < 3; ++r)
      c[r] = t1.index_to_world[4 * r] * ijk[0] + t1.index_to_world[4 * r + 1] * ijk[1] +
             t1.index_to_world[4 * r + 2] * ijk[2] + t1.index_to_world[4 * r + 3];
    ffseg_test::EngineBox eb(1, 12, int64_t(1) << 23);
    ffseg_params p;
    ffseg_params_init_default(&p);
    p.target_mode = FFSEG_TARGET_INTENSITY;
    ffseg_set_params(eb.e, &p);
    const int64_t dims[3] = {t1.dims[0], t1.dims[1], t1.dims[2]};
    ffseg_volume v = ffseg_test::make_volume(t1.data.data(), uint32_t(t1.voxel_type), dims, t1.index_to_world);
    v.rescale_slope = t1.scl_slope;
    v.rescale_intercept = t1.scl_inter;
    ffseg_set_volume(eb.e, &v);
    ffseg_init_sphere(eb.e, 0, c, depth / 2);
    int s = 0;
    ffseg_status st = FFSEG_OK;
    for (; s < 200 && st == FFSEG_OK; ++s) st = ffseg_step(eb.e, nullptr);
    std::printf("colin27 label %d steps %d status %d mesh %016llx\n", label, s, int(st),
                (unsigned long long)mesh_hash(eb.e, 0, st));
  }
}

}  // namespace

int main() {
  for (uint32_t n : {21u, 33u})
    for (double a : {0.3, 0.7}) cup(n, a);
  colin27();
  return 0;
}
