// The parameter table (src/engine/param_table.h) against its three readers:
// the public ffseg_params in include/ffseg.h (layout and init_default), the
// engine's Params and check_params (through the C API's copy in), and the
// CLI's --param table (tools/cli/param_args.h).
#include <doctest/doctest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "../../capi/capi_internal.h"  // engine_of()
#include "cli/param_args.h"
#include "engine.h"
#include "ffseg.h"
#include "param_table.h"

namespace {

size_t kind_size(ffseg::ParamKind k) { return k == ffseg::ParamKind::U32 ? 4 : 8; }

double read_field(const ffseg_params& p, size_t offset, ffseg::ParamKind k) {
  const char* at = reinterpret_cast<const char*>(&p) + offset;
  if (k == ffseg::ParamKind::U32) {
    uint32_t v;
    std::memcpy(&v, at, 4);
    return v;
  }
  double v;
  std::memcpy(&v, at, 8);
  return v;
}

// The engine's Params field i as a double, through the table's order.
double engine_field(const ffseg::Params& q, unsigned i) {
  const double v[] = {
#define FFSEG_TEST_VALUE(name, ctype, kind, def, lo, hi, bounds, unit, doc) double(q.name),
      FFSEG_PARAM_TABLE(FFSEG_TEST_VALUE)
#undef FFSEG_TEST_VALUE
  };
  return v[i];
}

struct SmallEngine {
  void* ws = nullptr;
  ffseg_engine* e = nullptr;
  SmallEngine() {
    ffseg_config c;
    ffseg_config_init_default(&c);
    c.mesh_resolution = 2;
    c.max_roi_voxels = 0;
    size_t bytes = 0;
    REQUIRE(ffseg_workspace_size(&c, &bytes) == FFSEG_OK);
    ws = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
    REQUIRE(ffseg_create(&c, ws, bytes, &e) == FFSEG_OK);
  }
  ~SmallEngine() {
    ffseg_destroy(e);
    std::free(ws);
  }
  // The engine sits behind the workspace guard (capi/capi_internal.h).
  const ffseg::Params& params() const { return ffseg::capi::engine_of(e)->params(); }
};

}  // namespace

TEST_CASE("params: the table lists every ffseg_params field, in the header's order") {
  // ffseg.h promises no implicit padding, so consecutive fields touch: the
  // first field follows struct_size, each next one starts where the previous
  // ends, except that the 0.2 layout's last field, reserved1 (4 bytes), sits
  // between partial_volume_steps and the 0.3 fields. A field added to the
  // header but not to the table (or the reverse, or two swapped) breaks this.
  size_t at = sizeof(uint32_t);  // struct_size
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ffseg_cli::ParamField f = ffseg_cli::param_field(i);
    CAPTURE(f.spec->name);
    if (at == offsetof(ffseg_params, reserved1)) at += sizeof(uint32_t);
    CHECK(f.offset == at);
    at = f.offset + kind_size(f.spec->kind);
  }
  CHECK(offsetof(ffseg_params, reserved1) == offsetof(ffseg_params, partial_volume_steps) + sizeof(uint32_t));
  CHECK(offsetof(ffseg_params, region_width_mm) == offsetof(ffseg_params, reserved1) + sizeof(uint32_t));
  // grey_respacing (0.7.0) took the tail padding that reserved2 filled.
  CHECK(offsetof(ffseg_params, grey_respacing) == offsetof(ffseg_params, region_interval) + sizeof(uint32_t));
  CHECK(at == sizeof(ffseg_params));
}

TEST_CASE("params: init_default, the engine's Params and the table agree on every default") {
  ffseg_params p;
  std::memset(&p, 0xA5, sizeof p);  // init_default must write every field
  ffseg_params_init_default(&p);
  CHECK(p.struct_size == sizeof(ffseg_params));
  CHECK(p.reserved1 == 0);
  const ffseg::Params q;
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ffseg_cli::ParamField f = ffseg_cli::param_field(i);
    CAPTURE(f.spec->name);
    CHECK(read_field(p, f.offset, f.spec->kind) == f.spec->default_value);
    CHECK(engine_field(q, i) == f.spec->default_value);
    CHECK(ffseg::param_in_range(*f.spec, f.spec->default_value));
    CHECK(f.spec->doc[0] != '\0');
  }
  // The automatic search ranges the header documents (search_range_mm = 0).
  ffseg::Params b;
  b.target_mode = ffseg::TargetMode::binary;
  CHECK(b.range_mm() == 80.0);
  b.target_mode = ffseg::TargetMode::intensity;
  CHECK(b.range_mm() == 20.0);
  b.search_range_mm = 7;
  CHECK(b.range_mm() == 7.0);
}

