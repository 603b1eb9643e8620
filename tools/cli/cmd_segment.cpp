// `ffseg segment`: grow sphere meshes into objects and write the results.
// Uses the engine through include/ffseg.h only.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>

#include "cli.h"
#include "ffseg.h"
#include "mesh_io.h"
#include "metrics.h"
#include "overlay.h"
#include "param_args.h"
#include "report_json.h"

namespace ffseg_cli {

namespace {

// The target mode used when --target is not given. FFSEG_TARGET_INTENSITY is
// the goal; an engine without it answers FFSEG_ERR_NOT_IMPLEMENTED, which is
// reported with a hint to use --target binary.
constexpr uint32_t kDefaultTarget = FFSEG_TARGET_INTENSITY;
constexpr uint32_t kDefaultMeshResolution = 33;
constexpr int64_t kDefaultMaxSteps = 200;
constexpr int64_t kMaxRoiCap = int64_t(1) << 26;

const char* target_name(uint32_t t) {
  return t == FFSEG_TARGET_BINARY ? "binary" : t == FFSEG_TARGET_INTENSITY ? "intensity" : "unknown";
}

// The parameters' names, comma-separated, in the table's order.
std::string param_names(const char* sep = ", ") {
  std::string s;
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) s += std::string(i ? sep : "") + ffseg::kParamSpecs[i].name;
  return s;
}

uint32_t parse_target(const std::string& v, const std::string& what) {
  if (v == "binary") return FFSEG_TARGET_BINARY;
  if (v == "intensity") return FFSEG_TARGET_INTENSITY;
  return uint32_t(parse_int(v, what + " (binary, intensity or a number)", 0, 0xFFFFFFFFLL));
}

// --param NAME=VALUE: any row of the parameter table (param_args.h); a value
// outside the table's range is refused here, naming the range.
void set_param(ffseg_params* p, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    fail(kExitUsage, "--param: expected NAME=VALUE, got '" + assignment + "'");
  const std::string name = assignment.substr(0, eq), value = assignment.substr(eq + 1);
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ParamField f = param_field(i);
    if (name != f.spec->name) continue;
    char* base = reinterpret_cast<char*>(p) + f.offset;
    const std::string what = "--param " + name;
    double v;
    if (name == "target_mode") v = parse_target(value, what);
    else if (f.spec->kind == ffseg::ParamKind::U32) v = double(parse_int(value, what, 0, 0xFFFFFFFFLL));
    else v = parse_double(value, what);
    if (!ffseg::param_in_range(*f.spec, v)) {
      char range[48];
      ffseg::param_range_text(*f.spec, range, sizeof range);
      fail(kExitUsage, what + ": " + value + " is outside " + range +
                           (f.spec->unit[0] ? std::string(" ") + f.spec->unit : std::string()) + " (" + f.spec->doc + ")");
    }
    if (f.spec->kind == ffseg::ParamKind::U32) {
      const uint32_t u = uint32_t(v);
      std::memcpy(base, &u, sizeof u);
    } else {
      std::memcpy(base, &v, sizeof v);
    }
    return;
  }
  fail(kExitUsage, "--param: unknown parameter '" + name + "' (known: " + param_names() + ")");
}

ffseg_tools::Json params_json(const ffseg_params& p) {
  ffseg_tools::Json j = ffseg_tools::Json::object();
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ParamField f = param_field(i);
    const char* base = reinterpret_cast<const char*>(&p) + f.offset;
    if (f.spec->kind == ffseg::ParamKind::U32) {
      uint32_t v;
      std::memcpy(&v, base, sizeof v);
      j.set(f.spec->name, v);
    } else {
      double v;
      std::memcpy(&v, base, sizeof v);
      j.set(f.spec->name, v);
    }
  }
  j.set("target_mode_name", target_name(p.target_mode));
  return j;
}

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

SphereArg parse_sphere(const std::string& opt, const std::string& v) {
  const std::vector<std::string> parts = split(v, ',');
  if (parts.size() != 4)
    fail(kExitUsage, opt + ": expected 4 comma-separated numbers " +
                         (opt == "--sphere" ? std::string("X,Y,Z,R") : std::string("I,J,K,R")) + ", got '" + v + "'");
  SphereArg s;
  for (int k = 0; k < 4; ++k) s.c[k] = parse_double(parts[size_t(k)], opt);
  if (!(s.c[3] > 0)) fail(kExitUsage, opt + ": the radius must be > 0 mm, got " + parts[3]);
  s.voxel = opt == "--sphere-voxel";
  s.text = opt + " " + v;
  return s;
}

// --sphere-from-label LABELS:L (the last ':' separates the label, so the path may hold ':').
SphereArg parse_sphere_from_label(const std::string& opt, const std::string& v) {
  const size_t colon = v.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == v.size())
    fail(kExitUsage, opt + ": expected LABELS.nii.gz:L (a label map and a label number), got '" + v + "'");
  SphereArg s;
  std::fill(s.c, s.c + 4, 0.0);
  s.voxel = false;
  s.text = opt + " " + v;
  s.label_path = v.substr(0, colon);
  s.label = parse_int(v.substr(colon + 1), opt + " label", 1, 2147483647LL);
  return s;
}

