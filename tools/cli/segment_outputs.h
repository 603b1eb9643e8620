// `ffseg segment`'s results: the objects read back from the engine, the one
// label map in which no voxel is claimed twice, the bounding regions as a
// label map, and the overlay picture.
#ifndef FFSEG_CLI_SEGMENT_OUTPUTS_H
#define FFSEG_CLI_SEGMENT_OUTPUTS_H

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ffseg.h"
#include "nifti.h"
#include "overlay.h"

namespace ffseg_cli {

// fail(kExitEngine, "<what>: <status> (<engine message>)").
[[noreturn]] void engine_fail(const ffseg_engine* e, ffseg_status st, const std::string& what);

struct ObjectResult {
  std::vector<float> xyz;
  std::vector<uint32_t> tris;
  // The voxels labels.nii.gz gives this object: inside its mesh and not
  // inside an earlier object's mesh (what the report's metrics measure).
  std::vector<uint8_t> mask;
  size_t voxels = 0;          // in mask
  size_t shared_voxels = 0;   // inside this mesh but labelled as an earlier object
  std::array<int, 3> centre_ijk{};
  uint32_t border_vertices = 0;  // at the last step the object moved (ffseg_step_info)
};

// Every object's mesh and mask, each voxel given to the first object whose
// mesh holds it (the lowest index), as in the label map; centre_ijk is the
// mask's centroid (the sphere's centre for an empty mask).
std::vector<ObjectResult> read_results(const ffseg_engine* e, const ffseg_tools::NiftiImage& img, uint32_t nobj,
                                       const std::vector<std::array<double, 3>>& centres_mm);

// A label image on img's grid, of the smallest type that holds every label.
ffseg_tools::NiftiImage make_label_image(const ffseg_tools::NiftiImage& img, const std::vector<int64_t>& labels,
                                         const char* descrip);
// Voxel i of a label image made by make_label_image gets v.
void put_label(ffseg_tools::NiftiImage* lab, size_t i, int64_t v);

// labels[k] on object k's voxels (res[k].mask: disjoint).
ffseg_tools::NiftiImage object_label_map(const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                                         const std::vector<int64_t>& labels);
// labels[k] on object k's bounding region (ffseg_region_mask), 0 where no
// object's front arrived. The regions are disjoint by construction.
ffseg_tools::NiftiImage region_label_map(const ffseg_engine* e, const ffseg_tools::NiftiImage& img,
                                         const std::vector<int64_t>& labels);

// The grey window of overlay.png when --window is not given: it follows the
// objects, not the whole scan (on CT the whole scan's p1..p99 spans air to
// bone and leaves soft tissue one grey). [lo, hi] = the p1..p99 of the
// voxels inside the objects, widened by that width on each side so the
// neighbouring tissue stays visible, and never wider than the scan's p1..p99;
// no object voxel: the scan's p1..p99.
void object_window(const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res, double* lo, double* hi);

// overlay.png: one row per object, each object in its own colour; truth_masks
// (empty, or one per object) as the reference contours; grey window [lo, hi].
bool write_overlay(const std::string& path, const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                   const std::vector<std::string>& names, const std::vector<std::vector<uint8_t>>& truth_masks,
                   double lo, double hi, ffseg_tools::OverlayView view, std::string* err);

}  // namespace ffseg_cli

#endif  // FFSEG_CLI_SEGMENT_OUTPUTS_H
