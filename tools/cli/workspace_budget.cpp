#include "workspace_budget.h"

namespace ffseg_cli {

WorkspaceSizing size_workspace(ffseg_config cfg, int64_t scan_voxels, int64_t roi, int64_t region,
                               uint64_t budget_bytes, int64_t roi_cap) {
  WorkspaceSizing r;
  auto measure = [&](int64_t crop, int64_t reg) {
    cfg.max_roi_voxels = crop;
    cfg.max_region_voxels = reg;
    size_t b = 0;
    if (ffseg_workspace_size(&cfg, &b) != FFSEG_OK) b = SIZE_MAX;
    r.max_roi_voxels = crop;
    r.max_region_voxels = reg;
    r.bytes = b;
    r.fits = b != SIZE_MAX && uint64_t(b) <= budget_bytes;
    return r.fits;
  };
  const int64_t whole = scan_voxels < roi_cap ? scan_voxels : roi_cap;
  const int64_t crop = roi >= 0 ? roi : whole;
  const auto region_for = [&](int64_t c, bool coarse) {
    if (region >= 0) return region;
    const int64_t e = coarse ? c / 8 : c;
    return e > 0 ? e : 1;
  };
  if (measure(crop, region_for(crop, false))) return r;
  if (region < 0 && measure(crop, region_for(crop, true))) return r.reduced = true, r;
  if (roi >= 0) return r;  // the crops were given: the caller reports the excess
  // The largest crop that fits, by bisection (the size grows with the crop).
  int64_t lo = 0, hi = crop;
  while (hi - lo > 1) {
    const int64_t mid = lo + (hi - lo) / 2;
    if (measure(mid, region_for(mid, true))) lo = mid;
    else hi = mid;
  }
  measure(lo > 0 ? lo : 1, region_for(lo > 0 ? lo : 1, true));
  r.reduced = true;
  return r;
}

}  // namespace ffseg_cli
