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
#include "segment_options.h"
#include "mesh_resolution.h"
#include "segment_outputs.h"
#include "report_json.h"

namespace ffseg_cli {

namespace {

// Milliseconds rounded to the microsecond (for the report).
double ms(double seconds) { return std::round(seconds * 1e6) / 1000.0; }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The workspace: 64-byte aligned, freed on scope exit (after ffseg_destroy).
struct Workspace {
  void* p = nullptr;
  ffseg_engine* e = nullptr;
  void release() {
    ffseg_destroy(e);
    std::free(p);
    e = nullptr;
    p = nullptr;
  }
  ~Workspace() { release(); }
};

// A temporary file removed on scope exit unless committed.
struct TempFile {
  std::string path;
  bool keep = false;
  ~TempFile() {
    if (!path.empty() && !keep) std::remove(path.c_str());
  }
};

bool ends_with(const std::string& s, const char* suffix) {
  const size_t n = std::strlen(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

// A temporary output directory removed on scope exit unless committed.
struct TempDir {
  std::string path;
  bool keep = false;
  ~TempDir() {
    if (!path.empty() && !keep) remove_tree(path);
  }
};

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

int cmd_segment(int argc, char** argv) {
  const auto t_start = std::chrono::steady_clock::now();
  Args args(argc, argv, 2);
  std::string tok, volume_path, out_dir, truth_path, names_opt, truth_labels_opt, regions_path;
  std::vector<SphereArg> spheres;
  ffseg_params params;
  ffseg_params_init_default(&params);
  params.target_mode = kDefaultTarget;
  uint32_t mesh_resolution = 0;  // automatic (mesh_resolution.h)
  double window_opt[2] = {0, 1};  // --window LO,HI (overlay grey levels)
  bool have_window = false;
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
    } else if (tok == "--window") {
      const std::string v = args.value(tok);
      const size_t comma = v.find(',');
      if (comma == std::string::npos) fail(kExitUsage, "--window: expected LO,HI, got '" + v + "'");
      window_opt[0] = parse_double(v.substr(0, comma), tok);
      window_opt[1] = parse_double(v.substr(comma + 1), tok);
      if (!(window_opt[1] > window_opt[0])) fail(kExitUsage, "--window: HI must be above LO, got '" + v + "'");
      have_window = true;
    } else if (tok == "--mesh-resolution") {
      const std::string v = args.value(tok);
      mesh_resolution = v == "auto" ? 0 : uint32_t(parse_int(v, tok, 2, 1024));
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
    } else if (tok == "--regions") {
      regions_path = args.value(tok);
      if (regions_path.empty()) fail(kExitUsage, "--regions: empty path");
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
    labels = default_labels(spheres);
  }
  if (!regions_path.empty()) {
    if (nobj < 2)
      fail(kExitUsage, "--regions: bounding regions exist only for two or more objects (thesis 6.2), got one");
    if (path_exists(regions_path) && !force)
      fail(kExitUsage, "--regions " + regions_path + " exists (use --force to replace it)");
    if (is_directory(regions_path)) fail(kExitUsage, "--regions " + regions_path + " is a directory");
    if (!ends_with(regions_path, ".nii.gz") && !ends_with(regions_path, ".nii") && !ends_with(regions_path, ".nrrd") &&
        !ends_with(regions_path, ".mha"))
      fail(kExitUsage, "--regions " + regions_path + ": the file name must end in .nii.gz, .nii, .nrrd or .mha");
    if (!is_directory(parent_dir(regions_path)))
      fail(kExitUsage, "--regions: the parent directory " + parent_dir(regions_path) + " does not exist");
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
  // Non-finite grey levels (float volumes): the engine leaves them out of the
  // intensity model and its crop reads them as a background value, so they
  // count as outside every object; say how many there are.
  size_t nonfinite_voxels = 0;
  if (img.voxel_type == FFSEG_F32 || img.voxel_type == FFSEG_F64)
    for_each_stored(img, [&](size_t, double v) { nonfinite_voxels += !std::isfinite(img.scl_slope * v + img.scl_inter); });
  if (nonfinite_voxels > 0)  // a warning, also with --quiet
    std::fprintf(stderr, "ffseg: warning: %zu voxels of %s are not finite (NaN or infinite); they are left out of the "
                 "intensity model and read as outside every object\n", nonfinite_voxels, volume_path.c_str());
  const double t_read = seconds_since(t_start);
  check_interrupted();

  // ---- engine, deformation ------------------------------------------------------
  // Without --mesh-resolution the first run at kFirstResolution measures each
  // object's surface and the run is made again when they ask for a finer mesh
  // (mesh_resolution.h).
  const uint64_t nvox = img.voxel_count();
  const bool auto_resolution = mesh_resolution == 0;
  uint32_t run_resolution = auto_resolution ? kFirstResolution : mesh_resolution;
  uint32_t wanted_resolution = 0;  // automatic: what the first run's surfaces asked for
  ffseg_status st = FFSEG_OK;
  ffseg_config cfg;
  size_t ws_bytes = 0;
  Workspace ws;
  ffseg_volume vol;
  std::vector<std::array<double, 3>> centres_mm(nobj);
  double t_setup = 0, t_stepping_before = 0;
  uint64_t stage_us[FFSEG_STAGE_COUNT] = {0};
  ffseg_step_info info;
  bool converged = false;
  int64_t steps = 0;
  std::vector<uint32_t> border_vertices;  // at the last step each object moved
  auto t_step0 = std::chrono::steady_clock::now();
  for (int pass = 0;; ++pass) {
    // ---- engine -------------------------------------------------------------------
    ffseg_config_init_default(&cfg);
    cfg.max_objects = nobj;
    cfg.mesh_resolution = run_resolution;
    cfg.max_roi_voxels = max_roi >= 0 ? max_roi : std::min<int64_t>(int64_t(nvox), kMaxRoiCap);
    // A binary target needs no grey-level buffers: a much smaller workspace.
    cfg.target_mode = params.target_mode == FFSEG_TARGET_BINARY ? FFSEG_TARGET_BINARY : FFSEG_TARGET_INTENSITY;
    ws_bytes = 0;
    st = ffseg_workspace_size(&cfg, &ws_bytes);
    if (st != FFSEG_OK) {
      const std::string detail = ffseg_last_error(nullptr);
      fail(st == FFSEG_ERR_INVALID_ARGUMENT || st == FFSEG_ERR_CONFIG_TOO_LARGE ? kExitUsage : kExitEngine,
           std::string("engine configuration refused: ") + ffseg_status_string(st) + (detail.empty() ? "" : " (" + detail + ")"));
    }
    ws.release();
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
    t_setup = seconds_since(t_start) - t_read - t_stepping_before;

    // ---- deformation ----------------------------------------------------------------
    for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) stage_us[g] = 0;
    std::memset(&info, 0, sizeof info);
    info.struct_size = sizeof info;
    converged = false;
    steps = 0;
    border_vertices.assign(nobj, 0);
    t_step0 = std::chrono::steady_clock::now();
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
        for (uint32_t k = 0; k < nobj && k < FFSEG_REPORT_OBJECTS; ++k) {
          if (info.vertices_with_target[k] > 0 || info.mean_displacement_mm[k] > 0)
            border_vertices[k] = info.border_vertices[k];
        }
        converged = st == FFSEG_CONVERGED;
        const bool at_rest = converged || st == FFSEG_DEGENERATE;
        progress.step(info, seconds_since(t_step0), at_rest || steps == max_steps);
        if (at_rest) break;
      }
    }
    // A finer mesh would not make a segmentation of a result that is none.
    if (!auto_resolution || pass > 0 || info.flags_all != 0) break;
    // How fine a mesh the surfaces ask for.
    wanted_resolution = kFirstResolution;
    for (uint32_t k = 0; k < nobj; ++k) {
      size_t nv = 0, nt = 0;
      st = ffseg_extract_mesh(ws.e, k, nullptr, 0, nullptr, 0, &nv, &nt);
      if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_extract_mesh");
      std::vector<float> xyz(nv * 3);
      std::vector<uint32_t> tris(nt * 3);
      st = ffseg_extract_mesh(ws.e, k, xyz.data(), nv, tris.data(), nt, &nv, &nt);
      if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_extract_mesh");
      const double h = std::min(img.spacing[0], std::min(img.spacing[1], img.spacing[2]));
      wanted_resolution = std::max(wanted_resolution, resolution_for_area(mesh_area_mm2(xyz, tris), h));
    }
    const uint32_t again = rerun_resolution(wanted_resolution);
    if (again == 0) break;
    if (!quiet)
      std::fprintf(stderr, "ffseg: the surfaces ask for mesh resolution %u; segmenting again at it "
                   "(--mesh-resolution N to fix one)\n", again);
    t_stepping_before += seconds_since(t_step0);
    run_resolution = again;
  }
  const double t_stepping = seconds_since(t_step0);
  check_interrupted();

