#include "params.h"

#include <cstdio>

#include "binary_search.h"
#include "cubesphere.h"
#include "intensity_search.h"

namespace ffseg {

namespace {
constexpr uint32_t kMaxObjects = 64;
constexpr int64_t kMaxRoi = int64_t(1) << 40;
}  // namespace

double Params::range_mm() const {
  if (search_range_mm > 0) return search_range_mm;
  return target_mode == TargetMode::binary ? kBinarySearchRangeMm : kIntensitySearchRangeMm;
}

Err check_config(const Config& c, char* msg, size_t n) {
  if (c.max_objects < 1 || c.max_objects > kMaxObjects) {
    std::snprintf(msg, n, "config.max_objects = %u is outside 1..%u", c.max_objects, kMaxObjects);
    return Err::invalid_argument;
  }
  if (c.mesh_resolution < CubeSphere::kMinN || c.mesh_resolution > CubeSphere::kMaxN) {
    std::snprintf(msg, n, "config.mesh_resolution = %u is outside %u..%u", c.mesh_resolution,
                  CubeSphere::kMinN, CubeSphere::kMaxN);
    return Err::invalid_argument;
  }
  if (c.max_roi_voxels < 0 || c.max_roi_voxels > kMaxRoi) {
    std::snprintf(msg, n, "config.max_roi_voxels = %lld is outside 0..2^40", (long long)c.max_roi_voxels);
    return Err::invalid_argument;
  }
  if (c.max_region_voxels < 0 || c.max_region_voxels > kMaxRoi) {
    std::snprintf(msg, n, "config.max_region_voxels = %lld is outside 0..2^40", (long long)c.max_region_voxels);
    return Err::invalid_argument;
  }
  if (c.target_mode != TargetMode::binary && c.target_mode != TargetMode::intensity) {
    std::snprintf(msg, n, "config.target_mode = %u is neither 0 (binary) nor 1 (intensity)", uint32_t(c.target_mode));
    return Err::invalid_argument;
  }
  return Err::ok;
}

Err check_params(const Params& p, char* msg, size_t n) {
  // Every field in table order, its value widened to double (exact for uint32_t).
  const double values[kParamCount] = {
#define FFSEG_PARAM_VALUE(name, ctype, kind, def, lo, hi, bounds, unit, doc) double(p.name),
      FFSEG_PARAM_TABLE(FFSEG_PARAM_VALUE)
#undef FFSEG_PARAM_VALUE
  };
  for (unsigned i = 0; i < kParamCount; ++i) {
    const ParamSpec& s = kParamSpecs[i];
    if (param_in_range(s, values[i])) continue;
    char range[48];
    param_range_text(s, range, sizeof range);
    std::snprintf(msg, n, "params.%s = %g is outside %s%s%s", s.name, values[i], range, s.unit[0] ? " " : "",
                  s.unit);
    return Err::invalid_argument;
  }
  return Err::ok;
}

}  // namespace ffseg
