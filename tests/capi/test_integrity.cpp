// Issue 20: the workspace guards its own integrity (a caller that scribbles
// over the engine's header, canaries or layout table gets MISUSE with a
// message, not a call reading garbage), and long runs stay put: stepping long
// after convergence and re-creating the engine a thousand times in one
// workspace give the same mesh bit for bit.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "../capi/capi_internal.h"  // the workspace layout behind the handle
#include "ffseg.h"
#include "test_util.h"

using ffseg_test::make_volume;

namespace {

constexpr int kN = 24;

// A ball of radius r voxels in a 24^3 u8 volume (1 mm voxels, shifted origin).
std::vector<uint8_t> ball(double cx, double cy, double cz, double r) {
  std::vector<uint8_t> v(size_t(kN) * kN * kN, 0);
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        const double d2 = (i - cx) * (i - cx) + (j - cy) * (j - cy) + (k - cz) * (k - cz);
        v[size_t(i + kN * (j + kN * k))] = d2 <= r * r ? 1 : 0;
      }
  return v;
}

const double kAffine[16] = {1, 0, 0, -12, 0, 1, 0, -10, 0, 0, 1, 3, 0, 0, 0, 1};

struct Setup {
  std::vector<uint8_t> data = ball(11.5, 12.5, 12, 7.5);
  ffseg_volume volume;
  double centre[3] = {-0.5, 2.5, 15};  // the ball's centre in mm
  Setup() {
    const int64_t dims[3] = {kN, kN, kN};
    volume = make_volume(data.data(), FFSEG_U8, dims, kAffine);
  }
};

ffseg_config small_config(uint32_t n) {
  ffseg_config c;
  ffseg_config_init_default(&c);
  c.max_objects = 1;
  c.mesh_resolution = n;
  c.max_roi_voxels = int64_t(1) << 16;
  return c;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

std::vector<float> mesh_of(ffseg_engine* e) {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  REQUIRE(ffseg_test::extract(e, 0, &xyz, &tris));
  return xyz;
}

// Every entry point that takes an engine, on a damaged one: MISUSE (and no
// read of the damaged state), the reason in ffseg_last_error.
void expect_refused_everywhere(ffseg_engine* e, const Setup& s, const char* reason) {
  CAPTURE(reason);
  ffseg_params p;
  ffseg_params_init_default(&p);
  CHECK(ffseg_set_params(e, &p) == FFSEG_ERR_MISUSE);
  CHECK(ffseg_set_volume(e, &s.volume) == FFSEG_ERR_MISUSE);
  CHECK(ffseg_init_sphere(e, 0, s.centre, 3.0) == FFSEG_ERR_MISUSE);
  CHECK(ffseg_step(e, nullptr) == FFSEG_ERR_MISUSE);
  double value = 0;
  CHECK(ffseg_sample(e, s.centre, FFSEG_SAMPLE_NEAREST, &value) == FFSEG_ERR_MISUSE);
  size_t nv = 0, nt = 0;
  CHECK(ffseg_extract_mesh(e, 0, nullptr, 0, nullptr, 0, &nv, &nt) == FFSEG_ERR_MISUSE);
  std::vector<uint8_t> mask(size_t(kN) * kN * kN);
  CHECK(ffseg_rasterize(e, 0, mask.data(), nullptr) == FFSEG_ERR_MISUSE);
  const std::string msg = ffseg_last_error(e);
  CHECK_MESSAGE(msg.find(reason) != std::string::npos, msg);
  // The thread's slot names the last call and why (for a damaged, not a
  // destroyed engine, the damage).
  const std::string tmsg = ffseg_last_error(nullptr);
  CHECK_MESSAGE(tmsg.rfind("rasterize: ", 0) == 0, tmsg);
}

}  // namespace

