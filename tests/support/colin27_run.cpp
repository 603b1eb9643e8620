#include "support/colin27_run.h"

#include <doctest/doctest.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "engine_volume.h"
#include "support/mesh_check.h"
#include "test_util.h"

namespace ffseg_test {

const char* const kColin27T1 = "/usr/share/mricron/templates/ch2.nii.gz";
const char* const kColin27Aal = "/usr/share/mricron/templates/aal.nii.gz";

ffseg_volume volume_of(const ffseg_tools::NiftiImage& img) { return ffseg_tools::engine_volume(img); }

void protocol_sphere(const ffseg_tools::NiftiImage& t1, const std::vector<uint8_t>& truth, double c[3], double* r) {
  std::array<int, 3> ijk{};
  double depth = 0;
  REQUIRE(ffseg_tools::find_deepest_voxel(truth.data(), t1.dims, t1.spacing, &ijk, &depth));
  const double* A = t1.index_to_world;
  for (int q = 0; q < 3; ++q) c[q] = A[4 * q] * ijk[0] + A[4 * q + 1] * ijk[1] + A[4 * q + 2] * ijk[2] + A[4 * q + 3];
  *r = depth / 2;
}

StructureResult segment_structure(const ffseg_tools::NiftiImage& t1, const ffseg_tools::NiftiImage& aal, int label,
                                  const char* name, uint32_t n, int max_steps, const StructureRunOptions& o) {
  StructureResult res;
  res.label = label;
  res.name = name;
  const size_t N = aal.data.size();
  std::vector<uint8_t> truth(N);
  for (size_t i = 0; i < N; ++i) truth[i] = aal.data[i] == label;
  double c[3], depth = 0;
  protocol_sphere(t1, truth, c, &depth);
  depth *= 2;  // the label's depth
  if (o.shift_mm)
    for (int r = 0; r < 3; ++r) c[r] += o.shift_mm[r];
  depth *= o.radius_scale;
  if (o.verbose) std::printf("label %d: centre %.1f,%.1f,%.1f radius %.2f\n", label, c[0], c[1], c[2], depth / 2);
  EngineBox eb(1, n, int64_t(1) << 23);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  if (o.tune) o.tune(p);
  if (o.partial_volume_steps >= 0) p.partial_volume_steps = uint32_t(o.partial_volume_steps);
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  ffseg_volume v = volume_of(t1);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, depth / 2) == FFSEG_OK);
  ffseg_step_info info;
  info.struct_size = sizeof info;
  MeshWatch watch;
  for (int s = 0; s < max_steps; ++s) {
    const auto t0 = std::chrono::steady_clock::now();  // ms: the step calls only
    const ffseg_status st = ffseg_step(eb.e, &info);
    res.ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    INFO(ffseg_last_error(eb.e));
    if (o.check_mesh && st >= 0) REQUIRE(watch.look(eb.e, 0));
    REQUIRE(st >= 0);
    res.steps = s + 1;
    if (o.print_steps)
      std::printf("  step %d: disp %.3f targets %u flips %u guard %u  guard_us %llu feat_us %llu\n", s + 1, info.mean_displacement_mm[0],
                  info.vertices_with_target[0], info.flips_avoided[0], info.intersections_avoided[0], (unsigned long long)info.stage_us[8], (unsigned long long)info.stage_us[7]);
    if (st == FFSEG_CONVERGED || st == FFSEG_DEGENERATE) break;  // at rest
  }
  res.intersections = watch.intersections;
  res.flips = watch.flips;
  std::vector<uint8_t> mask(N);
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  res.m = ffseg_tools::compare_masks(mask.data(), truth.data(), aal.dims, aal.spacing);
  if (o.mask_out) o.mask_out->swap(mask);
  return res;
}

}  // namespace ffseg_test