TEST_CASE("params: ffseg_set_params copies every field in and refuses each one beyond its range") {
  SmallEngine en;
  // In: a distinct in-range value per field arrives in the engine's Params.
  ffseg_params p;
  ffseg_params_init_default(&p);
  double want[ffseg::kParamCount];
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ffseg_cli::ParamField f = ffseg_cli::param_field(i);
    const ffseg::ParamSpec& s = *f.spec;
    // Inside the range and unlike every default: lo + a field-specific step.
    double v = s.kind == ffseg::ParamKind::U32 ? s.lo + 1 + (i % 2) : s.lo + (s.hi - s.lo) * (0.1 + 0.01 * i);
    if (v > s.hi) v = s.hi;
    REQUIRE(ffseg::param_in_range(s, v));
    want[i] = v;
    ffseg_cli::write_param(&p, f, v);
  }
  REQUIRE(ffseg_set_params(en.e, &p) == FFSEG_OK);
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    CAPTURE(ffseg::kParamSpecs[i].name);
    CHECK(engine_field(en.params(), i) == want[i]);
  }

  // Refusals: just beyond each bound (and at an open one), the message names
  // the field and the table's range; the engine keeps the previous values.
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ffseg_cli::ParamField f = ffseg_cli::param_field(i);
    const ffseg::ParamSpec& s = *f.spec;
    char range[48];
    ffseg::param_range_text(s, range, sizeof range);
    const bool lo_open = s.bounds == ffseg::ParamBounds::OC || s.bounds == ffseg::ParamBounds::OO;
    const bool hi_open = s.bounds == ffseg::ParamBounds::CO || s.bounds == ffseg::ParamBounds::OO;
    double bad[3];
    int nbad = 0;
    if (s.kind == ffseg::ParamKind::U32) {
      if (s.lo > 0) bad[nbad++] = s.lo - 1;
      if (s.hi < 4294967295.0) bad[nbad++] = s.hi + 1;
    } else {
      bad[nbad++] = lo_open ? s.lo : s.lo - 1e-9 * (1 + s.hi);
      bad[nbad++] = hi_open ? s.hi : s.hi * (1 + 1e-12) + 1e-9;
      bad[nbad++] = std::nan("");
    }
    REQUIRE(nbad > 0);
    for (int k = 0; k < nbad; ++k) {
      CAPTURE(s.name);
      CAPTURE(bad[k]);
      REQUIRE_FALSE(ffseg::param_in_range(s, bad[k]));
      ffseg_params q = p;
      ffseg_cli::write_param(&q, f, bad[k]);
      CHECK(ffseg_set_params(en.e, &q) == FFSEG_ERR_INVALID_ARGUMENT);
      const std::string msg = ffseg_last_error(en.e);
      CHECK(msg.find(std::string("params.") + s.name + " = ") != std::string::npos);
      CHECK(msg.find(range) != std::string::npos);
      CHECK(engine_field(en.params(), i) == want[i]);
    }
  }
}

TEST_CASE("params: range text is written as include/ffseg.h writes it") {
  char b[48];
  auto spec = [](const char* name) -> const ffseg::ParamSpec& {
    const ffseg_cli::ParamField f = ffseg_cli::param_field_named(name);
    REQUIRE(f.spec != nullptr);
    return *f.spec;
  };
  CHECK(std::string(ffseg::param_range_text(spec("lambda_laplacian"), b, sizeof b)) == "(0, 1e6]");
  CHECK(std::string(ffseg::param_range_text(spec("flip_tau"), b, sizeof b)) == "[0, 1)");
  CHECK(std::string(ffseg::param_range_text(spec("lambda_position"), b, sizeof b)) == "[1e-6, 1e6]");
  CHECK(std::string(ffseg::param_range_text(spec("intensity_gamma"), b, sizeof b)) == "(0, 1)");
  CHECK(std::string(ffseg::param_range_text(spec("search_range_mm"), b, sizeof b)) == "[0, 1e4]");
  CHECK(std::string(ffseg::param_range_text(spec("consecutive_background"), b, sizeof b)) == "1..64");
  CHECK(std::string(ffseg::param_range_text(spec("bin_min_count"), b, sizeof b)) == "0..2^31");
}