TEST_CASE("integrity: a scribbled workspace header, canary, engine header or layout table is MISUSE with a message") {
  using ffseg::capi::kGuardBytes;
  const Setup s;
  const ffseg_config cfg = small_config(6);
  size_t need = 0;
  REQUIRE(ffseg_workspace_size(&cfg, &need) == FFSEG_OK);
  unsigned char* ws = static_cast<unsigned char*>(std::aligned_alloc(64, need));
  REQUIRE(ws != nullptr);
  ffseg_engine* e = nullptr;
  REQUIRE(ffseg_create(&cfg, ws, need, &e) == FFSEG_OK);
  REQUIRE(reinterpret_cast<unsigned char*>(e) == ws);
  REQUIRE(ffseg_set_volume(e, &s.volume) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(e, 0, s.centre, 3.0) == FFSEG_OK);
  REQUIRE(ffseg_step(e, nullptr) == FFSEG_OK);
  const std::vector<float> before = mesh_of(e);

  // The first word of the engine's object that holds an address inside the
  // workspace: one entry of its layout table (an array the layout carved).
  size_t layout_word = 0;
  for (size_t w = 0; w < sizeof(ffseg::Engine) / 8 && layout_word == 0; ++w) {
    uint64_t v;
    std::memcpy(&v, ws + kGuardBytes + 8 * w, 8);
    if (v >= reinterpret_cast<uintptr_t>(ws) && v < reinterpret_cast<uintptr_t>(ws) + need)
      layout_word = kGuardBytes + 8 * w;
  }
  REQUIRE(layout_word != 0);

  struct Scribble {
    const char* what;
    size_t offset;  // into the workspace
    size_t length;
    const char* reason;
  };
  const Scribble cases[] = {
      {"the guard's magic", 0, 8, "not a live ffseg engine"},
      {"the guard's canary", offsetof(ffseg::capi::Guard, canary), 8, "guard in front of the engine"},
      {"the guard's layout map", offsetof(ffseg::capi::Guard, map), 1, "guard in front of the engine"},
      {"the whole guard (a memset)", 0, kGuardBytes, "not a live ffseg engine"},
      {"the tail canary", need - ffseg::capi::kTailBytes, 1, "canary after the engine"},
      {"the engine's header (its magic)", kGuardBytes, 4, "engine's header"},
      {"one entry of the layout table", layout_word, 8, "layout table"},
  };
  for (const Scribble& c : cases) {
    CAPTURE(c.what);
    std::vector<unsigned char> saved(ws + c.offset, ws + c.offset + c.length);
    for (size_t b = 0; b < c.length; ++b) ws[c.offset + b] ^= 0x5A;  // every byte changes
    expect_refused_everywhere(e, s, c.reason);
    // Put back, the engine is intact again: the check reads the state, it
    // does not latch, and the refusals changed nothing.
    std::memcpy(ws + c.offset, saved.data(), c.length);
    CHECK(ffseg_last_error(e)[0] == '\0');
    CHECK(same_bits(mesh_of(e), before));
  }

  // A workspace moved elsewhere by memcpy: its pointers still lead into the
  // old block, so the copy is refused (the guard's canary is keyed to its address).
  unsigned char* copy = static_cast<unsigned char*>(std::aligned_alloc(64, need));
  REQUIRE(copy != nullptr);
  std::memcpy(copy, ws, need);
  expect_refused_everywhere(reinterpret_cast<ffseg_engine*>(copy), s, "guard in front of the engine");
  std::free(copy);

  // The original still steps on, and destroy, then re-create, work as before.
  const ffseg_status st = ffseg_step(e, nullptr);
  CHECK((st == FFSEG_OK || st == FFSEG_CONVERGED));
  ffseg_destroy(e);
  CHECK(std::string(ffseg_last_error(e)) == "not a live ffseg engine");
  ffseg_engine* again = nullptr;
  REQUIRE(ffseg_create(&cfg, ws, need, &again) == FFSEG_OK);
  CHECK(ffseg_set_volume(again, &s.volume) == FFSEG_OK);
  ffseg_destroy(again);
  std::free(ws);
}

