// One AAL structure of the Colin27 T1 MRI segmented through the C API with
// the protocol sphere (centre = the label voxel farthest from the label's
// border, radius = half that distance), metrics against the label. Used by
// tests/engine/test_colin27.cpp and tools/experiments/experiment_colin27.
#pragma once
#include <cstddef>
#include <functional>
#include <vector>

#include "ffseg.h"
#include "metrics.h"
#include "nifti.h"

namespace ffseg_test {

extern const char* const kColin27T1;   // /usr/share/mricron/templates/ch2.nii.gz
extern const char* const kColin27Aal;  // /usr/share/mricron/templates/aal.nii.gz

struct StructureResult {
  int label = 0;
  const char* name = "";
  ffseg_tools::SegMetrics m{};
  int steps = 0;
  double ms = 0;
  size_t intersections = 0;  // worst over the steps (with check_mesh)
  size_t flips = 0;          // worst over the steps: triangles turned against their neighbours
};

struct StructureRunOptions {
  double radius_scale = 1;
  const double* shift_mm = nullptr;   // sphere centre moved by this (mm)
  bool check_mesh = false;            // self-intersections and flips after every step
  int partial_volume_steps = -1;      // >= 0: instead of the default
  // Experiments only: print the sphere and every step; change the parameters
  // before they are set.
  bool verbose = false;
  bool print_steps = false;
  std::function<void(ffseg_params&)> tune;
  std::vector<uint8_t>* mask_out = nullptr;  // the result's label mask on the AAL grid
};

ffseg_volume volume_of(const ffseg_tools::NiftiImage& img);

// The protocol sphere of a label's mask (truth, on t1's grid): centre c (mm)
// at the voxel farthest from the label's border, radius *r half that distance.
void protocol_sphere(const ffseg_tools::NiftiImage& t1, const std::vector<uint8_t>& truth, double c[3], double* r);

StructureResult segment_structure(const ffseg_tools::NiftiImage& t1, const ffseg_tools::NiftiImage& aal, int label,
                                  const char* name, uint32_t n, int max_steps,
                                  const StructureRunOptions& o = StructureRunOptions());

}  // namespace ffseg_test
