// Shared pieces of the `ffseg` command-line tool: errors and exit codes,
// option parsing, voxel access on images, grids, files and directories.
// The tool talks to the engine through include/ffseg.h only.
#ifndef FFSEG_CLI_CLI_H
#define FFSEG_CLI_CLI_H

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "image_io.h"
#include "nifti.h"
#include "report_json.h"

namespace ffseg_cli {

// Exit statuses.
constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;      // an output could not be written
constexpr int kExitUsage = 2;        // bad command line
constexpr int kExitInput = 3;        // unreadable or malformed input file
constexpr int kExitEngine = 4;       // the engine reported an error
constexpr int kExitNoResult = 5;     // the run ended, but no object was found (segment: see cmd_segment.cpp)
constexpr int kExitStalled = 6;      // segment: outputs written, but an object stalled short of its boundary
constexpr int kExitInterrupted = 130;

// Thrown anywhere in a command; main prints "ffseg: error: <message>" and
// returns `code`.
struct CliError {
  int code;
  std::string message;
};
[[noreturn]] void fail(int code, const std::string& message);

// ---- command line -----------------------------------------------------------
// Arguments after the command name. Options are "--name value" or
// "--name=value"; "--" ends the options.
class Args {
 public:
  Args(int argc, char** argv, int first);
  // Next token; false at the end. *is_option says whether it is "--name"
  // ("-h" counts too); for "--name=value" the value is kept for value().
  bool next(std::string* token, bool* is_option);
  // The option's value (the "=value" part or the following argument).
  std::string value(const std::string& option);

 private:
  std::vector<std::string> a_;
  size_t i_ = 0;
  bool only_positional_ = false;
  bool have_inline_ = false;
  std::string inline_value_;
};

std::vector<std::string> split(const std::string& s, char sep);
// Strict number parsing; fail(kExitUsage, "<what>: ...") on anything else.
double parse_double(const std::string& s, const std::string& what);
int64_t parse_int(const std::string& s, const std::string& what, int64_t lo, int64_t hi);
std::string format_double(double v, int digits = 6);  // "%.*g"

// ---- images -------------------------------------------------------------------
// Reads a NIfTI-1, NRRD, MetaImage file or a DICOM series directory (in the
// tools' RAS frame, image_io.h) or fails with kExitInput ("cannot read PATH:
// reason"); *format (may be null) gets the format, *dicom (may be null) a
// DICOM series' identifiers.
ffseg_tools::NiftiImage read_image(const std::string& path, ffseg_tools::ImageFormat* format = nullptr,
                                   ffseg_tools::DicomSource* dicom = nullptr);

// The rescaled value (slope * stored + intercept) of voxel idx.
double voxel_value(const ffseg_tools::NiftiImage& img, size_t idx);

// Calls f(idx, stored value as double) for every voxel, in order (fast path).
template <class F>
void for_each_stored(const ffseg_tools::NiftiImage& img, F f) {
  const size_t n = size_t(img.voxel_count());
  const uint8_t* d = img.data.data();
  switch (img.voxel_type) {
    case ffseg_tools::kNiftiVoxU8:
      for (size_t i = 0; i < n; ++i) f(i, double(d[i]));
      break;
    case ffseg_tools::kNiftiVoxI16:
      for (size_t i = 0; i < n; ++i) f(i, double(reinterpret_cast<const int16_t*>(d)[i]));
      break;
    case ffseg_tools::kNiftiVoxU16:
      for (size_t i = 0; i < n; ++i) f(i, double(reinterpret_cast<const uint16_t*>(d)[i]));
      break;
    case ffseg_tools::kNiftiVoxI32:
      for (size_t i = 0; i < n; ++i) f(i, double(reinterpret_cast<const int32_t*>(d)[i]));
      break;
    case ffseg_tools::kNiftiVoxF32:
      for (size_t i = 0; i < n; ++i) f(i, double(reinterpret_cast<const float*>(d)[i]));
      break;
    case ffseg_tools::kNiftiVoxF64:
      for (size_t i = 0; i < n; ++i) f(i, reinterpret_cast<const double*>(d)[i]);
      break;
    default:
      break;
  }
}

// Mask (1 byte per voxel) of the voxels whose rescaled value is the integer
// `label`; *count gets their number.
std::vector<uint8_t> label_mask(const ffseg_tools::NiftiImage& img, int64_t label, size_t* count);


// Voxel volume in mm^3 (|det| of the affine's 3x3 part).
double voxel_volume_mm3(const ffseg_tools::NiftiImage& img);
// world = A * (i, j, k, 1) and its inverse (for the voxel-to-world sphere
// centres and the world-to-voxel report).
std::array<double, 3> voxel_to_world(const double A[16], const double ijk[3]);
std::array<double, 3> world_to_voxel(const double A[16], const double xyz[3]);
// "RAS", "LPI", ...: the world direction each voxel axis points to most.
std::string orientation_code(const double A[16]);
const char* datatype_name(int nifti_datatype);

// Dice, VOE, ASSD, HD95 between two masks on one grid, computed on their
// common bounding box (plus one voxel) -- the same numbers as on the whole grid.
struct MaskMetrics {
  double dice, voe, rvd, assd_mm, hd95_mm, hd_mm, vol_a_ml, vol_b_ml;
  size_t voxels_a, voxels_b;
};
MaskMetrics compare_masks_cropped(const uint8_t* a, const uint8_t* b, const int dims[3],
                                  const double spacing[3]);
// Writes dice, voe, rvd, assd_mm, hd95_mm and hd_mm of m into the object j.
void set_metric_fields(ffseg_tools::Json& j, const MaskMetrics& m);

// ---- files ----------------------------------------------------------------------
bool path_exists(const std::string& p);
bool is_directory(const std::string& p);
bool directory_is_empty(const std::string& p);  // false if it cannot be read
void remove_tree(const std::string& p);          // best effort
std::string parent_dir(const std::string& p);    // "." for a bare name
std::string base_name(const std::string& p);     // without trailing slashes
bool write_text_file(const std::string& path, const std::string& text, std::string* err);

// ---- interruption -------------------------------------------------------------
// SIGINT/SIGTERM set a flag (a second signal kills as usual); check_interrupted
// throws CliError{kExitInterrupted} once it is set.
void install_interrupt_handlers();
void check_interrupted();

// ---- commands -------------------------------------------------------------------
int cmd_segment(int argc, char** argv);  // argv[0] = "ffseg", argv[1] = "segment"
int cmd_info(int argc, char** argv);
int cmd_eval(int argc, char** argv);
std::string segment_usage();  // mentions the default target
extern const char* const kInfoUsage;
extern const char* const kEvalUsage;

}  // namespace ffseg_cli

#endif  // FFSEG_CLI_CLI_H
