// The workspace reserves only what the configuration uses, and its size for a
// few configurations is pinned, as TensorFlow Lite Micro pins its arenas.
#include <doctest/doctest.h>

#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "cli/workspace_budget.h"
#include "ffseg.h"

namespace {

size_t workspace(uint32_t n, uint32_t objects, uint32_t target_mode) {
  ffseg_config c;
  ffseg_config_init_default(&c);
  c.mesh_resolution = n;
  c.max_objects = objects;
  c.target_mode = target_mode;
  size_t bytes = 0;
  REQUIRE(ffseg_workspace_size(&c, &bytes) == FFSEG_OK);
  return bytes;
}

}  // namespace

TEST_CASE("workspace: pinned sizes of a few configurations (default max_roi_voxels = 2^22)") {
  // PINNED. These byte counts are the memory a caller must hand over; a change
  // to any of them must be deliberate (say why in the commit, update the
  // number here and in BENCHMARKS/README if quoted). Measured at 0.2.0 plus
  // the bounding regions of several objects (thesis chapter 6), with the C
  // API's 128-byte workspace guard:
  //   binary n = 12, 8 objects:   230 699 712 B (220.0 MiB: 2 442 304 B before the
  //                                 regions, which take 22 bytes per max_roi_voxels
  //                                 voxel for the shared fast marching and 4 per
  //                                 object for its arrival times, and the contact
  //                                 test's obstacles)
  //   intensity n = 12, 1 object:  19 925 504 B ( 19.0 MiB; one object has no
  //                                 region, 512 B of bookkeeping; 196 608 B less
  //                                 since the g table holds 16 384 entries, issue 19)
  //   intensity n = 33, 1 object:  38 520 512 B ( 36.7 MiB)
  //   binary n = 33, 1 object:     20 588 224 B ( 19.6 MiB; the envelope factor dominates)
  // 0.5.0: 32 B more per object (its step record keeps the guard's kept
  // share and held count and the far-target counts of the stall test),
  // rounded to the arena's 64-byte lines: +192 B for 8 objects, +64 B for 1.
  // Then 32 B more per object, in its smoothed crop's record (the contrast
  // range within Tukey's fences and the fences, issue 30): +256 B for 8
  // objects, the single objects' records within their lines.
  // 0.6.0: the engine's Config holds max_region_voxels (+64 B, one arena
  // line) and each RegionMap its cells (+72 B per object, +576 B for 8).
  // The contact test keeps its crossing pairs from one guard round to the
  // next (mesh_contact.h): 8 B per pair, room for a mesh's triangles + 64
  // (1 792 at n = 12): +14 336 B with several objects, none for one.
  // Then 16 B more per object, in its step record (the motion across the
  // surface and the fronts' advance of the binary rest rule): +128 B for 8
  // objects, the single objects' records within their lines.
  // Then the guard's speed for several objects (issue 30): each object keeps
  // its guard's fold-test cache (48 B a face for the normals, 1 B a face for
  // the splits, 24 B a vertex for the key: 63 120 B at n = 12, x8), and the
  // contact test flags per face (1 B) and per obstacle triangle (1 B):
  // +519 168 B for 8 objects at n = 12; the one-object engines only grow by
  // their records' new fields (+128 B).
  // Then the fold prevention's grid copies its points in bucket order (48 B
  // a vertex: two points each) and the displacements' lengths (8 B a
  // vertex): +48 384 B at n = 12, +365 952 B at n = 33, shared by the objects.
  // Then the fold prevention's cones of directions, one per bucket of its
  // grid at the bucket's first slot (32 B a slot, two slots a vertex; the
  // other slots hold the members' unit directions while a cone is built):
  // +55 296 B at n = 12, +418 176 B at n = 33, shared by the objects.
  // Then the fold prevention's second grid, over the targets its passes
  // after the first have moved (room for a target per vertex: 40 B a vertex
  // and a table of at least two buckets a vertex): +42 944 B at n = 12,
  // +327 232 B at n = 33, shared by the objects.
  // Then each object's crop keeps its decorrelated noise estimate (8 B in
  // its record): +64 B for 8 objects; the one-object engines' records keep
  // their rounded size.
  // Then the engine holds the room several objects' crops share and its
  // sweep scratch (crop_pool.h: three pointers, two counts and the scratch's
  // pointer): +128 B for every configuration of several objects (the
  // intensity ones are smaller for it, below).
  // Then each object's crop keeps its acquisition gain, the noise's lag and
  // the oversampled axes (24 B in its record, smoothing.h): +192 B for 8
  // objects, +64 B for one (a line more).
  // Then each object keeps its first crop's acquisition scale (8 B in its
  // record, object.h): +64 B for 8 objects; the one-object engines' records
  // keep their rounded size.
  // Then each object's crop keeps the bounds its samplers read as doubles
  // (96 B in its record, smoothing.h), converted once per crop instead of at
  // every sample: +768 B for 8 objects, +64 B for one.
  // Then the contact test lists the obstacle triangles it set up (4 B per
  // obstacle triangle instead of a 1 B flag, mesh_contact.h), so that its
  // grids' builds walk these alone: +36 288 B for 8 objects at n = 12, and
  // its count, a line more of every engine's scratch record (+64 B).
  // Then each object's model keeps whether its boundary is in view (a flag
  // in its record, intensity_model.h): +64 B for 8 objects; the one-object
  // engines' records keep their rounded size.
  // Then an obstacle's faces take their splits from its guard's cache where
  // that cache holds their corners (mesh_contact.h: the cache's splits and
  // key, 16 B per obstacle in the contact test and per object in the
  // engine's scratch): +256 B for 8 objects, none for one.
  // Then each object's guard cache keeps what failed its last line search
  // (a face and a flag, step_guard.h), asked first at the next step: +64 B
  // for 8 objects; the one-object engines' records keep their rounded size.
  // Then each object's bounding region keeps its last speed table (its key
  // in the record, bounding_region.h; the 16 KiB table itself only where
  // grey levels are allowed) and each model counts its generations (8 B in
  // its record, intensity_model.h): +384 B for 8 binary objects, +64 B for
  // one (a line more).
  CHECK(workspace(12, 8, FFSEG_TARGET_BINARY) == 231419328u);
  CHECK(workspace(12, 1, FFSEG_TARGET_INTENSITY) == 20072640u);
  CHECK(workspace(33, 1, FFSEG_TARGET_INTENSITY) == 39632384u);
  CHECK(workspace(33, 1, FFSEG_TARGET_BINARY) == 21700096u);
}

