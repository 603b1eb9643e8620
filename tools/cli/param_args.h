// The CLI's --param NAME=VALUE table: generated from the engine's parameter
// table (src/engine/param_table.h, plain macros and literals), each row placed
// in the public struct ffseg_params by offsetof. Header-only so that
// tests/engine/test_params.cpp checks the very table the tool uses.
#pragma once
#include <cstddef>

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

}  // namespace ffseg_cli
