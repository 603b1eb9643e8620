// The CLI's --param NAME=VALUE table: generated from the engine's parameter
// table (src/engine/param_table.h, plain macros and literals), each row placed
// in the public struct ffseg_params by offsetof. Header-only so that
// tests/engine/test_params.cpp checks the very table the tool uses.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "ffseg.h"
#include "param_table.h"

namespace ffseg_cli {

struct ParamField {
  const ffseg::ParamSpec* spec;  // name, kind, default, range, unit, doc
  size_t offset;                 // in ffseg_params
};

#define FFSEG_CLI_PARAM(name, ctype, kind, def, lo, hi, bounds, unit, doc) offsetof(ffseg_params, name),
inline constexpr size_t kParamOffsets[] = {FFSEG_PARAM_TABLE(FFSEG_CLI_PARAM)};
#undef FFSEG_CLI_PARAM
static_assert(sizeof(kParamOffsets) / sizeof(kParamOffsets[0]) == ffseg::kParamCount, "one offset per parameter");

inline ParamField param_field(unsigned i) { return ParamField{&ffseg::kParamSpecs[i], kParamOffsets[i]}; }

// The row named `name`; spec is nullptr when there is none.
inline ParamField param_field_named(const char* name) {
  for (unsigned i = 0; i < ffseg::kParamCount; ++i)
    if (std::strcmp(ffseg::kParamSpecs[i].name, name) == 0) return param_field(i);
  return ParamField{nullptr, 0};
}

// Writes v into row f's field of p: a U32 row as uint32_t (v must be a whole
// number the field holds), an F64 row as it is.
inline void write_param(ffseg_params* p, const ParamField& f, double v) {
  char* at = reinterpret_cast<char*>(p) + f.offset;
  if (f.spec->kind == ffseg::ParamKind::U32) {
    const uint32_t u = uint32_t(v);
    std::memcpy(at, &u, sizeof u);
  } else {
    std::memcpy(at, &v, sizeof v);
  }
}

}  // namespace ffseg_cli
