// A run that comes to rest without segmenting anything: FFSEG_DEGENERATE
// and the object flags of ffseg_step_info, instead of FFSEG_CONVERGED.
#include <doctest/doctest.h>

#include <cstddef>
#include <cstring>
#include <vector>

#include "ffseg.h"
#include "support/phantoms.h"
#include "test_util.h"

namespace {

const double kIdentity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

struct Outcome {
  ffseg_status last = FFSEG_OK;
  ffseg_step_info info{};
  int steps = 0;
  bool flags_while_moving = false;  // some step before the last reported a flag
};

// Steps until the engine leaves FFSEG_OK (or max_steps).
Outcome run(ffseg_engine* e, int max_steps = 120) {
  Outcome o;
  while (o.steps < max_steps) {
    std::memset(&o.info, 0xCD, sizeof o.info);
    o.info.struct_size = sizeof o.info;
    o.last = ffseg_step(e, &o.info);
    ++o.steps;
    if (o.last != FFSEG_OK) break;
    if (o.info.flags_all != 0) o.flags_while_moving = true;
  }
  return o;
}

struct Binary {
  ffseg_test::EngineBox eb;
  ffseg_volume v;
  Binary(const ffseg_test::Phantom& p, uint32_t objects = 1, double search_mm = 0) : eb(objects, 8, int64_t(1) << 18) {
    REQUIRE(eb.e != nullptr);
    ffseg_params prm;
    ffseg_params_init_default(&prm);
    prm.target_mode = FFSEG_TARGET_BINARY;
    prm.search_range_mm = search_mm;
    REQUIRE(ffseg_set_params(eb.e, &prm) == FFSEG_OK);
    v = ffseg_test::make_volume(p.mask.data(), FFSEG_U8, p.dims, p.affine);
    REQUIRE(ffseg_set_volume(eb.e, &v) == FFSEG_OK);
  }
  void place(uint32_t obj, const double c[3], double r) { REQUIRE(ffseg_init_sphere(eb.e, obj, c, r) == FFSEG_OK); }
  size_t voxels(uint32_t obj, size_t n) {
    std::vector<uint8_t> m(n);
    REQUIRE(ffseg_rasterize(eb.e, obj, m.data(), nullptr) == FFSEG_OK);
    size_t c = 0;
    for (uint8_t b : m) c += b;
    return c;
  }
};

}  // namespace

TEST_CASE("degenerate: a sphere in uniform background comes to rest flagged NO_BOUNDARY, not converged") {
  const int64_t dims[3] = {32, 32, 32};
  const ffseg_test::Phantom empty = ffseg_test::make_phantom(dims, kIdentity, [](const double*) { return false; });
  Binary b(empty);
  const double c[3] = {15.3, 16.1, 15.7};
  b.place(0, c, 5);
  const Outcome o = run(b.eb.e);
  CHECK(o.last == FFSEG_DEGENERATE);
  CHECK(o.info.object_flags[0] == FFSEG_OBJECT_NO_BOUNDARY);
  CHECK(o.info.flags_all == FFSEG_OBJECT_NO_BOUNDARY);
  CHECK(o.info.vertices_with_target[0] == 0);
  CHECK(o.info.reserved1 == 0u);
  for (uint32_t k = 1; k < FFSEG_REPORT_OBJECTS; ++k) CHECK(o.info.object_flags[k] == 0u);
  // Not a failure: no message, and the mesh is still there to read.
  CHECK(std::strlen(ffseg_last_error(b.eb.e)) == 0);
  CHECK(b.voxels(0, empty.mask.size()) > 0);
  // At rest it stays so: stepping on repeats the verdict.
  const Outcome again = run(b.eb.e, 1);
  CHECK(again.last == FFSEG_DEGENERATE);
  CHECK(again.info.object_flags[0] == FFSEG_OBJECT_NO_BOUNDARY);
}

TEST_CASE("degenerate: a sphere around a whole small phantom is flagged FILLS_GRID") {
  const double centre[3] = {12, 12, 12};
  const ffseg_test::Phantom ball = ffseg_test::ball_phantom(24, centre, 5);
  Binary b(ball);
  // 150 mm: far beyond the grid and the 80 mm search, so nothing pulls it in.
  b.place(0, centre, 150);
  const Outcome o = run(b.eb.e);
  CHECK(o.last == FFSEG_DEGENERATE);
  CHECK((o.info.object_flags[0] & FFSEG_OBJECT_FILLS_GRID) != 0);
  CHECK(b.voxels(0, ball.mask.size()) == ball.mask.size());  // every voxel labelled
}

