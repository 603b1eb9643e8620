// `ffseg segment`'s command line: the sphere options, --param (generated from
// the engine's parameter table, param_args.h), --target and the usage text.
#ifndef FFSEG_CLI_SEGMENT_OPTIONS_H
#define FFSEG_CLI_SEGMENT_OPTIONS_H

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ffseg.h"
#include "image_io.h"
#include "mesh_io.h"
#include "nifti.h"
#include "overlay.h"
#include "report_json.h"

namespace ffseg_cli {

// The target mode used when --target is not given. FFSEG_TARGET_INTENSITY is
// the goal; an engine without it answers FFSEG_ERR_NOT_IMPLEMENTED, which is
// reported with a hint to use --target binary.
constexpr uint32_t kDefaultTarget = FFSEG_TARGET_INTENSITY;
constexpr int64_t kDefaultMaxSteps = 200;
constexpr int64_t kMaxRoiCap = int64_t(1) << 26;
// --memory's default, MB: five abdominal organs on a 1 mm grid fit it
// (issue 30); a larger engine is asked for explicitly.
constexpr uint64_t kDefaultMemoryMb = 400;

const char* target_name(uint32_t t);  // "binary", "intensity", "unknown"
// binary, intensity or a number; fail(kExitUsage) otherwise.
uint32_t parse_target(const std::string& v, const std::string& what);
// --param NAME=VALUE: any row of the parameter table; a value outside the
// table's range is refused (kExitUsage), naming the range.
void set_param(ffseg_params* p, const std::string& assignment);
// Every table field of p, plus target_mode_name.
ffseg_tools::Json params_json(const ffseg_params& p);

struct SphereArg {
  double c[4];   // centre (mm or voxel) and radius (mm)
  bool voxel;
  std::string text;
  // --sphere-from-label: c[] is filled in once the label map has been read.
  std::string label_path;  // empty for --sphere / --sphere-voxel
  int64_t label = 0;
  std::array<int, 3> label_ijk{};  // the deepest voxel of the label
  double depth_mm = 0;             // its distance to the label's border
};

// --sphere X,Y,Z,R or --sphere-voxel I,J,K,R (opt says which).
SphereArg parse_sphere(const std::string& opt, const std::string& v);
// --sphere-from-label LABELS:L (the last ':' separates the label).
SphereArg parse_sphere_from_label(const std::string& opt, const std::string& v);
// Fills in the protocol sphere of every --sphere-from-label object (see the .cpp).
void resolve_label_spheres(std::vector<SphereArg>* spheres, const ffseg_tools::NiftiImage& img,
                           const std::string& volume_path,
                           std::map<std::string, const ffseg_tools::NiftiImage*> known, bool resample,
                           bool quiet);
// The label of each object in labels.nii.gz when --truth-labels is not
// given: its --sphere-from-label label, else its index + 1, or the next
// number that no other object has; fail(kExitUsage) when two objects come
// from the same label.
std::vector<int64_t> default_labels(const std::vector<SphereArg>& spheres);
// A --names entry: letters, digits, '_', '-', '.'; not starting with '.' or '-'.
bool valid_name(const std::string& n);

// Everything `ffseg segment` was asked for, checked before any work: the
// objects (spheres, names, labels), the engine's settings and where the
// results go.
struct SegmentRequest {
  bool help = false;  // -h / --help: the usage was printed, nothing else to do
  std::string volume_path, out_dir, truth_path, regions_path;
  std::string dicom_seg_path;      // --dicom-seg FILE (a DICOM input writes DIR/segmentation.dcm without it)
  std::string rtstruct_path;       // --rtstruct FILE
  ffseg_tools::OverlayView view = ffseg_tools::OverlayView::Radiological;  // --view
  std::vector<SphereArg> spheres;
  std::vector<std::string> names;  // one per object
  std::vector<int64_t> labels;     // one per object: its label in labels.nii.gz (and in --truth)
  ffseg_params params{};
  uint32_t mesh_resolution = 0;    // 0: automatic (mesh_resolution.h)
  bool have_window = false;
  double window[2] = {0, 1};       // --window LO,HI (overlay grey levels)
  int64_t max_steps = kDefaultMaxSteps;
  int64_t max_roi = -1;            // < 0: from the budget (workspace_budget.h)
  int64_t max_region = -1;         // < 0: from the budget (workspace_budget.h)
  uint64_t memory_bytes = kDefaultMemoryMb * 1000000u;  // --memory: one engine's workspace budget, bytes
  ffseg_tools::MeshFormat mesh_format = ffseg_tools::MeshFormat::Ply;
  bool have_labels_format = false;
  ffseg_tools::ImageFormat labels_format = ffseg_tools::ImageFormat::Nifti;
  bool force = false, quiet = false;
  bool resample_labels = false;    // --resample-labels (label_grid.h)
  bool seed_check = false;         // --seed-check (seed_check.h)
  bool consensus = false;          // --consensus (seed_check.h; implies seed_check)
  bool html = false;               // --html: report.html beside report.json (report_html.h)
  uint32_t jobs = 0;               // --jobs: the seed check's runs at once; 0: the CPU count
  bool out_nonempty = false;       // --out exists with files in it (and --force replaces them)
  std::string out_parent;
  uint32_t objects() const { return uint32_t(spheres.size()); }
};

// Parses and checks `ffseg segment`'s command line (argv[2..]); every
// mistake is fail(kExitUsage) with a message, before anything is read.
SegmentRequest parse_segment_request(int argc, char** argv);

}  // namespace ffseg_cli

#endif  // FFSEG_CLI_SEGMENT_OPTIONS_H