TEST_CASE("workspace: grey-level buffers are per object and only in intensity configurations") {
  // Whatever the pins say, the two modes differ by the grey-level block
  // (smoothed crops sized by max_roi_voxels, intensity models), and nothing
  // else: binary-only engines carry none of it. One object has its crop and
  // its sweep scratch to itself; several share one room of max_objects x
  // max_roi_voxels floats for their crops and one sweep scratch (crop_pool.h),
  // so eight hold at least eight crops' floats and less than eight blocks.
  const size_t per_object = workspace(12, 1, FFSEG_TARGET_INTENSITY) - workspace(12, 1, FFSEG_TARGET_BINARY);
  CHECK(per_object > 4 * (size_t(1) << 22));  // at least one float per crop voxel
  const size_t eight = workspace(12, 8, FFSEG_TARGET_INTENSITY) - workspace(12, 8, FFSEG_TARGET_BINARY);
  CHECK(eight > 8 * 4 * (size_t(1) << 22));
  CHECK(eight < 8 * per_object);
  CHECK(workspace(33, 1, FFSEG_TARGET_INTENSITY) - workspace(33, 1, FFSEG_TARGET_BINARY) == per_object);

  // max_roi_voxels sizes only the grey-level buffers.
  ffseg_config c;
  ffseg_config_init_default(&c);
  c.mesh_resolution = 12;
  c.target_mode = FFSEG_TARGET_BINARY;
  size_t small = 0, large = 0;
  c.max_roi_voxels = 0;
  REQUIRE(ffseg_workspace_size(&c, &small) == FFSEG_OK);
  c.max_roi_voxels = int64_t(1) << 30;
  REQUIRE(ffseg_workspace_size(&c, &large) == FFSEG_OK);
  CHECK(small == large);
}

TEST_CASE("workspace: a 0.1 ffseg_config (no target_mode) means intensity allowed, as before") {
  ffseg_config c;
  ffseg_config_init_default(&c);
  CHECK(c.target_mode == FFSEG_TARGET_INTENSITY);
  CHECK(c.reserved1 == 0);
  c.mesh_resolution = 12;
  // An old caller's struct ends at max_roi_voxels; what follows it in memory
  // is not the caller's and must not be read.
  c.struct_size = uint32_t(offsetof(ffseg_config, target_mode));
  c.target_mode = 0xDEADBEEF;
  size_t bytes = 0;
  REQUIRE(ffseg_workspace_size(&c, &bytes) == FFSEG_OK);
  CHECK(bytes == workspace(12, 1, FFSEG_TARGET_INTENSITY));
  c.struct_size -= 1;
  CHECK(ffseg_workspace_size(&c, &bytes) == FFSEG_ERR_STRUCT_SIZE);

  ffseg_config_init_default(&c);
  c.target_mode = 2;
  CHECK(ffseg_workspace_size(&c, &bytes) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::string(ffseg_last_error(nullptr)).find("config.target_mode") != std::string::npos);
  ffseg_config_init_default(&c);
  c.reserved1 = 1;
  CHECK(ffseg_workspace_size(&c, &bytes) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::string(ffseg_last_error(nullptr)).find("config.reserved1") != std::string::npos);
}

