// A label map or reference read onto the volume's grid: the same voxel
// centres stored in another order are re-indexed exactly (grid_match.h); a
// grid that truly differs is refused naming what differs, or, with
// --resample-labels, resampled by nearest neighbour with a warning.
#ifndef FFSEG_CLI_LABEL_GRID_H
#define FFSEG_CLI_LABEL_GRID_H

#include <string>

#include "nifti.h"

namespace ffseg_cli {

// `role` names the option in messages ("--truth", "--sphere-from-label");
// grid_path is the file that defined `grid`. own_affine: a map of the same
// dimensions on another affine is returned as it is (--sphere-from-label
// places its sphere in world mm by the map's own affine, so any such map
// serves). Fails with kExitInput.
ffseg_tools::NiftiImage read_on_grid(const ffseg_tools::NiftiImage& grid, const std::string& grid_path,
                                     const std::string& path, const std::string& role, bool resample, bool quiet,
                                     bool own_affine = false);

}  // namespace ffseg_cli

#endif  // FFSEG_CLI_LABEL_GRID_H
