// Every failing call leaves a message, on the engine and in the thread's
// slot that ffseg_last_error(NULL) reads, and the slot always tells the
// latest failure.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "ffseg.h"
#include "test_util.h"

namespace {
bool has(const char* msg, const char* part) { return msg != nullptr && std::strstr(msg, part) != nullptr; }
}  // namespace

TEST_CASE("a NULL or dead engine: the call and the cause in ffseg_last_error(NULL), never an older message") {
  // An older failure of another call fills the thread's slot first.
  ffseg_config c;
  ffseg_config_init_default(&c);
  alignas(64) static unsigned char tiny[64];
  ffseg_engine* out = nullptr;
  REQUIRE(ffseg_create(&c, tiny, sizeof tiny, &out) == FFSEG_ERR_WORKSPACE_TOO_SMALL);
  REQUIRE(has(ffseg_last_error(nullptr), "create"));

  CHECK(ffseg_step(nullptr, nullptr) == FFSEG_ERR_NULL_POINTER);
  CHECK(has(ffseg_last_error(nullptr), "step: engine is NULL"));
  double v = 0;
  const double p[3] = {0, 0, 0};
  CHECK(ffseg_sample(nullptr, p, 0, &v) == FFSEG_ERR_NULL_POINTER);
  CHECK(has(ffseg_last_error(nullptr), "sample: engine is NULL"));
  CHECK(ffseg_init_sphere(nullptr, 0, p, 1) == FFSEG_ERR_NULL_POINTER);
  CHECK(has(ffseg_last_error(nullptr), "init_sphere"));
  CHECK(ffseg_set_params(nullptr, nullptr) == FFSEG_ERR_NULL_POINTER);
  CHECK(has(ffseg_last_error(nullptr), "set_params"));

  ffseg_test::EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  ffseg_destroy(eb.e);
  CHECK(ffseg_step(eb.e, nullptr) == FFSEG_ERR_MISUSE);
  CHECK(has(ffseg_last_error(nullptr), "step: not a live engine"));
  eb.e = nullptr;
}

TEST_CASE("ffseg_sample's errors leave messages on the engine and in the thread's slot") {
  ffseg_test::EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  const double p[3] = {1, 1, 1};
  double v = 0;
  CHECK(ffseg_sample(eb.e, p, 0, &v) == FFSEG_ERR_MISUSE);
  CHECK(has(ffseg_last_error(eb.e), "no volume"));
  CHECK(has(ffseg_last_error(nullptr), "no volume"));

  const int64_t dims[3] = {4, 4, 4};
  std::vector<uint8_t> vox(64, 1);
  const double A[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  ffseg_volume vol = ffseg_test::make_volume(vox.data(), FFSEG_U8, dims, A);
  REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
  CHECK(ffseg_sample(eb.e, p, 7, &v) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(has(ffseg_last_error(eb.e), "mode = 7"));
  const double bad[3] = {1, std::nan(""), 1};
  CHECK(ffseg_sample(eb.e, bad, 0, &v) == FFSEG_ERR_INVALID_ARGUMENT);
  CHECK(has(ffseg_last_error(eb.e), "not finite"));
  CHECK(ffseg_sample(eb.e, p, 0, nullptr) == FFSEG_ERR_NULL_POINTER);
  CHECK(has(ffseg_last_error(eb.e), "value is NULL"));
  CHECK(has(ffseg_last_error(nullptr), "value is NULL"));
  // A success clears the engine's message.
  CHECK(ffseg_sample(eb.e, p, 0, &v) == FFSEG_OK);
  CHECK(std::string(ffseg_last_error(eb.e)).empty());
}

TEST_CASE("every failing engine call names itself in ffseg_last_error(NULL)") {
  ffseg_test::EngineBox eb(1, 4);
  REQUIRE(eb.e != nullptr);
  const double p[3] = {0, 0, 0};
  std::vector<uint8_t> mask(8);
  float xyz[3];
  size_t nv = 0, nt = 0;
  CHECK(ffseg_step(eb.e, nullptr) < 0);
  CHECK(has(ffseg_last_error(nullptr), "step"));
  CHECK(ffseg_init_sphere(eb.e, 5, p, 1) < 0);
  CHECK(has(ffseg_last_error(nullptr), "object 5"));
  CHECK(ffseg_extract_mesh(eb.e, 0, xyz, 1, nullptr, 0, &nv, &nt) < 0);
  CHECK(std::string(ffseg_last_error(nullptr)).size() > 0);
  CHECK(std::string(ffseg_last_error(nullptr)) == ffseg_last_error(eb.e));
  CHECK(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) < 0);
  CHECK(has(ffseg_last_error(nullptr), "rasterize"));
  CHECK(ffseg_region_mask(eb.e, 0, mask.data(), nullptr) < 0);
  CHECK(has(ffseg_last_error(nullptr), "region_mask"));
  CHECK(ffseg_set_volume(eb.e, nullptr) < 0);
  CHECK(has(ffseg_last_error(nullptr), "set_volume"));
}