TEST_CASE("workspace: a binary-only engine is exact, refuses grey-level targets and still segments") {
  ffseg_config c;
  ffseg_config_init_default(&c);
  c.mesh_resolution = 8;
  c.target_mode = FFSEG_TARGET_BINARY;
  size_t bytes = 0;
  REQUIRE(ffseg_workspace_size(&c, &bytes) == FFSEG_OK);
  const size_t cap = (bytes + 63) / 64 * 64;
  void* ws = std::aligned_alloc(64, cap);
  REQUIRE(ws != nullptr);
  ffseg_engine* e = nullptr;
  CHECK(ffseg_create(&c, ws, bytes - 1, &e) == FFSEG_ERR_WORKSPACE_TOO_SMALL);
  REQUIRE(ffseg_create(&c, ws, bytes, &e) == FFSEG_OK);

  // A 16^3 grid, 1 mm voxels, a ball of radius 5 mm at its centre.
  std::vector<uint8_t> mask(16 * 16 * 16, 0);
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i) {
        const double x = i - 7.5, y = j - 7.5, z = k - 7.5;
        mask[size_t((k * 16 + j) * 16 + i)] = x * x + y * y + z * z <= 25 ? 1 : 0;
      }
  ffseg_volume v;
  std::memset(&v, 0, sizeof v);
  v.struct_size = sizeof v;
  v.voxel_type = FFSEG_U8;
  v.data = mask.data();
  v.data_bytes = mask.size();
  for (int a = 0; a < 3; ++a) v.dims[a] = 16;
  v.strides[0] = 1;
  v.strides[1] = 16;
  v.strides[2] = 256;
  for (int a = 0; a < 4; ++a) v.index_to_world[5 * a] = 1;
  v.rescale_slope = 1;
  REQUIRE(ffseg_set_volume(e, &v) == FFSEG_OK);

  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  CHECK(ffseg_set_params(e, &p) == FFSEG_ERR_INVALID_ARGUMENT);
  const std::string msg = ffseg_last_error(e);
  CHECK(msg.find("params.target_mode") != std::string::npos);
  CHECK(msg.find("binary-only") != std::string::npos);
  p.target_mode = FFSEG_TARGET_BINARY;
  REQUIRE(ffseg_set_params(e, &p) == FFSEG_OK);

  const double centre[3] = {7.5, 7.5, 7.5};
  REQUIRE(ffseg_init_sphere(e, 0, centre, 2.0) == FFSEG_OK);
  ffseg_status st = FFSEG_OK;
  for (int s = 0; s < 100 && st == FFSEG_OK; ++s) st = ffseg_step(e, nullptr);
  CHECK(st == FFSEG_CONVERGED);
  std::vector<float> xyz(6 * 8 * 8 * 3);
  size_t nv = 0, nt = 0;
  REQUIRE(ffseg_extract_mesh(e, 0, xyz.data(), xyz.size() / 3, nullptr, 0, &nv, &nt) == FFSEG_OK);
  double mean_r = 0;
  for (size_t q = 0; q < nv; ++q) {
    double r2 = 0;
    for (int a = 0; a < 3; ++a) r2 += (xyz[3 * q + a] - 7.5) * (xyz[3 * q + a] - 7.5);
    mean_r += std::sqrt(r2) / double(nv);
  }
  CHECK(mean_r == doctest::Approx(5.0).epsilon(0.1));  // grew from 2 mm onto the 5 mm ball
  ffseg_destroy(e);
  std::free(ws);
}

TEST_CASE("workspace: several objects reserve their bounding regions from max_roi_voxels, exactly") {
  // Per voxel of max_roi_voxels: the shared fast marching (float time, state
  // byte, heap slot, 8-byte heap entry, float speed) and seed byte, 22 bytes,
  // and each object's float arrival times. One object has no region.
  auto bytes = [](uint32_t objects, int64_t roi) {
    ffseg_config c;
    ffseg_config_init_default(&c);
    c.mesh_resolution = 12;
    c.max_objects = objects;
    c.target_mode = FFSEG_TARGET_BINARY;
    c.max_roi_voxels = roi;
    size_t b = 0;
    REQUIRE(ffseg_workspace_size(&c, &b) == FFSEG_OK);
    return b;
  };
  const int64_t r1 = int64_t(1) << 16, r2 = int64_t(1) << 18;
  for (uint32_t objects : {2u, 8u, 64u}) {
    CAPTURE(objects);
    CHECK(bytes(objects, r2) - bytes(objects, r1) == size_t(22 + 4 * objects) * size_t(r2 - r1));
  }
  CHECK(bytes(1, r2) == bytes(1, r1));
}

