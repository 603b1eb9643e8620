#include "support/deform_run.h"

#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "../../capi/capi_internal.h"  // engine_of(): the naive-variant test hook
#include "engine.h"
#include "support/mesh_check.h"
#include "test_util.h"
#include "testing.h"

namespace ffseg_test {

DeformRunResult run_deform(const Phantom& ph, const DeformRunOptions& o) {
  DeformRunResult res;
  EngineBox eb(1, o.n);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.step_size = o.alpha;
  if (o.grey_noise >= 0) p.target_mode = FFSEG_TARGET_INTENSITY;
  if (o.search_range > 0) p.search_range_mm = o.search_range;
  if (o.convergence > 0) p.convergence_mm = o.convergence;
  if (o.tune) o.tune(p);
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  std::vector<float> grey;
  if (o.grey_noise >= 0) {
    // Box-Muller on a fixed-seed engine: the same noise on every platform.
    std::mt19937_64 rng(1);
    const double two_pi = 6.283185307179586, scale = 1.0 / 18446744073709551616.0;
    grey.resize(ph.mask.size());
    for (size_t q = 0; q < grey.size(); ++q) {
      const double u1 = (double(rng()) + 1.0) * scale, u2 = double(rng()) * scale;
      const double z = std::sqrt(-2.0 * std::log(u1)) * std::cos(two_pi * u2);
      grey[q] = float((ph.mask[q] ? 100.0 : 0.0) + o.grey_noise * z);
    }
  }
  ffseg_volume v = grey.empty() ? make_volume(ph.mask.data(), FFSEG_U8, ph.dims, ph.affine)
                                : make_volume(grey.data(), FFSEG_F32, ph.dims, ph.affine);
  REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, o.center, o.radius) == FFSEG_OK);
  if (o.naive) ffseg::EngineTesting::set_naive(*ffseg::capi::engine_of(eb.e), true);
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  ffseg_step_info info;
  info.struct_size = sizeof info;
  for (int s = 0; s < o.max_steps; ++s) {
    res.last = ffseg_step(eb.e, &info);
    REQUIRE(res.last >= 0);
    res.steps = s + 1;
    if (o.check_every_step || res.last == FFSEG_CONVERGED || s + 1 == o.max_steps) {
      REQUIRE(extract(eb.e, 0, &xyz, &tris));
      const SelfIntersectionReport rep = check_self_intersections(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3);
      const size_t bad = rep.disjoint_pairs + rep.shared_vertex_pairs;
      const size_t flips = count_normal_flips(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3, -0.5);
      if (bad > res.intersections) res.intersections = bad;
      if (o.verbose) std::printf("  [step %d: %zu intersecting pairs, %zu normal flips]\n", s + 1, bad, flips);
      if (flips > res.flips) res.flips = flips;
      res.closed = res.closed && is_closed_oriented_manifold(xyz.data(), xyz.size() / 3, tris.data(), tris.size() / 3);
    }
    if (o.verbose)
      std::printf("  step %3d disp %.4f targets %u flips %u folds %u | search %llu flips %llu diff %llu inter %llu asm %llu fact %llu solve %llu us\n",
                  s + 1, info.mean_displacement_mm[0], info.vertices_with_target[0], info.flips_avoided[0],
                  info.intersections_avoided[0], (unsigned long long)info.stage_us[0], (unsigned long long)info.stage_us[1],
                  (unsigned long long)info.stage_us[2], (unsigned long long)info.stage_us[3],
                  (unsigned long long)info.stage_us[4], (unsigned long long)info.stage_us[5],
                  (unsigned long long)info.stage_us[6]);
    if (o.after_step) o.after_step(s + 1, eb.e, info);
    if (res.last == FFSEG_CONVERGED) {
      res.converged = true;
      break;
    }
  }
  std::vector<uint8_t> mask(ph.mask.size());
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  res.dice = dice(mask, ph.mask);
  return res;
}

}  // namespace ffseg_test