// The evaluation-protocol sphere (PEERS.md) of every --sphere-from-label object:
// centre = the label voxel farthest from the label's border (Euclidean distance
// in mm; beyond the grid counts as outside), radius = half that distance, the
// centre taken to world mm with the label map's own affine. Each label map is
// read once; `known` holds maps already in memory (the --truth map), by path.
void resolve_label_spheres(std::vector<SphereArg>* spheres, const ffseg_tools::NiftiImage& img,
                           const std::string& volume_path,
                           std::map<std::string, const ffseg_tools::NiftiImage*> known, bool quiet) {
  std::vector<std::unique_ptr<ffseg_tools::NiftiImage>> owned;
  for (SphereArg& s : *spheres) {
    if (s.label_path.empty()) continue;
    const ffseg_tools::NiftiImage*& lm = known[s.label_path];
    if (!lm) {
      owned.push_back(std::make_unique<ffseg_tools::NiftiImage>(read_image(s.label_path)));
      lm = owned.back().get();
    }
    if (lm->dims[0] != img.dims[0] || lm->dims[1] != img.dims[1] || lm->dims[2] != img.dims[2])
      fail(kExitInput, "grids differ: dimensions differ (" + std::to_string(img.dims[0]) + "x" +
                           std::to_string(img.dims[1]) + "x" + std::to_string(img.dims[2]) + " vs " +
                           std::to_string(lm->dims[0]) + "x" + std::to_string(lm->dims[1]) + "x" +
                           std::to_string(lm->dims[2]) + ") between " + volume_path +
                           " and --sphere-from-label " + s.label_path);
    size_t count = 0;
    const std::vector<uint8_t> mask = label_mask(*lm, s.label, &count);
    if (count == 0 || !ffseg_tools::find_deepest_voxel(mask.data(), lm->dims, lm->spacing, &s.label_ijk, &s.depth_mm))
      fail(kExitUsage, "--sphere-from-label: label " + std::to_string(s.label) + " has no voxel in " + s.label_path);
    const double ijk[3] = {double(s.label_ijk[0]), double(s.label_ijk[1]), double(s.label_ijk[2])};
    const std::array<double, 3> centre = voxel_to_world(lm->index_to_world, ijk);
    for (int a = 0; a < 3; ++a) s.c[a] = centre[size_t(a)];
    s.c[3] = s.depth_mm / 2;
    if (!quiet)
      std::fprintf(stderr, "ffseg: sphere from label %lld: centre (%s, %s, %s) mm, radius %s mm\n",
                   static_cast<long long>(s.label), format_double(s.c[0]).c_str(), format_double(s.c[1]).c_str(),
                   format_double(s.c[2]).c_str(), format_double(s.c[3]).c_str());
  }
}

bool valid_name(const std::string& n) {
  if (n.empty() || n.size() > 100 || n[0] == '.' || n[0] == '-') return false;
  for (char c : n)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

// Milliseconds rounded to the microsecond (for the report).
double ms(double seconds) { return std::round(seconds * 1e6) / 1000.0; }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The workspace: 64-byte aligned, freed on scope exit (after ffseg_destroy).
struct Workspace {
  void* p = nullptr;
  ffseg_engine* e = nullptr;
  ~Workspace() {
    ffseg_destroy(e);
    std::free(p);
  }
};

// A temporary output directory removed on scope exit unless committed.
struct TempDir {
  std::string path;
  bool keep = false;
  ~TempDir() {
    if (!path.empty() && !keep) remove_tree(path);
  }
};

[[noreturn]] void engine_fail(const ffseg_engine* e, ffseg_status st, const std::string& what) {
  const std::string detail = ffseg_last_error(e);
  fail(kExitEngine, what + ": " + ffseg_status_string(st) + (detail.empty() ? "" : " (" + detail + ")"));
}

// Progress on stderr: one updating line on a terminal, a line every 10 steps otherwise.
class Progress {
 public:
  Progress(bool enabled, int64_t max_steps, uint32_t objects)
      : on_(enabled), tty_(enabled && ::isatty(STDERR_FILENO)), max_(max_steps), nobj_(objects) {}
  void step(const ffseg_step_info& info, double elapsed, bool last) {
    if (!on_) return;
    if (!tty_ && !last && info.step_index % 10 != 0 && info.step_index != 1) return;
    std::string s = "ffseg: step " + std::to_string(info.step_index) + "/" + std::to_string(max_) +
                    "  mean displacement";
    const uint32_t shown = std::min<uint32_t>(nobj_, 8);
    for (uint32_t o = 0; o < shown; ++o) {
      char d[32];
      std::snprintf(d, sizeof d, " %.3f", info.mean_displacement_mm[o]);
      s += d;
    }
    if (nobj_ > shown) s += " ...";
    char t[32];
    std::snprintf(t, sizeof t, " mm  %.1f s", elapsed);
    s += t;
    if (tty_) {
      if (s.size() < width_) s.append(width_ - s.size(), ' ');
      width_ = std::max(width_, s.size());
      std::fprintf(stderr, "\r%s", s.c_str());
      if (last) std::fputc('\n', stderr);
    } else {
      std::fprintf(stderr, "%s\n", s.c_str());
    }
    std::fflush(stderr);
    dirty_ = tty_ && !last;
  }
  // Ends an unfinished terminal line (before an error message).
  ~Progress() {
    if (dirty_) std::fputc('\n', stderr);
  }

 private:
  bool on_, tty_;
  int64_t max_;
  uint32_t nobj_;
  size_t width_ = 0;
  bool dirty_ = false;
};

// "x -90 .. 90, y ... mm": the world box of the voxel centres.
std::string world_extent(const ffseg_tools::NiftiImage& img) {
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (int c = 0; c < 8; ++c) {
    const double ijk[3] = {c & 1 ? img.dims[0] - 1.0 : 0.0, c & 2 ? img.dims[1] - 1.0 : 0.0,
                           c & 4 ? img.dims[2] - 1.0 : 0.0};
    const auto p = voxel_to_world(img.index_to_world, ijk);
    for (int w = 0; w < 3; ++w) lo[w] = std::min(lo[w], p[size_t(w)]), hi[w] = std::max(hi[w], p[size_t(w)]);
  }
  std::string s = "voxel centres span";
  const char* axis[3] = {"x", "y", "z"};
  for (int w = 0; w < 3; ++w)
    s += std::string(w ? "," : "") + " " + axis[w] + " " + format_double(lo[w], 5) + " .. " + format_double(hi[w], 5);
  return s + " mm";
}

const char* kStageNames[FFSEG_STAGE_COUNT] = {"search",   "flips",    "diffusion", "intersection",
                                              "assembly", "factor",   "solve",     "features",
                                              "guard",    "regions"};

}  // namespace

