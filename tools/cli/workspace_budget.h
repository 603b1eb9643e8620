// The engine's crop and region budgets from a memory budget (issue 30):
// memory that follows the organs, not the scan.
//
// Without a budget the tool would reserve, per object, a smoothing crop and a
// bounding region as large as the whole scan (22 + 8 x objects bytes per scan
// voxel: 2.4 GB for five organs on a 1 mm abdomen), while each organ's own
// boxes are a fraction of it. The rule, for one engine:
//  1. Every crop and region may hold the whole scan (at most kMaxRoiCap
//     voxels), as before. If that workspace fits the budget, it is used: a
//     small scan keeps every region at full resolution.
//  2. Otherwise the regions get an eighth of a crop's voxels: a region's box
//     (mesh + region width) is smaller than a crop's (mesh + twice the search
//     range + the smoothing margin), so a region as large as the largest crop
//     is then marched on cells of two voxels (ffseg.h, max_region_voxels;
//     thesis 7.2: regions need not be of single-voxel accuracy).
//  3. If that still does not fit, the crops shrink to the largest that fits
//     (the exact workspace size is asked of the library at every try).
// A value given on the command line is kept as given. Several organs share
// a room of objects x max_roi_voxels for their crops (ffseg.h), so a liver
// may hold more than its share beside small organs; when the crops together
// do not fit, the engine returns FFSEG_ERR_ROI_TOO_LARGE: with sizes from
// the budget, the tool starts the run again with twice the budget
// (cmd_segment.cpp, run_engine); with sizes given, it ends the run with the
// --memory hint.
#pragma once
#include <cstddef>
#include <cstdint>

#include "ffseg.h"

namespace ffseg_cli {

struct WorkspaceSizing {
  int64_t max_roi_voxels = 0;
  int64_t max_region_voxels = 0;
  size_t bytes = 0;       // ffseg_workspace_size of the result
  bool fits = false;      // bytes <= the budget
  bool reduced = false;   // the budget moved a size below the scan's (rules 2-3)
};

// cfg: max_objects, mesh_resolution and target_mode set (its sizes are
// overwritten); scan_voxels: the volume's voxel count; roi, region: the
// command line's values, < 0 when not given; budget_bytes: the budget.
WorkspaceSizing size_workspace(ffseg_config cfg, int64_t scan_voxels, int64_t roi, int64_t region,
                               uint64_t budget_bytes, int64_t roi_cap);

}  // namespace ffseg_cli