namespace {
std::string read_text(const std::string& path) {
  std::string s;
  if (FILE* f = std::fopen(path.c_str(), "rb")) {
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) s.append(buf, n);
    std::fclose(f);
  }
  return s;
}
}  // namespace

TEST_CASE("params: include/ffseg.h documents each field with the table's range and default") {
  // The header's struct is written by hand (it must stand alone); its comments
  // are what callers read. Each field's comment, the text from its declaration
  // to the next field's, names the table's range and "default <value>".
  const std::string h = read_text(std::string(FFSEG_SOURCE_DIR) + "/include/ffseg.h");
  const size_t begin = h.find("typedef struct ffseg_params {"), end = h.find("} ffseg_params;");
  REQUIRE(begin != std::string::npos);
  REQUIRE(end != std::string::npos);
  const std::string body = h.substr(begin, end - begin);
  auto decl = [&](const std::string& name, size_t from) {
    const size_t at = body.find(" " + name + ";", from);
    return at == std::string::npos ? at : at + name.size() + 2;
  };
  size_t at = 0;
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ffseg::ParamSpec& s = ffseg::kParamSpecs[i];
    CAPTURE(s.name);
    const size_t here = decl(s.name, at);
    REQUIRE(here != std::string::npos);  // declared, and after the previous field
    const size_t next = i + 1 < ffseg::kParamCount ? decl(ffseg::kParamSpecs[i + 1].name, here) : body.size();
    REQUIRE(next != std::string::npos);
    const std::string doc = body.substr(here, next - here);
    CAPTURE(doc);
    if (std::strcmp(s.name, "target_mode") == 0) {
      CHECK(doc.find("default FFSEG_TARGET_BINARY") != std::string::npos);
      CHECK(double(FFSEG_TARGET_BINARY) == s.default_value);
      CHECK(double(FFSEG_TARGET_INTENSITY) == s.hi);
    } else {
      char range[48], def[40];
      CHECK(doc.find(ffseg::param_range_text(s, range, sizeof range)) != std::string::npos);
      std::snprintf(def, sizeof def, "default %g", s.default_value);
      const size_t d = doc.find(def);
      REQUIRE(d != std::string::npos);
      const char after = doc[d + std::strlen(def)];
      CHECK_FALSE(((after >= '0' && after <= '9') || after == '.' || after == 'e'));  // "default 1", not "default 10"
    }
    at = here;
  }
}

TEST_CASE("params: ffseg segment --help lists every row of the table in order, with its range") {
  // The built tool (next to this test binary), not the header it was built from.
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
  REQUIRE(n > 0);
  self[n] = '\0';
  std::string bin(self);
  bin = bin.substr(0, bin.rfind('/') + 1) + "ffseg";
  std::string help;
  if (FILE* f = popen((bin + " segment --help 2>/dev/null").c_str(), "r")) {
    char buf[4096];
    size_t k;
    while ((k = std::fread(buf, 1, sizeof buf, f)) > 0) help.append(buf, k);
    CHECK(pclose(f) == 0);
  }
  size_t at = help.find("--param NAME=VALUE");
  REQUIRE(at != std::string::npos);
  for (const ffseg::ParamSpec& s : ffseg::kParamSpecs) {
    CAPTURE(s.name);
    char range[48];
    const size_t row = help.find(std::string(" ") + s.name + " ", at);
    REQUIRE(row != std::string::npos);
    const std::string line = help.substr(row, help.find('\n', row) - row);
    CHECK(line.find(ffseg::param_range_text(s, range, sizeof range)) != std::string::npos);
    at = row;
  }
}