  // ---- results in memory ----------------------------------------------------------
  const auto t_out0 = std::chrono::steady_clock::now();
  std::vector<ObjectResult> res = read_results(ws.e, img, nobj, centres_mm);
  size_t shared_voxels = 0;
  for (uint32_t k = 0; k < nobj; ++k) {
    res[k].border_vertices = border_vertices[k];
    shared_voxels += res[k].shared_voxels;
  }
  // A run that found nothing is not a segmentation, by the engine's flags
  // (FFSEG_DEGENERATE at rest; as of the last step when stopped at
  // --max-steps): no vertex of an object ever met a boundary (its mesh stayed
  // the sphere), or the object fills most of the grid (a sphere around the
  // whole scan: every voxel labelled). Exit 5, nothing written.
  for (uint32_t k = 0; k < nobj && k < FFSEG_REPORT_OBJECTS; ++k) {
    const std::string who = "object " + std::to_string(k + 1) + " (" + names[k] + ")";
    if (info.object_flags[k] & FFSEG_OBJECT_NO_BOUNDARY)
      fail(kExitNoResult, who + ": no vertex found a boundary along its normal in " + std::to_string(steps) +
                              " steps; the sphere is not inside or near an object of the target (check --sphere and --target)");
    if (info.object_flags[k] & FFSEG_OBJECT_FILLS_GRID)
      fail(kExitNoResult, who + " fills " + std::to_string(int(100.0 * double(res[k].voxels) / double(nvox) + 0.5)) +
                              "% of the volume grid: no organ boundary held it (is the sphere larger than the organ?)");
  }
  if (info.flags_all != 0)  // an object past the engine's per-object report
    fail(kExitNoResult, "one of objects " + std::to_string(FFSEG_REPORT_OBJECTS + 1) + ".." + std::to_string(nobj) +
                            (info.flags_all & FFSEG_OBJECT_NO_BOUNDARY
                                 ? ": no vertex found a boundary along its normal (check --sphere and --target)"
                                 : " fills most of the volume grid: no organ boundary held it"));
  ffseg_tools::NiftiImage regions_map;
  if (!regions_path.empty()) regions_map = region_label_map(ws.e, img, labels);
  const double vox_mm3 = voxel_volume_mm3(img);
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