TEST_CASE("degenerate: an object that leaks to the grid's walls is FILLS_GRID alone, a smaller one is not") {
  // Binary objects spanning the grid but for a one-voxel border of background
  // (the grid's 22^3 = 10,648 voxels, the object's 20^3 = 8,000: 75%), or
  // touching every wall (100%); the sphere grows from inside to the walls.
  const int64_t dims[3] = {22, 22, 22};
  for (int border : {0, 1}) {
    CAPTURE(border);
    const ffseg_test::Phantom box = ffseg_test::make_phantom(dims, kIdentity, [&](const double* w) {
      for (int a = 0; a < 3; ++a)
        if (w[a] < border - 0.5 || w[a] > 21.5 - border) return false;
      return true;
    });
    Binary b(box);
    const double c[3] = {10.6, 10.4, 10.5};
    b.place(0, c, 4);
    const Outcome o = run(b.eb.e, 200);
    const size_t inside = b.voxels(0, box.mask.size());
    MESSAGE("border " << border << ": " << o.steps << " steps, " << inside << " of " << box.mask.size()
                      << " voxels inside, status " << o.last);
    REQUIRE(o.last != FFSEG_OK);
    // The engine's rule is ffseg_rasterize's voxels against 80% of the grid.
    const bool most = double(inside) > 0.8 * double(box.mask.size());
    CHECK(most == (border == 0));
    CHECK(o.info.object_flags[0] == (most ? FFSEG_OBJECT_FILLS_GRID : 0u));
    CHECK(o.last == (most ? FFSEG_DEGENERATE : FFSEG_CONVERGED));
  }
}

TEST_CASE("degenerate: a normal phantom run converges with no flag at any step") {
  const double centre[3] = {20.2, 19.7, 20.4};
  const ffseg_test::Phantom ball = ffseg_test::ball_phantom(40, centre, 11);
  Binary b(ball);
  b.place(0, centre, 4);
  const Outcome o = run(b.eb.e);
  CHECK(o.last == FFSEG_CONVERGED);
  CHECK_FALSE(o.flags_while_moving);
  CHECK(o.info.object_flags[0] == 0u);
  CHECK(o.info.flags_all == 0u);
  CHECK(o.info.reserved1 == 0u);
  CHECK(std::strcmp(ffseg_status_string(FFSEG_DEGENERATE), ffseg_status_string(FFSEG_CONVERGED)) != 0);
}

TEST_CASE("degenerate: flags follow init_sphere and set_params, not the object's history") {
  // A ball in a corner-free middle; a 3 mm search from a far corner meets nothing.
  const double centre[3] = {24, 24, 24};
  const ffseg_test::Phantom ball = ffseg_test::ball_phantom(48, centre, 8);
  Binary b(ball, 1, 3.0);
  const double corner[3] = {6, 6, 6};
  b.place(0, corner, 3);
  Outcome o = run(b.eb.e);
  CHECK(o.last == FFSEG_DEGENERATE);
  CHECK(o.info.object_flags[0] == FFSEG_OBJECT_NO_BOUNDARY);
  // Placed again inside the ball, 2 mm from its surface: the first step finds it.
  b.place(0, centre, 6);
  o = run(b.eb.e, 1);
  CHECK(o.info.object_flags[0] == 0u);
  o = run(b.eb.e, 300);
  CHECK(o.last == FFSEG_CONVERGED);
  CHECK(o.info.flags_all == 0u);
  // New parameters restart the search: the mesh on the surface finds it again.
  ffseg_params prm;
  ffseg_params_init_default(&prm);
  prm.target_mode = FFSEG_TARGET_BINARY;
  prm.search_range_mm = 3.0;
  REQUIRE(ffseg_set_params(b.eb.e, &prm) == FFSEG_OK);
  o = run(b.eb.e, 300);
  CHECK(o.last == FFSEG_CONVERGED);
  CHECK(o.info.flags_all == 0u);
  // A new volume without the ball: the boundaries found in the old one do not count.
  const ffseg_test::Phantom empty =
      ffseg_test::make_phantom(ball.dims, kIdentity, [](const double*) { return false; });
  const ffseg_volume ev = ffseg_test::make_volume(empty.mask.data(), FFSEG_U8, empty.dims, kIdentity);
  REQUIRE(ffseg_set_volume(b.eb.e, &ev) == FFSEG_OK);
  o = run(b.eb.e);
  CHECK(o.last == FFSEG_DEGENERATE);
  CHECK(o.info.object_flags[0] == FFSEG_OBJECT_NO_BOUNDARY);
  // Back on the ball, in the corner: neither does a boundary found before placing.
  REQUIRE(ffseg_set_volume(b.eb.e, &b.v) == FFSEG_OK);
  b.place(0, centre, 6);
  REQUIRE(run(b.eb.e, 300).last == FFSEG_CONVERGED);
  b.place(0, corner, 3);
  o = run(b.eb.e);
  CHECK(o.last == FFSEG_DEGENERATE);
  CHECK(o.info.object_flags[0] == FFSEG_OBJECT_NO_BOUNDARY);
}