TEST_CASE("workspace: five abdominal organs on a 1 mm grid fit the tool's 400 MB; a 3 mm scan keeps full-resolution regions") {
  // Issue 30: liver, spleen, both kidneys and the vena cava in one engine on
  // the shared CT resampled to 1 mm (366 x 303 x 336 voxels) asked for
  // 2 403 435 648 B when every crop and region held the whole scan.
  ffseg_config c;
  ffseg_config_init_default(&c);
  c.max_objects = 5;
  c.mesh_resolution = 49;  // what the automatic resolution chose there
  const int64_t fine = int64_t(366) * 303 * 336, coarse = int64_t(122) * 101 * 112;
  const uint64_t budget = 400000000;
  const ffseg_cli::WorkspaceSizing s = ffseg_cli::size_workspace(c, fine, -1, -1, budget, int64_t(1) << 26);
  CAPTURE(s.bytes);
  CHECK(s.fits);
  CHECK(s.reduced);
  CHECK(s.bytes <= budget);
  c.max_roi_voxels = s.max_roi_voxels;
  c.max_region_voxels = s.max_region_voxels;
  size_t exact = 0;
  REQUIRE(ffseg_workspace_size(&c, &exact) == FFSEG_OK);
  CHECK(exact == s.bytes);
  // Room for the organs: the liver's largest smoothed crop there measured
  // 7 766 280 voxels and its largest region box 3 741 390 (cells of 2 voxels
  // hold it in an eighth).
  CHECK(s.max_roi_voxels >= 7766280);
  CHECK(s.max_region_voxels * 8 >= 3741390);
  // The 3 mm scan: everything holds the whole scan, as before issue 30.
  c.mesh_resolution = 23;
  const ffseg_cli::WorkspaceSizing t = ffseg_cli::size_workspace(c, coarse, -1, -1, budget, int64_t(1) << 26);
  CHECK(t.fits);
  CHECK_FALSE(t.reduced);
  CHECK(t.max_roi_voxels == coarse);
  CHECK(t.max_region_voxels == coarse);
  // Values given on the command line are kept, even over the budget.
  const ffseg_cli::WorkspaceSizing u = ffseg_cli::size_workspace(c, fine, fine, fine, budget, int64_t(1) << 26);
  CHECK(u.max_roi_voxels == fine);
  CHECK(u.max_region_voxels == fine);
  CHECK_FALSE(u.fits);
}

TEST_CASE("workspace: max_region_voxels sizes the regions alone, 22 + 4 per object bytes a voxel; 0 means max_roi_voxels") {
  auto bytes = [](int64_t roi, int64_t region) {
    ffseg_config c;
    ffseg_config_init_default(&c);
    c.mesh_resolution = 12;
    c.max_objects = 4;
    c.max_roi_voxels = roi;
    c.max_region_voxels = region;
    size_t b = 0;
    REQUIRE(ffseg_workspace_size(&c, &b) == FFSEG_OK);
    return b;
  };
  const int64_t r1 = int64_t(1) << 16, r2 = int64_t(1) << 18;
  CHECK(bytes(r1, r2) - bytes(r1, r1) == size_t(22 + 4 * 4) * size_t(r2 - r1));
  CHECK(bytes(r2, 0) == bytes(r2, r2));
  // With the regions fixed, max_roi_voxels sizes the crops: at least a float
  // per voxel per object, and no region byte.
  CHECK(bytes(r2, r1) - bytes(r1, r1) >= size_t(4 * 4) * size_t(r2 - r1));
  CHECK(bytes(r2, r1) - bytes(r1, r1) < size_t(4 * 4 + 22) * size_t(r2 - r1));
  ffseg_config c;
  ffseg_config_init_default(&c);
  CHECK(c.max_region_voxels == 0);
  c.max_region_voxels = (int64_t(1) << 40) + 1;
  size_t b = 1;
  CHECK(ffseg_workspace_size(&c, &b) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(std::string(ffseg_last_error(nullptr)).find("max_region_voxels") != std::string::npos);
  CHECK(b == 0);
}