  // Label map: object k -> labels[k], each voxel claimed once (read_results).
  const ffseg_tools::NiftiImage lab = object_label_map(img, res, labels);
  if (!ffseg_tools::image_write_file(tmp.path + "/" + labels_file, labels_format, lab, &err)) fail(kExitFailure, err);
  check_interrupted();

  double window[2] = {window_opt[0], window_opt[1]};
  if (!have_window) object_window(img, res, &window[0], &window[1]);
  if (!write_overlay(tmp.path + "/overlay.png", img, res, names, truth_masks, window[0], window[1], &err))
    fail(kExitFailure, err);
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
    if (nobj > 1) {
      if (k < FFSEG_REPORT_OBJECTS) o.set("border_vertices", r.border_vertices);  // ffseg_step_info's reach
      o.set("shared_voxels", uint64_t(r.shared_voxels));
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
  rep.set("non_finite_voxels", uint64_t(nonfinite_voxels));
  rep.set("steps", steps);
  rep.set("max_steps", max_steps);
  rep.set("converged", converged);
  rep.set("objects", std::move(objects));
  if (nobj > 1) rep.set("shared_voxels", uint64_t(shared_voxels));
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
  cj.set("mesh_resolution", run_resolution);
  cj.set("mesh_resolution_source", auto_resolution ? "automatic" : "--mesh-resolution");
  if (auto_resolution) {
    // The first run's resolution and what its surfaces asked for (mesh_resolution.h).
    cj.set("first_mesh_resolution", kFirstResolution);
    cj.set("asked_mesh_resolution", wanted_resolution);
  }
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
  outs.set("overlay_window", Json::array_of(window, 2));
  outs.set("overlay_window_source", have_window ? "--window" : "objects");
  if (!regions_path.empty()) outs.set("regions", regions_path);
  rep.set("outputs", std::move(outs));
  if (!write_text_file(tmp.path + "/report.json", rep.dump(), &err)) fail(kExitFailure, err);
  check_interrupted();

  // The bounding regions beside it (renamed into place after DIR).
  TempFile regions_tmp;
  if (!regions_path.empty()) {
    regions_tmp.path = parent_dir(regions_path) + "/.ffseg-tmp-" + std::to_string(::getpid()) + "-" +
                       base_name(regions_path);
    if (!ffseg_tools::image_write_file(regions_tmp.path, ffseg_tools::image_format_of_path(regions_path),
                                       regions_map, &err))
      fail(kExitFailure, err);
  }
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

  if (!regions_path.empty()) {
    if (std::rename(regions_tmp.path.c_str(), regions_path.c_str()) != 0)
      fail(kExitFailure, "cannot rename the bounding regions to " + regions_path + ": " + std::strerror(errno));
    regions_tmp.keep = true;
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
    if (nobj > 1) std::printf("  border %u", res[k].border_vertices);
    std::printf("\n");
  }
  if (nobj > 1) {
    uint64_t rest = 0;
    for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) rest += g == FFSEG_STAGE_REGIONS ? 0 : stage_us[g];
    std::printf("  %u objects in one engine: bounding regions %.2f s, the rest of the steps %.2f s; "
                "%llu voxel%s inside two meshes (labelled as the first)%s%s\n",
                nobj, double(stage_us[FFSEG_STAGE_REGIONS]) / 1e6, double(rest) / 1e6,
                static_cast<unsigned long long>(shared_voxels), shared_voxels == 1 ? "" : "s",
                regions_path.empty() ? "" : "; regions in ", regions_path.c_str());
  }
  return kExitOk;
}

}  // namespace ffseg_cli