namespace {
const char* const kSegmentUsageText =
    "usage: ffseg segment VOLUME (--sphere X,Y,Z,R | --sphere-voxel I,J,K,R |\n"
    "                             --sphere-from-label LABELS:L)... --out DIR [options]\n"
    "\n"
    "Places one sphere mesh per --sphere / --sphere-voxel / --sphere-from-label\n"
    "(object 1, 2, ... in the order given), deforms them all until they converge or\n"
    "--max-steps is reached, and writes into DIR:\n"
    "  NAME.ply        each object's closed triangle mesh in world mm (format: --mesh-format)\n"
    "  labels.nii.gz   label map on the input grid: object k -> label k (or its\n"
    "                  --truth-labels number); where objects overlap the first wins;\n"
    "                  labels.nrrd / labels.mha for NRRD / MetaImage input\n"
    "  overlay.png     axial, coronal and sagittal slices through each object's\n"
    "                  centre with every object's contour in its own colour\n"
    "                  (with --truth: the reference label as a dashed yellow contour)\n"
    "  report.json     input, steps, convergence, volume (ml), mesh size, metrics,\n"
    "                  time per stage, workspace bytes, version, parameters\n"
    "Everything is written to a temporary directory beside DIR and renamed into\n"
    "place at the end: a failed or interrupted run leaves nothing behind.\n"
    "\n"
    "objects:\n"
    "  --sphere X,Y,Z,R        centre in world mm, radius in mm; world = RAS (the NIfTI sform,\n"
    "                          else qform; NRRD, MetaImage and DICOM LPS converted)\n"
    "  --sphere-voxel I,J,K,R  centre in voxel indices (may be fractional), radius in mm\n"
    "  --sphere-from-label LABELS:L\n"
    "                          the evaluation-protocol sphere of label L of the label\n"
    "                          map LABELS (same dims as VOLUME): centre = the label's\n"
    "                          voxel farthest from its border (Euclidean, mm), in world\n"
    "                          mm by LABELS' affine; radius = half that distance.\n"
    "                          Printed on stderr; report.json gives sphere_source.\n"
    "  --names a,b,...         file and report names, one per object (default object1, ...);\n"
    "                          letters, digits, '_', '-', '.'\n"
    "\n"
    "output:\n"
    "  --out DIR               output directory (required); must not exist or be empty\n"
    "  --force                 replace a non-empty DIR\n"
    "  --labels-format FMT     nifti, nrrd or metaimage (default: the input's; nifti for DICOM)\n"
    "  --mesh-format FMT       ply (binary little endian, default), stl (binary), obj, vtk\n"
    "                          (legacy ASCII POLYDATA)\n"
    "  -q, --quiet             no progress line (nor the --sphere-from-label lines)\n"
    "\n"
    "algorithm:\n"
    "  --target MODE           binary (non-zero voxels are the object) or intensity\n"
    "                          (grey-level model); default: @TARGET@\n"
    "  --mesh-resolution N     each mesh has 6 N^2 vertices; 2..1024 (default 33)\n"
    "  --max-steps K           stop after K deformation steps (default 200)\n"
    "  --param NAME=VALUE      set an engine parameter (repeatable); NAME, default, range:\n"
    "@PARAMS@"
    "                          (full text: include/ffseg.h)\n"
    "  --max-roi-voxels N      engine crop budget per object (default: the voxel\n"
    "                          count, at most 2^26)\n"
    "\n"
    "evaluation:\n"
    "  --truth LABELS          reference label map on the same grid\n"
    "  --truth-labels a,b,...  its label for each object (default 1, 2, ...); adds\n"
    "                          Dice, VOE, ASSD and HD95 (mm) per object to the report\n"
    "\n"
    "example:\n"
    "  ffseg segment ch2bet.nii.gz --target binary --sphere 0,-17,19,60 --out brain\n";
}  // namespace

std::string segment_usage() {
  std::string s = kSegmentUsageText;
  const size_t p = s.find("@TARGET@");
  if (p != std::string::npos) s.replace(p, 8, target_name(kDefaultTarget));
  // One line per row of the parameter table.
  std::string rows;
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) {
    const ffseg::ParamSpec& f = ffseg::kParamSpecs[i];
    char line[160], range[48], def[24];
    ffseg::param_range_text(f, range, sizeof range);
    // target_mode's default here is --target's, not the engine's.
    if (std::strcmp(f.name, "target_mode") == 0) std::snprintf(def, sizeof def, "%s", target_name(kDefaultTarget));
    else std::snprintf(def, sizeof def, "%g", f.default_value);
    std::snprintf(line, sizeof line, "                            %-22s %-9s %s%s%s\n", f.name, def, range,
                  f.unit[0] ? " " : "", f.unit);
    rows += line;
  }
  const size_t q = s.find("@PARAMS@");
  if (q != std::string::npos) s.replace(q, 8, rows);
  return s;
}