TEST_CASE("long run: 10,000 steps after convergence leave the mesh bit for bit where it converged") {
  const Setup s;
  for (uint32_t mode : {uint32_t(FFSEG_TARGET_BINARY), uint32_t(FFSEG_TARGET_INTENSITY)}) {
    CAPTURE(mode);
    ffseg_test::EngineBox eb(1, 6, int64_t(1) << 16);
    REQUIRE(eb.e != nullptr);
    ffseg_params p;
    ffseg_params_init_default(&p);
    p.target_mode = mode;
    REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
    REQUIRE(ffseg_set_volume(eb.e, &s.volume) == FFSEG_OK);
    REQUIRE(ffseg_init_sphere(eb.e, 0, s.centre, 3.0) == FFSEG_OK);
    ffseg_status st = FFSEG_OK;
    int steps = 0;
    for (; steps < 200 && st == FFSEG_OK; ++steps) st = ffseg_step(eb.e, nullptr);
    REQUIRE(st == FFSEG_CONVERGED);
    CHECK(steps > 2);  // it moved before it came to rest
    const std::vector<float> rest = mesh_of(eb.e);
    std::vector<uint8_t> rest_mask(size_t(kN) * kN * kN), mask(rest_mask.size());
    REQUIRE(ffseg_rasterize(eb.e, 0, rest_mask.data(), nullptr) == FFSEG_OK);
    ffseg_step_info info;
    std::memset(&info, 0, sizeof info);
    info.struct_size = sizeof info;
    int not_converged = 0, moved = 0;
    for (int k = 0; k < 10000; ++k) {
      if (ffseg_step(eb.e, &info) != FFSEG_CONVERGED) ++not_converged;
      if (info.mean_displacement_mm[0] != 0) ++moved;
    }
    CHECK(not_converged == 0);
    CHECK(moved == 0);
    CHECK(info.step_index == uint32_t(steps + 10000));
    CHECK(same_bits(mesh_of(eb.e), rest));
    REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
    CHECK(mask == rest_mask);
  }
}

TEST_CASE("long run: 1,000 create/set_volume/init/step/destroy cycles in one workspace give the same mesh") {
  const Setup s;
  const ffseg_config cfg = small_config(5);
  size_t need = 0;
  REQUIRE(ffseg_workspace_size(&cfg, &need) == FFSEG_OK);
  void* ws = std::aligned_alloc(64, need);
  REQUIRE(ws != nullptr);
  std::memset(ws, 0xA5, need);
  std::vector<float> first;
  int differing = 0, failed = 0;
  for (int cycle = 0; cycle < 1000; ++cycle) {
    ffseg_engine* e = nullptr;
    if (ffseg_create(&cfg, ws, need, &e) != FFSEG_OK || ffseg_set_volume(e, &s.volume) != FFSEG_OK ||
        ffseg_init_sphere(e, 0, s.centre, 3.0) != FFSEG_OK) {
      ++failed;
      ffseg_destroy(e);
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const ffseg_status st = ffseg_step(e, nullptr);
      if (st != FFSEG_OK && st != FFSEG_CONVERGED) ++failed;
    }
    const std::vector<float> xyz = mesh_of(e);
    if (cycle == 0) first = xyz;
    else if (!same_bits(xyz, first)) ++differing;
    ffseg_destroy(e);
  }
  CHECK(failed == 0);
  CHECK(differing == 0);
  // The mesh moved from the sphere: the cycles compared real work.
  ffseg_test::EngineBox fresh(1, 5, int64_t(1) << 16);
  REQUIRE(ffseg_set_volume(fresh.e, &s.volume) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(fresh.e, 0, s.centre, 3.0) == FFSEG_OK);
  CHECK(!same_bits(mesh_of(fresh.e), first));
  std::free(ws);
}
