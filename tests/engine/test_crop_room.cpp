// Several objects' smoothed crops share one room (crop_pool.h, issue 30):
// a large organ may hold more than max_roi_voxels while a small one holds
// less, with the same result as rooms of its own, and a clear error when the
// crops together do not fit.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "crop_pool.h"
#include "ffseg.h"
#include "test_util.h"

namespace {

// A large ball (radius 14 mm) and a small one (4 mm) in a 90 x 50 x 50 grid
// of 1 mm voxels, 200 inside, 50 outside, a deterministic ripple of +-6.
struct TwoBalls {
  int64_t dims[3] = {90, 50, 50};
  std::vector<uint8_t> v;
  TwoBalls() : v(size_t(90 * 50 * 50)) {
    for (int64_t k = 0; k < 50; ++k)
      for (int64_t j = 0; j < 50; ++j)
        for (int64_t i = 0; i < 90; ++i) {
          const double a = std::hypot(std::hypot(i - 25.0, j - 25.0), k - 25.0);
          const double b = std::hypot(std::hypot(i - 70.0, j - 25.2), k - 24.9);
          const double base = (a <= 14 || b <= 4) ? 200 : 50;
          v[size_t((k * 50 + j) * 90 + i)] = uint8_t(base + 6 * std::sin(0.9 * i + 1.7 * j + 2.3 * k));
        }
  }
};

struct Outcome {
  ffseg_status last = FFSEG_OK;
  std::string message;
  std::vector<std::vector<float>> steps[2];  // each object's vertices after each step
};

Outcome grow(int64_t max_roi) {
  const TwoBalls balls;
  Outcome out;
  ffseg_test::EngineBox eb(2, 12, max_roi);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  ffseg_volume vol = ffseg_test::make_volume(balls.v.data(), FFSEG_U8, balls.dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
  const double c0[3] = {25.2, 24.9, 25.1}, c1[3] = {70.1, 25.1, 24.8};
  REQUIRE(ffseg_init_sphere(eb.e, 0, c0, 5.0) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 1, c1, 2.5) == FFSEG_OK);
  std::vector<uint32_t> tris;
  for (int s = 0; s < 40; ++s) {
    out.last = ffseg_step(eb.e, nullptr);
    if (out.last < 0) {
      out.message = ffseg_last_error(eb.e);
      break;
    }
    for (uint32_t o = 0; o < 2; ++o) {
      std::vector<float> xyz;
      REQUIRE(ffseg_test::extract(eb.e, o, &xyz, &tris));
      out.steps[o].push_back(xyz);
    }
    if (out.last == FFSEG_CONVERGED) break;
  }
  return out;
}

}  // namespace

TEST_CASE("crop room: objects share their crops' room; a crop larger than max_roi_voxels fits beside a small one") {
  // The large ball's crops need up to about 160 000 voxels, the small
  // ball's about 120 000. Rooms of 2^20 each: the reference. A room of
  // 2 x 150 000 shared: the large crop takes more than 150 000, the small
  // one less, and every step's meshes are the same bit for bit (a crop's
  // values do not depend on where in the room it lies). 2 x 130 000 cannot
  // hold both: ROI_TOO_LARGE, naming the shared room.
  const Outcome ref = grow(int64_t(1) << 20);
  REQUIRE(ref.last >= 0);
  REQUIRE(ref.steps[0].size() >= 5);
  const Outcome shared = grow(150000);
  CAPTURE(shared.message);
  REQUIRE(shared.last == ref.last);
  REQUIRE(shared.steps[0].size() == ref.steps[0].size());
  for (uint32_t o = 0; o < 2; ++o)
    for (size_t s = 0; s < ref.steps[o].size(); ++s) {
      CAPTURE(o);
      CAPTURE(s);
      CHECK(shared.steps[o][s] == ref.steps[o][s]);
    }
  const Outcome tight = grow(130000);
  CHECK(tight.last == FFSEG_ERR_ROI_TOO_LARGE);
  CAPTURE(tight.message);
  CHECK(tight.message.find("shared room") != std::string::npos);
}

TEST_CASE("crop room: a span too short is given up, the others are moved down with their contents") {
  ffseg::CropPool room;
  const int64_t cap = 1000;
  std::vector<unsigned char> mem;
  {
    ffseg::Arena m;
    room.carve(m, cap, 3);
    mem.resize(m.used() + 64);
  }
  unsigned char* base = mem.data() + (64 - reinterpret_cast<uintptr_t>(mem.data()) % 64) % 64;
  ffseg::Arena a(base, mem.size() - 64);
  room.carve(a, cap, 3);
  REQUIRE(a.ok());
  float* buf[3] = {nullptr, nullptr, nullptr};
  for (uint32_t k = 0; k < 3; ++k) room.attach(k, &buf[k]);
  REQUIRE(room.acquire(0, 300) != nullptr);
  REQUIRE(room.acquire(1, 300) != nullptr);
  REQUIRE(room.acquire(2, 300) != nullptr);
  CHECK(buf[0] != nullptr);
  for (uint32_t k = 0; k < 3; ++k) {
    CHECK(reinterpret_cast<uintptr_t>(buf[k]) % 64 == 0);
    for (int i = 0; i < 300; ++i) buf[k][i] = float(1000 * k + i);
  }
  // Object 0 grows: its span is given up, the free room after the last span
  // is too short (1048 - 912), so objects 1 and 2 move down, contents kept.
  float* const old1 = buf[1];
  REQUIRE(room.acquire(0, 400) != nullptr);
  CHECK(buf[1] != old1);
  for (uint32_t k = 1; k < 3; ++k)
    for (int i = 0; i < 300; ++i) REQUIRE(buf[k][i] == float(1000 * k + i));
  CHECK(buf[0] > buf[2]);
  CHECK(room.held() == 304 + 304 + 400);
  // A span that fits in its own is kept where it is, and shrinks.
  float* const at = buf[0];
  CHECK(room.acquire(0, 100) == at);
  CHECK(room.held_by(0) == 112);
  // More than the room holds beside the others: refused, the asker left without a span.
  CHECK(room.acquire(1, 900) == nullptr);
  CHECK(buf[1] == nullptr);
  CHECK(room.held_by(1) == 0);
  for (int i = 0; i < 300; ++i) REQUIRE(buf[2][i] == float(2000 + i));
}