int cmd_segment(int argc, char** argv) {
  const auto t_start = std::chrono::steady_clock::now();
  Args args(argc, argv, 2);
  std::string tok, volume_path, out_dir, truth_path, names_opt, truth_labels_opt;
  std::vector<SphereArg> spheres;
  ffseg_params params;
  ffseg_params_init_default(&params);
  params.target_mode = kDefaultTarget;
  uint32_t mesh_resolution = kDefaultMeshResolution;
  int64_t max_steps = kDefaultMaxSteps, max_roi = -1;
  ffseg_tools::MeshFormat mesh_format = ffseg_tools::MeshFormat::Ply;
  bool force = false, quiet = false, have_truth_labels = false, have_labels_format = false;
  ffseg_tools::ImageFormat labels_format = ffseg_tools::ImageFormat::Nifti;
  bool opt;
  while (args.next(&tok, &opt)) {
    if (!opt) {
      if (!volume_path.empty()) fail(kExitUsage, "one VOLUME only ('" + tok + "' is extra)");
      volume_path = tok;
    } else if (tok == "-h" || tok == "--help") {
      std::fputs(segment_usage().c_str(), stdout);
      return kExitOk;
    } else if (tok == "--sphere" || tok == "--sphere-voxel") {
      spheres.push_back(parse_sphere(tok, args.value(tok)));
    } else if (tok == "--sphere-from-label") {
      spheres.push_back(parse_sphere_from_label(tok, args.value(tok)));
    } else if (tok == "--out" || tok == "-o") {
      out_dir = args.value(tok);
      if (out_dir.empty()) fail(kExitUsage, "--out: empty path");
    } else if (tok == "--force") {
      force = true;
    } else if (tok == "-q" || tok == "--quiet") {
      quiet = true;
    } else if (tok == "--mesh-resolution") {
      mesh_resolution = uint32_t(parse_int(args.value(tok), tok, 2, 1024));
    } else if (tok == "--max-steps") {
      max_steps = parse_int(args.value(tok), tok, 1, 1000000);
    } else if (tok == "--max-roi-voxels") {
      max_roi = parse_int(args.value(tok), tok, 0, int64_t(1) << 40);
    } else if (tok == "--param") {
      set_param(&params, args.value(tok));
    } else if (tok == "--target") {
      const std::string v = args.value(tok);
      if (v != "binary" && v != "intensity") fail(kExitUsage, "--target: expected binary or intensity, got '" + v + "'");
      params.target_mode = parse_target(v, tok);
    } else if (tok == "--names") {
      names_opt = args.value(tok);
    } else if (tok == "--labels-format") {
      const std::string v = args.value(tok);
      if (!ffseg_tools::image_format_from_name(v, &labels_format) || labels_format == ffseg_tools::ImageFormat::Dicom)
        fail(kExitUsage, "--labels-format: expected nifti, nrrd or metaimage, got '" + v + "'");
      have_labels_format = true;
    } else if (tok == "--mesh-format") {
      const std::string v = args.value(tok);
      if (!ffseg_tools::mesh_format_from_name(v, &mesh_format))
        fail(kExitUsage, "--mesh-format: expected ply, stl, obj or vtk, got '" + v + "'");
    } else if (tok == "--truth") {
      truth_path = args.value(tok);
    } else if (tok == "--truth-labels") {
      truth_labels_opt = args.value(tok);
      have_truth_labels = true;
    } else {
      fail(kExitUsage, "unknown option " + tok + " (see 'ffseg segment --help')");
    }
  }
  if (volume_path.empty()) fail(kExitUsage, "missing VOLUME");
  if (spheres.empty())
    fail(kExitUsage,
         "no object: give at least one --sphere X,Y,Z,R, --sphere-voxel I,J,K,R or --sphere-from-label LABELS:L");
  if (spheres.size() > 64) fail(kExitUsage, "at most 64 objects, got " + std::to_string(spheres.size()));
  if (out_dir.empty()) fail(kExitUsage, "missing --out DIR");
  const uint32_t nobj = uint32_t(spheres.size());

  std::vector<std::string> names;
  if (!names_opt.empty()) {
    names = split(names_opt, ',');
    if (names.size() != nobj)
      fail(kExitUsage, "--names gives " + std::to_string(names.size()) + " name(s) for " + std::to_string(nobj) + " object(s)");
    for (size_t i = 0; i < names.size(); ++i) {
      if (!valid_name(names[i]))
        fail(kExitUsage, "--names: '" + names[i] + "' is not a valid name (letters, digits, '_', '-', '.'; not starting with '.' or '-')");
      for (size_t j = 0; j < i; ++j)
        if (names[i] == names[j]) fail(kExitUsage, "--names: '" + names[i] + "' is given twice");
    }
  } else {
    for (uint32_t k = 0; k < nobj; ++k) names.push_back("object" + std::to_string(k + 1));
  }

  std::vector<int64_t> labels;
  if (have_truth_labels) {
    if (truth_path.empty()) fail(kExitUsage, "--truth-labels needs --truth LABELS");
    for (const std::string& s : split(truth_labels_opt, ','))
      labels.push_back(parse_int(s, "--truth-labels", 1, 2147483647LL));
    if (labels.size() != nobj)
      fail(kExitUsage, "--truth-labels gives " + std::to_string(labels.size()) + " label(s) for " +
                           std::to_string(nobj) + " object(s)");
  } else {
    for (uint32_t k = 0; k < nobj; ++k) labels.push_back(int64_t(k) + 1);
  }

  // The output directory: refuse early, before any work.
  while (out_dir.size() > 1 && out_dir.back() == '/') out_dir.pop_back();
  const bool out_exists = path_exists(out_dir);
  if (out_exists && !is_directory(out_dir)) fail(kExitUsage, "--out " + out_dir + " exists and is not a directory");
  const bool out_nonempty = out_exists && !directory_is_empty(out_dir);
  if (out_nonempty && !force)
    fail(kExitUsage, "output directory " + out_dir + " exists and is not empty (use --force to replace it)");
  const std::string out_parent = parent_dir(out_dir);
  if (!is_directory(out_parent)) fail(kExitUsage, "--out: the parent directory " + out_parent + " does not exist");
  if (base_name(out_dir) == "." || base_name(out_dir) == ".." || base_name(out_dir) == "/")
    fail(kExitUsage, "--out: give a directory name, not '" + out_dir + "'");

  install_interrupt_handlers();

  // ---- inputs -----------------------------------------------------------------
  ffseg_tools::ImageFormat in_format;
  const ffseg_tools::NiftiImage img = read_image(volume_path, &in_format);
  if (!have_labels_format && in_format != ffseg_tools::ImageFormat::Dicom) labels_format = in_format;
  const std::string labels_file = ffseg_tools::label_file_name(labels_format);
  ffseg_tools::NiftiImage truth;
  std::vector<std::vector<uint8_t>> truth_masks;
  if (!truth_path.empty()) {
    truth = read_image(truth_path);
    std::string why;
    if (!same_grid(img, truth, &why))
      fail(kExitInput, "grids differ: " + why + " between " + volume_path + " and --truth " + truth_path);
    for (uint32_t k = 0; k < nobj; ++k) {
      size_t count = 0;
      truth_masks.push_back(label_mask(truth, labels[k], &count));
      if (count == 0)
        fail(kExitUsage, "--truth-labels: label " + std::to_string(labels[k]) + " has no voxel in " + truth_path);
    }
  }
  {
    std::map<std::string, const ffseg_tools::NiftiImage*> known;
    if (!truth_path.empty()) known[truth_path] = &truth;
    resolve_label_spheres(&spheres, img, volume_path, known, quiet);
  }
  const double t_read = seconds_since(t_start);
  check_interrupted();

  // ---- engine -------------------------------------------------------------------
  const uint64_t nvox = img.voxel_count();
  ffseg_config cfg;
  ffseg_config_init_default(&cfg);
  cfg.max_objects = nobj;
  cfg.mesh_resolution = mesh_resolution;
  cfg.max_roi_voxels = max_roi >= 0 ? max_roi : std::min<int64_t>(int64_t(nvox), kMaxRoiCap);
  // A binary target needs no grey-level buffers: a much smaller workspace.
  cfg.target_mode = params.target_mode == FFSEG_TARGET_BINARY ? FFSEG_TARGET_BINARY : FFSEG_TARGET_INTENSITY;
  size_t ws_bytes = 0;
  ffseg_status st = ffseg_workspace_size(&cfg, &ws_bytes);
  if (st != FFSEG_OK) {
    const std::string detail = ffseg_last_error(nullptr);
    fail(st == FFSEG_ERR_INVALID_ARGUMENT || st == FFSEG_ERR_CONFIG_TOO_LARGE ? kExitUsage : kExitEngine,
         std::string("engine configuration refused: ") + ffseg_status_string(st) + (detail.empty() ? "" : " (" + detail + ")"));
  }
  Workspace ws;
  ws.p = std::aligned_alloc(64, (ws_bytes + 63) / 64 * 64);
  if (!ws.p) fail(kExitEngine, "cannot allocate the engine workspace of " + std::to_string(ws_bytes) + " bytes");
  st = ffseg_create(&cfg, ws.p, ws_bytes, &ws.e);
  if (st != FFSEG_OK) engine_fail(nullptr, st, "ffseg_create");

  st = ffseg_set_params(ws.e, &params);
  if (st != FFSEG_OK) {
    const std::string detail = ffseg_last_error(ws.e);
    fail(st == FFSEG_ERR_INVALID_ARGUMENT ? kExitUsage : kExitEngine,
         std::string("the engine refused the parameters: ") + (detail.empty() ? ffseg_status_string(st) : detail));
  }

  // The volume, zero-copy from the NIfTI buffer (i fastest, contiguous).
  ffseg_volume vol;
  std::memset(&vol, 0, sizeof vol);
  vol.struct_size = sizeof vol;
  vol.voxel_type = uint32_t(img.voxel_type);
  vol.data = img.data.data();
  vol.data_bytes = img.data.size();
  vol.offset = 0;
  const int64_t bpv = img.bytes_per_voxel;
  for (int a = 0; a < 3; ++a) vol.dims[a] = img.dims[a];
  vol.strides[0] = bpv;
  vol.strides[1] = bpv * img.dims[0];
  vol.strides[2] = bpv * img.dims[0] * int64_t(img.dims[1]);
  std::memcpy(vol.index_to_world, img.index_to_world, sizeof vol.index_to_world);
  vol.rescale_slope = img.scl_slope;
  vol.rescale_intercept = img.scl_inter;
  st = ffseg_set_volume(ws.e, &vol);
  if (st == FFSEG_ERR_INVALID_VOLUME)
    fail(kExitInput, volume_path + " is not usable: " + ffseg_last_error(ws.e));
  if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_set_volume");

  std::vector<std::array<double, 3>> centres_mm(nobj);
  for (uint32_t k = 0; k < nobj; ++k) {
    const SphereArg& s = spheres[k];
    centres_mm[k] = s.voxel ? voxel_to_world(img.index_to_world, s.c)
                            : std::array<double, 3>{s.c[0], s.c[1], s.c[2]};
    st = ffseg_init_sphere(ws.e, k, centres_mm[k].data(), s.c[3]);
    if (st == FFSEG_ERR_SPHERE_OUTSIDE || st == FFSEG_ERR_INVALID_ARGUMENT) {
      const std::string detail = ffseg_last_error(ws.e);
      fail(kExitUsage, "object " + std::to_string(k + 1) + " (" + s.text + "): " +
                           (st == FFSEG_ERR_SPHERE_OUTSIDE ? "the sphere does not meet the volume grid (" + world_extent(img) + ")"
                                                           : (detail.empty() ? ffseg_status_string(st) : detail)));
    }
    if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_init_sphere (object " + std::to_string(k + 1) + ")");
  }
  const double t_setup = seconds_since(t_start) - t_read;

  // ---- deformation ----------------------------------------------------------------
  uint64_t stage_us[FFSEG_STAGE_COUNT] = {0};
  ffseg_step_info info;
  std::memset(&info, 0, sizeof info);
  info.struct_size = sizeof info;
  bool converged = false;
  int64_t steps = 0;
  const auto t_step0 = std::chrono::steady_clock::now();
  {
    Progress progress(!quiet, max_steps, nobj);
    for (int64_t s = 0; s < max_steps; ++s) {
      check_interrupted();
      st = ffseg_step(ws.e, &info);
      if (st == FFSEG_ERR_NOT_IMPLEMENTED) {
        const std::string detail = ffseg_last_error(ws.e);
        fail(kExitEngine, std::string("this engine build does not implement --target ") +
                              target_name(params.target_mode) + " yet" + (detail.empty() ? "" : " (" + detail + ")") +
                              (params.target_mode != FFSEG_TARGET_BINARY ? "; use --target binary on a binary mask" : ""));
      }
      if (st < 0) engine_fail(ws.e, st, "step " + std::to_string(s + 1));
      steps = s + 1;
      for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) stage_us[g] += info.stage_us[g];
      converged = st == FFSEG_CONVERGED;
      progress.step(info, seconds_since(t_step0), converged || steps == max_steps);
      if (converged) break;
    }
  }
  const double t_stepping = seconds_since(t_step0);
  check_interrupted();

  // ---- results in memory ----------------------------------------------------------
  const auto t_out0 = std::chrono::steady_clock::now();
  struct ObjectResult {
    std::vector<float> xyz;
    std::vector<uint32_t> tris;
    std::vector<uint8_t> mask;
    size_t voxels = 0;
    std::array<int, 3> centre_ijk{};
  };
  std::vector<ObjectResult> res(nobj);
  const double vox_mm3 = voxel_volume_mm3(img);
  for (uint32_t k = 0; k < nobj; ++k) {
    ObjectResult& r = res[k];
    size_t nv = 0, nt = 0;
    st = ffseg_extract_mesh(ws.e, k, nullptr, 0, nullptr, 0, &nv, &nt);
    if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_extract_mesh");
    r.xyz.resize(nv * 3);
    r.tris.resize(nt * 3);
    st = ffseg_extract_mesh(ws.e, k, r.xyz.data(), nv, r.tris.data(), nt, &nv, &nt);
    if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_extract_mesh");
    r.mask.assign(size_t(nvox), 0);
    st = ffseg_rasterize(ws.e, k, r.mask.data(), nullptr);
    if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_rasterize");
    double sum[3] = {0, 0, 0};
    size_t idx = 0;
    for (int kk = 0; kk < img.dims[2]; ++kk)
      for (int j = 0; j < img.dims[1]; ++j)
        for (int i = 0; i < img.dims[0]; ++i, ++idx)
          if (r.mask[idx]) {
            ++r.voxels;
            sum[0] += i;
            sum[1] += j;
            sum[2] += kk;
          }
    std::array<double, 3> c;
    if (r.voxels) {
      for (int a = 0; a < 3; ++a) c[size_t(a)] = sum[a] / double(r.voxels);
    } else {
      c = world_to_voxel(img.index_to_world, centres_mm[k].data());
    }
    for (int a = 0; a < 3; ++a)
      r.centre_ijk[size_t(a)] = std::min(img.dims[a] - 1, std::max(0, int(std::lround(c[size_t(a)]))));
  }
  check_interrupted();

  // ---- write everything into a temporary directory --------------------------------
  TempDir tmp;
  {
    std::string templ = out_parent + "/." + base_name(out_dir) + ".ffseg-tmp-XXXXXX";
    std::vector<char> buf(templ.begin(), templ.end());
    buf.push_back('\0');
    if (!::mkdtemp(buf.data()))
      fail(kExitFailure, "cannot create a temporary directory in " + out_parent + ": " + std::strerror(errno));
    tmp.path = buf.data();
    const mode_t mask = ::umask(0);  // mkdtemp makes 0700; use the usual mode
    ::umask(mask);
    ::chmod(tmp.path.c_str(), 0777 & ~mask);
  }
  std::string err;
  ffseg_tools::Json objects = ffseg_tools::Json::array();
  std::vector<std::string> mesh_files;
  for (uint32_t k = 0; k < nobj; ++k) {
    const ObjectResult& r = res[k];
    const std::string file = names[k] + "." + ffseg_tools::mesh_format_extension(mesh_format);
    if (!ffseg_tools::mesh_write_file(tmp.path + "/" + file, mesh_format, r.xyz.data(), r.xyz.size() / 3,
                                      r.tris.data(), r.tris.size() / 3, "SPACE=RAS", &err))
      fail(kExitFailure, err);
    mesh_files.push_back(file);
  }
  check_interrupted();

  // Label map: object k -> labels[k]; the lowest index wins on overlaps.
  const int64_t max_label = *std::max_element(labels.begin(), labels.end());
  const int ltype = max_label <= 255 ? ffseg_tools::kNiftiVoxU8
                    : max_label <= 65535 ? ffseg_tools::kNiftiVoxU16 : ffseg_tools::kNiftiVoxI32;
  ffseg_tools::NiftiImage lab = ffseg_tools::nifti_make_label_image(img, ltype);
  lab.descrip = "ffseg labels";
  for (uint32_t k = 0; k < nobj; ++k) {
    const uint8_t* m = res[k].mask.data();
    for (size_t i = 0; i < size_t(nvox); ++i) {
      if (!m[i]) continue;
      switch (ltype) {
        case ffseg_tools::kNiftiVoxU8:
          if (!lab.data[i]) lab.data[i] = uint8_t(labels[k]);
          break;
        case ffseg_tools::kNiftiVoxU16: {
          uint16_t* p = reinterpret_cast<uint16_t*>(lab.data.data()) + i;
          if (!*p) *p = uint16_t(labels[k]);
          break;
        }
        default: {
          int32_t* p = reinterpret_cast<int32_t*>(lab.data.data()) + i;
          if (!*p) *p = int32_t(labels[k]);
          break;
        }
      }
    }
  }
  if (!ffseg_tools::image_write_file(tmp.path + "/" + labels_file, labels_format, lab, &err)) fail(kExitFailure, err);
  check_interrupted();

  // Overlay picture.
  {
    ffseg_tools::OverlayVolume ov;
    ov.value = [&img](size_t i) { return voxel_value(img, i); };
    for (int a = 0; a < 3; ++a) {
      ov.dims[a] = img.dims[a];
      ov.spacing[a] = img.spacing[a];
    }
    std::memcpy(ov.index_to_world, img.index_to_world, sizeof ov.index_to_world);
    ffseg_tools::percentile_window(ov.value, size_t(nvox), 0.01, 0.99, &ov.window_lo, &ov.window_hi);
    std::vector<ffseg_tools::OverlayObject> oo(nobj);
    for (uint32_t k = 0; k < nobj; ++k) {
      oo[k].name = names[k];
      ffseg_tools::overlay_palette(k, oo[k].rgb);
      oo[k].mask = res[k].mask.data();
      if (k < truth_masks.size()) oo[k].truth = truth_masks[k].data();
      for (int a = 0; a < 3; ++a) oo[k].center_ijk[a] = res[k].centre_ijk[size_t(a)];
    }
    ffseg_tools::RgbImage picture;
    if (!ffseg_tools::overlay_render(ov, oo, &picture, &err)) fail(kExitFailure, err);
    if (!ffseg_tools::png_write_file(tmp.path + "/overlay.png", picture, &err)) fail(kExitFailure, err);
  }
  check_interrupted();

  // Report.
  using ffseg_tools::Json;
  for (uint32_t k = 0; k < nobj; ++k) {
    const ObjectResult& r = res[k];
    Json o = Json::object();
    o.set("index", k + 1);
    o.set("name", names[k]);
    o.set("label", labels[k]);
    const SphereArg& sa = spheres[k];
    o.set("sphere_source",
          sa.label_path.empty() ? std::string("command line")
                                : "label " + std::to_string(sa.label) + " of " + base_name(sa.label_path));
    Json sp = Json::object();
    sp.set("center_mm", Json::array_of(centres_mm[k].data(), 3));
    sp.set("radius_mm", sa.c[3]);
    if (sa.voxel) sp.set("center_voxel", Json::array_of(sa.c, 3));
    if (!sa.label_path.empty()) {
      sp.set("label_map", sa.label_path);
      sp.set("label", sa.label);
      sp.set("label_voxel", Json::array_of(sa.label_ijk.data(), 3));
      sp.set("depth_mm", sa.depth_mm);
    }
    o.set("sphere", std::move(sp));
    o.set("mesh", mesh_files[k]);
    o.set("vertices", uint64_t(r.xyz.size() / 3));
    o.set("triangles", uint64_t(r.tris.size() / 3));
    o.set("voxels", uint64_t(r.voxels));
    o.set("volume_ml", double(r.voxels) * vox_mm3 / 1000.0);
    o.set("centre_voxel", Json::array_of(r.centre_ijk.data(), 3));
    if (k < FFSEG_REPORT_OBJECTS) {
      o.set("final_mean_displacement_mm", info.mean_displacement_mm[k]);
      o.set("final_vertices_with_target", info.vertices_with_target[k]);
    }
    if (!truth_masks.empty()) {
      check_interrupted();
      const MaskMetrics m = compare_masks_cropped(r.mask.data(), truth_masks[k].data(), img.dims, img.spacing);
      Json mj = Json::object();
      mj.set("truth_label", labels[k]);
      mj.set("truth_voxels", uint64_t(m.voxels_b));
      mj.set("truth_volume_ml", m.vol_b_ml);
      set_metric_fields(mj, m);
      o.set("metrics", std::move(mj));
    }
    objects.push(std::move(o));
  }

  Json rep = Json::object();
  {
    const uint32_t lv = ffseg_version_number();
    rep.set("ffseg_version", std::to_string(lv / 10000) + "." + std::to_string(lv / 100 % 100) + "." + std::to_string(lv % 100));
  }
  Json cmdline = Json::array();
  for (int i = 0; i < argc; ++i) cmdline.push(argv[i]);
  rep.set("command_line", std::move(cmdline));
  Json in = Json::object();
  in.set("path", volume_path);
  in.set("format", ffseg_tools::image_format_name(in_format));
  in.set("dims", Json::array_of(img.dims, 3));
  in.set("spacing_mm", Json::array_of(img.spacing, 3));
  in.set("datatype", datatype_name(img.datatype));
  in.set("affine_source", img.which_affine);
  in.set("orientation", orientation_code(img.index_to_world));
  Json aff = Json::array();
  for (int r = 0; r < 4; ++r) aff.push(Json::array_of(img.index_to_world + 4 * r, 4));
  in.set("index_to_world", std::move(aff));
  in.set("rescale_slope", img.scl_slope);
  in.set("rescale_intercept", img.scl_inter);
  rep.set("input", std::move(in));
  if (!truth_path.empty()) rep.set("truth", truth_path);
  rep.set("target", target_name(params.target_mode));
  rep.set("steps", steps);
  rep.set("max_steps", max_steps);
  rep.set("converged", converged);
  rep.set("objects", std::move(objects));
  Json times = Json::object();
  Json stages = Json::object();
  uint64_t stage_total = 0;
  for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) {
    stages.set(kStageNames[g], double(stage_us[g]) / 1000.0);
    stage_total += stage_us[g];
  }
  times.set("read", ms(t_read));
  times.set("setup", ms(t_setup));
  times.set("stepping", ms(t_stepping));
  times.set("stages", std::move(stages));
  times.set("stages_total", double(stage_total) / 1000.0);
  times.set("outputs", ms(seconds_since(t_out0)));
  times.set("total", ms(seconds_since(t_start)));
  rep.set("time_ms", std::move(times));
  rep.set("workspace_bytes", uint64_t(ws_bytes));
  Json cj = Json::object();
  cj.set("max_objects", cfg.max_objects);
  cj.set("mesh_resolution", cfg.mesh_resolution);
  cj.set("max_roi_voxels", cfg.max_roi_voxels);
  rep.set("config", std::move(cj));
  rep.set("parameters", params_json(params));
  Json outs = Json::object();
  Json mf = Json::array();
  for (const std::string& f : mesh_files) mf.push(f);
  outs.set("meshes", std::move(mf));
  outs.set("mesh_format", ffseg_tools::mesh_format_extension(mesh_format));
  outs.set("labels", labels_file);
  outs.set("overlay", "overlay.png");
  rep.set("outputs", std::move(outs));
  if (!write_text_file(tmp.path + "/report.json", rep.dump(), &err)) fail(kExitFailure, err);
  check_interrupted();

  // ---- move into place ------------------------------------------------------------
  if (out_nonempty) {
    // --force: set the old directory aside, move the new one in, then delete the old.
    const std::string aside = out_parent + "/." + base_name(out_dir) + ".ffseg-old-" + std::to_string(::getpid());
    remove_tree(aside);
    if (std::rename(out_dir.c_str(), aside.c_str()) != 0)
      fail(kExitFailure, "cannot move the old " + out_dir + " aside: " + std::strerror(errno));
    if (std::rename(tmp.path.c_str(), out_dir.c_str()) != 0) {
      const int e = errno;
      std::rename(aside.c_str(), out_dir.c_str());
      fail(kExitFailure, "cannot rename the results to " + out_dir + ": " + std::strerror(e));
    }
    tmp.keep = true;
    remove_tree(aside);
  } else {
    // rename() replaces an empty directory.
    if (std::rename(tmp.path.c_str(), out_dir.c_str()) != 0)
      fail(kExitFailure, "cannot rename the results to " + out_dir + ": " + std::strerror(errno));
    tmp.keep = true;
  }

  // Summary on stdout.
  std::printf("%s after %lld step%s in %.2f s; outputs in %s/\n", converged ? "converged" : "stopped",
              static_cast<long long>(steps), steps == 1 ? "" : "s", t_stepping, out_dir.c_str());
  for (uint32_t k = 0; k < nobj; ++k) {
    const Json& o = (*rep.get("objects"))[k];
    std::printf("  %-16s %8.3f ml  %6llu vertices", names[k].c_str(), o.get("volume_ml")->as_number(),
                static_cast<unsigned long long>(res[k].xyz.size() / 3));
    if (const Json* m = o.get("metrics"))
      std::printf("  dice %.4f  voe %.4f  assd %.3f mm  hd95 %.3f mm", m->get("dice")->as_number(),
                  m->get("voe")->as_number(), m->get("assd_mm")->as_number(), m->get("hd95_mm")->as_number());
    std::printf("\n");
  }
  return kExitOk;
}

}  // namespace ffseg_cli
