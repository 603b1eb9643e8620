// A label map read onto the volume's grid (label_grid.h).
#include "label_grid.h"

#include <cstdio>

#include "cli.h"
#include "grid_match.h"

namespace ffseg_cli {

namespace {
std::string axis_text(const ffseg_tools::AxisMap& m) {
  static const char* const names[3] = {"i", "j", "k"};
  std::string s;
  for (int a = 0; a < 3; ++a) {
    if (!s.empty()) s += ", ";
    s += std::string(m.reversed[a] ? "-" : "") + names[m.axis[a]];
  }
  return "(" + s + ")";
}
}  // namespace

ffseg_tools::NiftiImage read_on_grid(const ffseg_tools::NiftiImage& grid, const std::string& grid_path,
                                     const std::string& path, const std::string& role, bool resample, bool quiet,
                                     bool own_affine) {
  ffseg_tools::NiftiImage other = read_image(path);
  ffseg_tools::AxisMap m;
  std::string why;
  if (ffseg_tools::match_voxel_centres(grid, other, &m, &why)) {
    if (m.identity()) return other;
    if (!quiet)
      std::fprintf(stderr, "ffseg: %s %s holds %s's voxel centres in another order: its axes %s along %s's i, j, k; "
                   "re-indexed exactly\n", role.c_str(), path.c_str(), grid_path.c_str(), axis_text(m).c_str(),
                   grid_path.c_str());
    return ffseg_tools::reindex_to(grid, other, m);
  }
  if (own_affine && other.dims[0] == grid.dims[0] && other.dims[1] == grid.dims[1] && other.dims[2] == grid.dims[2])
    return other;
  if (!resample)
    fail(kExitInput, "grids differ: " + why + " between " + grid_path + " and " + role + " " + path +
                         " (--resample-labels resamples it by nearest neighbour)");
  size_t outside = 0;
  ffseg_tools::NiftiImage out = ffseg_tools::resample_nearest(grid, other, &outside);
  std::fprintf(stderr, "ffseg: warning: %s %s is on another grid (%s); resampled by nearest neighbour onto %s's "
               "(%zu voxels beyond it read 0): its labels move by up to half a voxel\n", role.c_str(), path.c_str(),
               why.c_str(), grid_path.c_str(), outside);
  return out;
}

}  // namespace ffseg_cli