TEST_CASE("degenerate: each object has its own flags, the status is every object's") {
  const double centre[3] = {12, 24, 24};
  const ffseg_test::Phantom ball = ffseg_test::ball_phantom(48, centre, 8);
  Binary b(ball, 2, 3.0);
  const double far[3] = {40, 40, 40};
  b.place(0, centre, 6);  // 2 mm inside the ball's surface, within the 3 mm search
  b.place(1, far, 3);
  const Outcome o = run(b.eb.e, 300);
  CHECK(o.last == FFSEG_DEGENERATE);
  CHECK(o.info.object_flags[0] == 0u);
  CHECK(o.info.object_flags[1] == FFSEG_OBJECT_NO_BOUNDARY);
  CHECK(o.info.flags_all == FFSEG_OBJECT_NO_BOUNDARY);
}

TEST_CASE("degenerate: a caller of the 0.3 layout gets its fields and keeps the bytes past them") {
  const int64_t dims[3] = {24, 24, 24};
  const ffseg_test::Phantom empty = ffseg_test::make_phantom(dims, kIdentity, [](const double*) { return false; });
  Binary b(empty);
  const double c[3] = {12, 12, 12};
  b.place(0, c, 4);
  const size_t old_size = offsetof(ffseg_step_info, object_flags);
  ffseg_status st = FFSEG_OK;
  ffseg_step_info info;
  for (int s = 0; s < 120 && st == FFSEG_OK; ++s) {
    std::memset(&info, 0xAB, sizeof info);
    info.struct_size = uint32_t(old_size);
    st = ffseg_step(b.eb.e, &info);
    REQUIRE(st >= 0);
    CHECK(info.step_index == uint32_t(s + 1));
    CHECK(info.reserved0 == 0u);
    const unsigned char* tail = reinterpret_cast<const unsigned char*>(&info) + old_size;
    bool untouched = true;
    for (size_t q = 0; q < sizeof info - old_size; ++q) untouched = untouched && tail[q] == 0xAB;
    CHECK(untouched);
  }
  // Its loop ends as a loop on FFSEG_OK does; the status is not CONVERGED.
  CHECK(st == FFSEG_DEGENERATE);
  // One byte short of that layout is refused, and info is left as it was.
  std::memset(&info, 0xAB, sizeof info);
  info.struct_size = uint32_t(old_size - 1);
  CHECK(ffseg_step(b.eb.e, &info) == FFSEG_ERR_STRUCT_SIZE);
  CHECK(info.step_index == 0xABABABABu);
}

TEST_CASE("degenerate: a caller of the 0.5-0.7 layout gets the far counts and keeps the bytes past them") {
  const int64_t dims[3] = {24, 24, 24};
  const ffseg_test::Phantom ball =
      ffseg_test::make_phantom(dims, kIdentity, [](const double* p) {
        const double dx = p[0] - 12, dy = p[1] - 12, dz = p[2] - 12;
        return dx * dx + dy * dy + dz * dz <= 64.0;
      });
  Binary b(ball);
  const double c[3] = {12, 12, 12};
  b.place(0, c, 3);
  const size_t old_size = offsetof(ffseg_step_info, respaced);
  ffseg_step_info info;
  std::memset(&info, 0xAB, sizeof info);
  info.struct_size = uint32_t(old_size);
  REQUIRE(ffseg_step(b.eb.e, &info) == FFSEG_OK);
  CHECK(info.far_outward[0] != 0xABABABABu);  // the 0.5 fields are written
  const unsigned char* tail = reinterpret_cast<const unsigned char*>(&info) + old_size;
  bool untouched = true;
  for (size_t q = 0; q < sizeof info - old_size; ++q) untouched = untouched && tail[q] == 0xAB;
  CHECK(untouched);
  // The whole struct: a binary mesh growing from its sphere re-spaces its loops.
  info.struct_size = sizeof info;
  REQUIRE(ffseg_step(b.eb.e, &info) == FFSEG_OK);
  CHECK(info.respaced[0] == 1u);
  CHECK(info.respaced[1] == 0u);  // no object there
}
