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
#include <thread>

#include "cli.h"
#include "engine_volume.h"
#include "ffseg.h"
#include "mesh_io.h"
#include "metrics.h"
#include "overlay.h"
#include "segment_options.h"
#include "mesh_resolution.h"
#include "refinement_reach.h"
#include "seed_check.h"
#include "segment_outputs.h"
#include "workspace_budget.h"
#include "dicom_outputs.h"
#include "dicom_study.h"
#include "label_grid.h"
#include "report_html.h"
#include "report_json.h"

namespace ffseg_cli {

namespace {

// Milliseconds rounded to the microsecond (for the report).
double ms(double seconds) { return std::round(seconds * 1e6) / 1000.0; }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The workspace: 64-byte aligned, freed on scope exit (after ffseg_destroy);
// one owner at a time.
struct Workspace {
  void* p = nullptr;
  ffseg_engine* e = nullptr;
  Workspace() = default;
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;
  Workspace& operator=(Workspace&& o) noexcept {
    if (this != &o) {
      release();
      std::swap(p, o.p);
      std::swap(e, o.e);
    }
    return *this;
  }
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

// An output outside DIR (--regions, --dicom-seg, --rtstruct): written to a
// temporary name beside it, renamed after DIR.
struct SideFile {
  std::string dest;
  TempFile tmp;
};
using SideFiles = std::vector<std::unique_ptr<SideFile>>;

std::string add_side_file(SideFiles* sides, const std::string& dest) {
  sides->push_back(std::make_unique<SideFile>());
  SideFile& f = *sides->back();
  f.dest = dest;
  f.tmp.path = parent_dir(dest) + "/.ffseg-tmp-" + std::to_string(::getpid()) + "-" + base_name(dest);
  return f.tmp.path;
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

// What was read: the volume, the truth's masks (one per object, or none)
// and the name of the label map to write.
struct Inputs {
  ffseg_tools::NiftiImage img;
  ffseg_tools::ImageFormat format = ffseg_tools::ImageFormat::Nifti;
  ffseg_tools::ImageFormat labels_format = ffseg_tools::ImageFormat::Nifti;
  std::string labels_file;
  ffseg_tools::NiftiImage truth;
  std::vector<std::vector<uint8_t>> truth_masks;
  size_t nonfinite_voxels = 0;
  ffseg_tools::DicomSource dicom;  // the series' identifiers, or a generated study
};

// The DICOM objects written, for the report.
struct DicomWritten {
  std::string seg, rtstruct;
  size_t contours = 0;
};

// Reads the volume and --truth, fills in the --sphere-from-label spheres and
// counts the non-finite voxels (a warning, also with --quiet).
void read_inputs(SegmentRequest* rq, Inputs* in) {
  in->img = read_image(rq->volume_path, &in->format, &in->dicom);
  if (in->format != ffseg_tools::ImageFormat::Dicom) {
    in->dicom = ffseg_tools::dicom_generated_source(rq->volume_path);
  } else if (in->dicom.frame_of_reference_uid.empty()) {
    in->dicom.frame_of_reference_uid = ffseg_tools::dicom_new_uid();
    in->dicom.note = "made from a series without FrameOfReferenceUID (0020,0052): they carry a new frame of reference";
  }
  const ffseg_tools::NiftiImage& img = in->img;
  in->labels_format = rq->labels_format;
  if (!rq->have_labels_format && in->format != ffseg_tools::ImageFormat::Dicom) in->labels_format = in->format;
  in->labels_file = ffseg_tools::label_file_name(in->labels_format);
  if (!rq->truth_path.empty()) {
    in->truth = read_on_grid(img, rq->volume_path, rq->truth_path, "--truth", rq->resample_labels, rq->quiet);
    for (uint32_t k = 0; k < rq->objects(); ++k) {
      size_t count = 0;
      in->truth_masks.push_back(label_mask(in->truth, rq->labels[k], &count));
      if (count == 0)
        fail(kExitUsage, "--truth-labels: label " + std::to_string(rq->labels[k]) + " has no voxel in " + rq->truth_path);
    }
  }
  {
    std::map<std::string, const ffseg_tools::NiftiImage*> known;
    if (!rq->truth_path.empty()) known[rq->truth_path] = &in->truth;
    resolve_label_spheres(&rq->spheres, img, rq->volume_path, known, rq->resample_labels, rq->quiet);
  }
  // Non-finite grey levels (float volumes): the engine leaves them out of the
  // intensity model and its crop reads them as a background value, so they
  // count as outside every object; say how many there are.
  if (img.voxel_type == FFSEG_F32 || img.voxel_type == FFSEG_F64)
    for_each_stored(img, [&](size_t, double v) { in->nonfinite_voxels += !std::isfinite(img.scl_slope * v + img.scl_inter); });
  if (in->nonfinite_voxels > 0)
    std::fprintf(stderr, "ffseg: warning: %zu voxels of %s are not finite (NaN or infinite); they are left out of the "
                 "intensity model and read as outside every object\n", in->nonfinite_voxels, rq->volume_path.c_str());
}

// Where an object's mesh started in the last engine (report.json:
// objects[].started_from).
constexpr uint8_t kStartSphere = 0, kStartFirstRun = 1;
const char* start_name(uint8_t k) { return k == kStartFirstRun ? "first run" : "sphere"; }

// The first run's meshes never cross, but resampled to the finer resolution
// two that touch may: each fine vertex lies on the bilinear patch of its
// coarse cell, not on the coarse triangles, and the patches bulge by a
// fraction of a voxel. A refused mesh is tried again scaled about its
// centroid by these factors (a similarity: it still does not cross itself)
// before its sphere: the nine organs' vena cava fits at 0.99, where from its
// sphere it grew again alone for 30 steps and ended at 0.527 against 0.614
// (over seven placements of every sphere the nine 0.615 -> 0.620;
// BENCHMARKS.md section 12).
constexpr double kFirstRunScales[] = {1.0, 0.99, 0.98, 0.95};

// xyz (3 floats per vertex) scaled by f about its centroid (the vertices'
// mean, summed in order in double), each coordinate rounded to float once:
// the bindings' segment() computes the same bits.
std::vector<float> scaled_about_centroid(const std::vector<float>& xyz, double f) {
  if (f == 1.0) return xyz;
  const size_t nv = xyz.size() / 3;
  double c[3] = {0, 0, 0};
  for (size_t i = 0; i < nv; ++i)
    for (int a = 0; a < 3; ++a) c[a] += double(xyz[3 * i + a]);
  for (int a = 0; a < 3; ++a) c[a] /= double(nv);
  std::vector<float> out(xyz.size());
  for (size_t i = 0; i < nv; ++i)
    for (int a = 0; a < 3; ++a) out[3 * i + a] = float(c[a] + f * (double(xyz[3 * i + a]) - c[a]));
  return out;
}

// What the last pass left for the outputs beside its engine: its engine's
// sizes and placements, how its steps went and how long they took.
struct PassRecord {
  ffseg_config cfg{};
  size_t ws_bytes = 0;
  uint32_t resolution = 0;         // the last run's mesh resolution
  std::vector<std::array<double, 3>> centres_mm;
  uint64_t stage_us[FFSEG_STAGE_COUNT] = {0};
  ffseg_step_info info{};
  bool converged = false;
  int64_t steps = 0;
  std::vector<uint32_t> border_vertices;  // at the last step each object moved
  // Where the last engine placed each object: kStartSphere or
  // kStartFirstRun (its first-run mesh, scaled by first_run_scale).
  std::vector<uint8_t> start;
  std::vector<double> first_run_scale;
  std::vector<std::array<double, 3>> far;  // outward, inward, vertices: at each object's last moving step
  // Steps of the last pass in which each object's mesh re-spaced its loops
  // (ffseg_step_info.respaced), and whether its first step did: a grey-level
  // object then grows freely (grey_respacing; by default where its boundary
  // is in view).
  std::vector<int64_t> respaced_steps;
  std::vector<uint8_t> grows_freely;
  double t_stepping = 0;  // seconds: the last pass's steps (as stage_us)
  bool budget_reduced = false;  // the last engine's sizes are below the scan's (workspace_budget.h)
};

// The engine's run: its workspace (the results are read from it), the last
// pass's record, and what the passes before it left.
struct EngineRun : PassRecord {
  Workspace ws;
  uint32_t wanted_resolution = 0;  // automatic: what the first run's surfaces asked for
  // Coarse to fine (a resolution above the first): each object's first-run
  // mesh (xyz, kFirstResolution) the finer run starts from, and whether that
  // run stalled; stalled: each object's FFSEG_OBJECT_STALLED at the end, and
  // from_coarse: objects whose finer run stalled and that were put back on
  // their first-run surface instead (every object when the finer run was
  // given up: finer_given_up).
  std::vector<std::vector<float>> coarse;
  std::vector<uint64_t> coarse_voxels;  // each first-run mesh's voxels
  std::vector<uint8_t> coarse_stalled, stalled, from_coarse;
  bool start_from_coarse = false;  // the next engine starts from `coarse`
  // The finer run re-spaces its loops (refinement_reach.h): while
  // respacing, each object is held to reach_mm3 (its first-run mesh's
  // refinement_reach_mm3); left_reach: the first object to enclose more
  // (else -1), at step left_step, enclosing left_mm3. finer_respaced: the
  // finer run that stands is the re-spaced one.
  bool respacing = false, finer_respaced = false;
  std::vector<double> reach_mm3;
  int64_t left_reach = -1, left_step = 0;
  double left_mm3 = 0;
  // The finer run was given up for the first run's resolution (run_engine_once).
  bool finer_given_up = false;
  // The re-spaced pass at the first run's own resolution (run_engine_once)
  // left its reach, and the first run, kept meanwhile, stands, or the run
  // from the sphere at kLeakerResolution that encloses fewer voxels
  // (refinement_reach.h): leaker_voxels its voxels (0: not run),
  // leaker_run_stands when it is the result.
  bool first_run_stands = false;
  uint64_t leaker_voxels = 0;
  bool leaker_run_stands = false;
  // Seconds: every pass's engine setup.
  double t_setup = 0;
  // Every pass's steps and stepping (the first run's and the finer run's):
  // what the whole segmentation cost, not only its last pass.
  int64_t steps_all = 0;
  double t_stepping_all = 0;
  int passes = 0;
  // The workspace budget the engines are sized by: --memory, doubled each
  // time an organ outgrew a crop or region the budget gave it (run_engine).
  uint64_t memory_bytes = 0;
  int budget_raises = 0;
};

// Coarse to fine: an object the finer engine refuses from its first-run mesh
// (scaled too) and from its sphere, the others' finer meshes being in the
// way (run_engine_once gives the finer run up).
struct NoFinerStart {
  uint32_t object;
  std::string detail;
};

// An organ outgrew the crop or region the memory budget gave it
// (FFSEG_ERR_ROI_TOO_LARGE with sizes the budget chose): run_engine starts
// the run again with a larger budget.
struct OutgrewBudget {
  std::string detail;
};

// The engine's message about object k's placement in the tool's terms: the
// engine counts objects from 0 ("overlaps object 0"), the tool from 1 and
// by name, so the other object is named as the tool's messages name it.
std::string placement_message(const SegmentRequest& rq, const char* engine_msg) {
  std::string m = engine_msg ? engine_msg : "";
  const std::string key = "overlaps object ";
  const size_t at = m.find(key);
  if (at == std::string::npos) return m;
  const size_t from = at + key.size();
  size_t to = from;
  while (to < m.size() && m[to] >= '0' && m[to] <= '9') ++to;
  if (to == from || to - from > 9) return m;
  const unsigned long other = std::stoul(m.substr(from, to - from));
  if (other >= rq.objects()) return m;
  return m.substr(0, from) + std::to_string(other + 1) + " (" + rq.names[other] + ")" + m.substr(to);
}

// A new engine for the request at run->resolution, the volume set (the
// image's buffer, borrowed) and every sphere placed.
void start_engine(const SegmentRequest& rq, const ffseg_tools::NiftiImage& img, EngineRun* run) {
  ffseg_config& cfg = run->cfg;
  ffseg_config_init_default(&cfg);
  cfg.max_objects = rq.objects();
  cfg.mesh_resolution = run->resolution;
  // A binary target needs no grey-level buffers: a much smaller workspace.
  cfg.target_mode = rq.params.target_mode == FFSEG_TARGET_BINARY ? FFSEG_TARGET_BINARY : FFSEG_TARGET_INTENSITY;
  const WorkspaceSizing sz =
      size_workspace(cfg, int64_t(img.voxel_count()), rq.max_roi, rq.max_region, run->memory_bytes, kMaxRoiCap);
  run->budget_reduced = sz.reduced;
  cfg.max_roi_voxels = sz.max_roi_voxels;
  cfg.max_region_voxels = sz.max_region_voxels;
  if (!sz.fits && !rq.quiet)
    std::fprintf(stderr, "ffseg: the engine's workspace (%.0f MB) exceeds --memory %.0f MB\n", sz.bytes / 1e6,
                 run->memory_bytes / 1e6);
  run->ws_bytes = 0;
  ffseg_status st = ffseg_workspace_size(&cfg, &run->ws_bytes);
  if (st != FFSEG_OK) {
    const std::string detail = ffseg_last_error(nullptr);
    fail(st == FFSEG_ERR_INVALID_ARGUMENT || st == FFSEG_ERR_CONFIG_TOO_LARGE ? kExitUsage : kExitEngine,
         std::string("engine configuration refused: ") + ffseg_status_string(st) + (detail.empty() ? "" : " (" + detail + ")"));
  }
  Workspace& ws = run->ws;
  ws.release();
  ws.p = std::aligned_alloc(64, (run->ws_bytes + 63) / 64 * 64);
  if (!ws.p) fail(kExitEngine, "cannot allocate the engine workspace of " + std::to_string(run->ws_bytes) + " bytes");
  st = ffseg_create(&cfg, ws.p, run->ws_bytes, &ws.e);
  if (st != FFSEG_OK) engine_fail(nullptr, st, "ffseg_create");

  ffseg_params params = rq.params;
  if (run->respacing) params.grey_respacing = 1;
  st = ffseg_set_params(ws.e, &params);
  if (st != FFSEG_OK) {
    const std::string detail = ffseg_last_error(ws.e);
    fail(st == FFSEG_ERR_INVALID_ARGUMENT ? kExitUsage : kExitEngine,
         std::string("the engine refused the parameters: ") + (detail.empty() ? ffseg_status_string(st) : detail));
  }

  const ffseg_volume vol = ffseg_tools::engine_volume(img);
  st = ffseg_set_volume(ws.e, &vol);
  if (st == FFSEG_ERR_INVALID_VOLUME) fail(kExitInput, rq.volume_path + " is not usable: " + ffseg_last_error(ws.e));
  if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_set_volume");

  run->centres_mm.assign(rq.objects(), {});
  run->start.assign(rq.objects(), kStartSphere);
  run->first_run_scale.assign(rq.objects(), 1.0);
  // Resampled to the finer resolution, two first-run meshes that touch may
  // overlap (kFirstRunScales), and the engine refuses the one placed second:
  // the larger organs go first (by their first-run volume), so that the
  // smaller one is the one scaled, or sent back to its sphere. A large organ
  // sent back to its sphere loses most: on the 1 mm CT the liver at n = 49
  // jams from it (BENCHMARKS.md section 7).
  std::vector<uint32_t> order(rq.objects());
  for (uint32_t k = 0; k < rq.objects(); ++k) order[k] = k;
  if (run->start_from_coarse && run->coarse_voxels.size() == rq.objects())
    std::stable_sort(order.begin(), order.end(),
                     [&](uint32_t a, uint32_t b) { return run->coarse_voxels[a] > run->coarse_voxels[b]; });
  for (const uint32_t k : order) {
    const SphereArg& s = rq.spheres[k];
    run->centres_mm[k] =
        s.voxel ? voxel_to_world(img.index_to_world, s.c) : std::array<double, 3>{s.c[0], s.c[1], s.c[2]};
    // Coarse to fine: the first run's mesh, resampled (its model still from
    // the sphere), scaled about its centroid where the engine refuses it,
    // else the sphere.
    st = FFSEG_ERR_INVALID_ARGUMENT;
    std::string refused;  // the engine's reason for the unscaled mesh
    for (const double f : kFirstRunScales) {
      if (!run->start_from_coarse) break;
      const std::vector<float> xyz = scaled_about_centroid(run->coarse[k], f);
      st = ffseg_init_mesh(ws.e, k, run->centres_mm[k].data(), s.c[3], xyz.data(), xyz.size() / 3);
      if (st == FFSEG_OK) {
        run->start[k] = kStartFirstRun;
        run->first_run_scale[k] = f;
        if (f != 1.0 && !rq.quiet)
          std::fprintf(stderr, "ffseg: object %u (%s): its first-run mesh overlapped a neighbour's (%s); placed "
                       "scaled by %g about its centroid\n", k + 1, rq.names[k].c_str(), refused.c_str(), f);
        break;
      }
      if (f == 1.0) refused = placement_message(rq, ffseg_last_error(ws.e));
    }
    if (st != FFSEG_OK && run->start_from_coarse && !rq.quiet)
      std::fprintf(stderr, "ffseg: object %u (%s): the engine refused its first-run mesh (%s), scaled too; it "
                   "starts from its sphere\n", k + 1, rq.names[k].c_str(), refused.c_str());
    if (st != FFSEG_OK) st = ffseg_init_sphere(ws.e, k, run->centres_mm[k].data(), s.c[3]);
    if (st == FFSEG_ERR_INVALID_ARGUMENT && run->start_from_coarse && run->resolution != kFirstResolution)
      throw NoFinerStart{k, placement_message(rq, ffseg_last_error(ws.e))};
    if (st == FFSEG_ERR_SPHERE_OUTSIDE || st == FFSEG_ERR_INVALID_ARGUMENT) {
      const std::string detail = placement_message(rq, ffseg_last_error(ws.e));
      fail(kExitUsage, "object " + std::to_string(k + 1) + " (" + s.text + "): " +
                           (st == FFSEG_ERR_SPHERE_OUTSIDE ? "the sphere does not meet the volume grid (" + world_extent(img) + ")"
                                                           : (detail.empty() ? ffseg_status_string(st) : detail)));
    }
    if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_init_sphere (object " + std::to_string(k + 1) + ")");
  }
  // The reach bounds a refinement of the first run's surface: an object the
  // engine refused there grows from its sphere, as without re-spacing (a
  // 2 mm sphere of the 1 mm CT re-spaced from it stalled, could not be put
  // back, and the first run's leak of 490 ml stood).
  if (run->respacing && run->start[0] != kStartFirstRun) {
    run->respacing = false;
    run->finer_respaced = false;
    st = ffseg_set_params(ws.e, &rq.params);
    if (st != FFSEG_OK) engine_fail(ws.e, st, "ffseg_set_params");
  }
}

// Object k's mesh as the engine extracts it: xyz, and tris when given.
std::vector<float> mesh_vertices(const ffseg_engine* e, uint32_t k, std::vector<uint32_t>* tris = nullptr) {
  size_t nv = 0, nt = 0;
  ffseg_status st = ffseg_extract_mesh(e, k, nullptr, 0, nullptr, 0, &nv, &nt);
  if (st != FFSEG_OK) engine_fail(e, st, "ffseg_extract_mesh");
  std::vector<float> xyz(3 * nv);
  if (tris) tris->resize(3 * nt);
  st = ffseg_extract_mesh(e, k, xyz.data(), nv, tris ? tris->data() : nullptr, tris ? nt : 0, &nv, &nt);
  if (st != FFSEG_OK) engine_fail(e, st, "ffseg_extract_mesh");
  return xyz;
}

// Whether some object of a re-spacing finer run now encloses more than its
// first run's reach (refinement_reach.h); the first such is recorded.
bool left_refinement_reach(EngineRun* run, uint32_t nobj) {
  std::vector<uint32_t> tris;
  for (uint32_t k = 0; k < nobj && k < run->reach_mm3.size(); ++k) {
    const std::vector<float> xyz = mesh_vertices(run->ws.e, k, &tris);
    const double v = enclosed_volume_mm3(xyz, tris);
    if (!(v > run->reach_mm3[k])) continue;
    run->left_reach = k;
    run->left_step = run->steps;
    run->left_mm3 = v;
    return true;
  }
  return false;
}

// Steps every object until all are at rest or the run has taken `limit`
// steps (at most --max-steps), with a progress line; resume: go on from the
// steps already taken. Returns whether every object is at rest.
bool step_to_rest(const SegmentRequest& rq, EngineRun* run, int64_t limit, bool resume) {
  const uint32_t nobj = rq.objects();
  ffseg_step_info& info = run->info;
  if (!resume) {
    for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) run->stage_us[g] = 0;
    std::memset(&info, 0, sizeof info);
    info.struct_size = sizeof info;
    run->converged = false;
    run->steps = 0;
    run->border_vertices.assign(nobj, 0);
    run->far.assign(nobj, {0.0, 0.0, 0.0});
    run->respaced_steps.assign(nobj, 0);
    // A re-spacing finer run keeps the first run's: every object re-spaces
    // there, grows_freely is the automatic rule's.
    if (!run->respacing) run->grows_freely.assign(nobj, 0);
  }
  const auto t0 = std::chrono::steady_clock::now();
  Progress progress(!rq.quiet, rq.max_steps, nobj);
  bool at_rest = false;
  for (int64_t s = run->steps; s < std::min(limit, rq.max_steps); ++s) {
    check_interrupted();
    const ffseg_status st = ffseg_step(run->ws.e, &info);
    if (st == FFSEG_ERR_NOT_IMPLEMENTED) {
      const std::string detail = ffseg_last_error(run->ws.e);
      fail(kExitEngine, std::string("this engine build does not implement --target ") +
                            target_name(rq.params.target_mode) + " yet" + (detail.empty() ? "" : " (" + detail + ")") +
                            (rq.params.target_mode != FFSEG_TARGET_BINARY ? "; use --target binary on a binary mask" : ""));
    }
    // The memory budget is a starting size, not a cap: an organ that
    // outgrew it is segmented with more memory rather than not at all
    // (sizes given on the command line are kept: engine_fail).
    if (st == FFSEG_ERR_ROI_TOO_LARGE && rq.max_roi < 0 && rq.max_region < 0 && run->budget_reduced)
      throw OutgrewBudget{ffseg_last_error(run->ws.e)};
    if (st < 0) engine_fail(run->ws.e, st, "step " + std::to_string(s + 1));
    run->steps = s + 1;
    for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) run->stage_us[g] += info.stage_us[g];
    for (uint32_t k = 0; k < nobj && k < FFSEG_REPORT_OBJECTS; ++k) {
      run->respaced_steps[k] += info.respaced[k];
      if (s == 0 && !run->respacing)
        run->grows_freely[k] = info.respaced[k] != 0 && rq.params.target_mode != FFSEG_TARGET_BINARY;
    }
    for (uint32_t k = 0; k < nobj && k < FFSEG_REPORT_OBJECTS; ++k)
      if (info.vertices_with_target[k] > 0 || info.mean_displacement_mm[k] > 0) {
        run->border_vertices[k] = info.border_vertices[k];
        run->far[k] = {double(info.far_outward[k]), double(info.far_inward[k]), 0.0};
      }
    run->converged = st == FFSEG_CONVERGED;
    at_rest = run->converged || st == FFSEG_DEGENERATE;
    if (run->respacing && left_refinement_reach(run, nobj)) {
      progress.step(info, seconds_since(t0), true);
      return false;
    }
    progress.step(info, seconds_since(t0), at_rest || run->steps == rq.max_steps);
    if (at_rest) break;
  }
  return at_rest;
}

// The finest mesh resolution the objects' surfaces ask for (mesh_resolution.h);
// grew_freely[k]: object k grew freely in the first run (its sides count too).
uint32_t wanted_resolution(const ffseg_engine* e, const ffseg_tools::NiftiImage& img, uint32_t nobj,
                           const std::vector<uint8_t>& grew_freely) {
  uint32_t wanted = kFirstResolution;
  const double h = std::min(img.spacing[0], std::min(img.spacing[1], img.spacing[2]));
  for (uint32_t k = 0; k < nobj; ++k) {
    size_t nv = 0, nt = 0;
    ffseg_status st = ffseg_extract_mesh(e, k, nullptr, 0, nullptr, 0, &nv, &nt);
    if (st != FFSEG_OK) engine_fail(e, st, "ffseg_extract_mesh");
    std::vector<float> xyz(nv * 3);
    std::vector<uint32_t> tris(nt * 3);
    st = ffseg_extract_mesh(e, k, xyz.data(), nv, tris.data(), nt, &nv, &nt);
    if (st != FFSEG_OK) engine_fail(e, st, "ffseg_extract_mesh");
    wanted = std::max(wanted, resolution_for_area(mesh_area_mm2(xyz, tris), h));
    if (k < grew_freely.size() && grew_freely[k])
      wanted = std::max(wanted, resolution_for_sides(quad_side_quantile_mm(xyz, tris, kStretchQuantile),
                                                     kFirstResolution, h));
  }
  return wanted;
}

// Each object's FFSEG_OBJECT_STALLED as of the run's last step.
std::vector<uint8_t> stalled_objects(const EngineRun& run, uint32_t nobj) {
  std::vector<uint8_t> s(nobj, 0);
  for (uint32_t k = 0; k < nobj && k < FFSEG_REPORT_OBJECTS; ++k)
    s[k] = (run.info.object_flags[k] & FFSEG_OBJECT_STALLED) != 0;
  return s;
}

// Voxels inside each object's mesh (ffseg_rasterize).
std::vector<uint64_t> object_voxels(const ffseg_engine* e, const ffseg_tools::NiftiImage& img, uint32_t nobj) {
  std::vector<uint8_t> mask(img.voxel_count());
  std::vector<uint64_t> n(nobj, 0);
  for (uint32_t k = 0; k < nobj; ++k) {
    const ffseg_status st = ffseg_rasterize(e, k, mask.data(), nullptr);
    if (st != FFSEG_OK) engine_fail(e, st, "ffseg_rasterize");
    for (uint8_t b : mask) n[k] += b;
  }
  return n;
}

// A first run whose re-spaced pass left its reach (one object,
// refinement_reach.h) is made again from the sphere at kLeakerResolution;
// the run that encloses fewer voxels stands. run holds the first run and
// its engine; pass(limit) runs an engine at run->resolution from the
// spheres (run->start_from_coarse false) and returns whether it came to rest.
template <class Pass>
void run_leaker_again(const SegmentRequest& rq, const ffseg_tools::NiftiImage& img, EngineRun* run, Pass& pass) {
  const uint64_t first_voxels = run->coarse_voxels[0];
  PassRecord first = *run;
  Workspace first_ws;
  first_ws = std::move(run->ws);
  run->resolution = kLeakerResolution;
  const bool at_rest = pass(rq.max_steps);
  run->leaker_voxels = object_voxels(run->ws.e, img, 1)[0];
  const bool result = at_rest && run->info.flags_all == 0;  // neither stalled nor without a boundary
  const bool smaller = result && run->leaker_voxels < first_voxels;
  if (!rq.quiet)
    std::fprintf(stderr, "ffseg: made again from its sphere at mesh resolution %u, it encloses %llu voxels "
                 "against the first run's %llu: %s\n", kLeakerResolution, (unsigned long long)run->leaker_voxels,
                 (unsigned long long)first_voxels,
                 smaller ? "that run stands" : !result ? "it found no rest, the first run stands" : "the first run stands");
  if (smaller) {
    run->leaker_run_stands = true;
    run->first_run_stands = false;
    return;
  }
  // The first run's record and engine back (every pass's cost stays counted).
  static_cast<PassRecord&>(*run) = first;
  run->ws = std::move(first_ws);
}

// The deformation. Without --mesh-resolution the first run at
// kFirstResolution comes to rest (or --max-steps) and measures each object's
// surface there, and the run is made again at a finer resolution when they
// ask for one (mesh_resolution.h); else the first run is the result. A
// fixed resolution above kFirstResolution has the same first run. Coarse
// to fine: the finer run starts from the first run's meshes
// (ffseg_init_mesh; the cube-sphere subdivides exactly), not from the
// spheres, so a fine mesh never has to grow from a small sphere, where it
// jams on a scanner's grid (the 1 mm CT liver at n = 49 stopped at 12% of
// it), and the finer run costs the steps from the coarse surface on only. An
// object that stalls in the finer run where its first run did not is put
// back on its first-run surface, and where that is refused the finer run is
// given up for the first run, gone on at its own resolution. Growing the
// finer mesh from the sphere first (the finer run made again from the coarse
// meshes only where it fell short) was measured over seven placements of
// every sphere (BENCHMARKS.md section 12): the same Dice at 3 mm alone and
// together within their spread, 0.011 more on the 1 mm choosing set, at two
// to four times the stepping.
void run_engine_once(const SegmentRequest& rq, const ffseg_tools::NiftiImage& img, EngineRun* run) {
  const bool automatic = rq.mesh_resolution == 0;
  const bool fixed_fine = !automatic && rq.mesh_resolution > kFirstResolution;
  const uint32_t nobj = rq.objects();
  run->resolution = automatic || fixed_fine ? kFirstResolution : rq.mesh_resolution;
  run->t_setup = 0;
  run->t_stepping_all = 0;
  run->steps_all = 0;
  run->passes = 0;
  run->coarse.clear();
  run->coarse_voxels.clear();
  run->start_from_coarse = false;
  run->finer_given_up = false;
  run->first_run_stands = false;
  run->leaker_voxels = 0;
  run->leaker_run_stands = false;
  run->from_coarse.assign(nobj, 0);
  // (Also when run_engine starts again with more memory mid-pass.)
  run->respacing = false;
  run->finer_respaced = false;
  run->left_reach = -1;
  run->reach_mm3.clear();
  auto pass = [&](int64_t limit) {
    const auto t_setup0 = std::chrono::steady_clock::now();
    start_engine(rq, img, run);
    run->t_setup += seconds_since(t_setup0);
    const auto t_step0 = std::chrono::steady_clock::now();
    const bool at_rest = step_to_rest(rq, run, limit, false);
    run->t_stepping = seconds_since(t_step0);
    run->t_stepping_all += run->t_stepping;
    run->steps_all += run->steps;
    ++run->passes;
    return at_rest;
  };
  const bool at_rest = pass(rq.max_steps);
  // A finer mesh would not make a segmentation of a result that is none.
  // (A stalled first run is still refined: the finer mesh may get past.)
  const bool found = (run->info.flags_all & ~uint32_t(FFSEG_OBJECT_STALLED)) == 0;
  const uint32_t finer = fixed_fine ? rq.mesh_resolution
                         : !automatic || !found
                             ? 0
                             : rerun_resolution(run->wanted_resolution = wanted_resolution(run->ws.e, img, nobj, run->grows_freely));
  // One grey-level object re-spaces its loops from its first-run surface
  // within that surface's reach (refinement_reach.h): in a finer run, or,
  // where the automatic resolution keeps the first one, in a second pass at
  // it (a first run stopped by --max-steps is not refined at its own n).
  // The re-spacing, not the resolution, is what carries a rested mesh
  // into the corners and lobes it jammed short of (the 3 mm CT's left
  // kidney 0.813 -> 0.873, stomach 0.682 -> 0.765; BENCHMARKS.md section 12).
  // One object only: the parameter is the engine's, so one leaker among
  // several would make every object's finer run again (the 16 organs of the
  // 3 mm CT together: the vena cava left its reach at step 6, and the run
  // cost 1 s more for the same result). An object that grew freely (its
  // boundary in view) re-spaces anyway.
  const bool respaceable = nobj == 1 && !run->grows_freely[0] && rq.params.grey_respacing == 0 &&
                           rq.params.target_mode != FFSEG_TARGET_BINARY;
  const uint32_t fine = finer == 0 && automatic && found && at_rest && respaceable ? kFirstResolution : finer;
  if (fine == 0) {
    if (!at_rest) {
      const auto t_step0 = std::chrono::steady_clock::now();
      const int64_t before = run->steps;
      step_to_rest(rq, run, rq.max_steps, true);
      const double t = seconds_since(t_step0);
      run->t_stepping += t;
      run->t_stepping_all += t;
      run->steps_all += run->steps - before;
    }
    run->stalled = stalled_objects(*run, nobj);
    return;
  }
  run->coarse.resize(nobj);
  run->reach_mm3.assign(nobj, 0.0);
  for (uint32_t k = 0; k < nobj; ++k) {
    std::vector<uint32_t> tris;
    run->coarse[k] = mesh_vertices(run->ws.e, k, &tris);
    run->reach_mm3[k] = refinement_reach_mm3(run->coarse[k], tris);
  }
  run->coarse_stalled = stalled_objects(*run, nobj);
  run->coarse_voxels = object_voxels(run->ws.e, img, nobj);
  if (!rq.quiet && fixed_fine)
    std::fprintf(stderr, "ffseg: first run at mesh resolution %u; now at %u from its meshes\n", kFirstResolution, fine);
  else if (!rq.quiet && fine == kFirstResolution)
    std::fprintf(stderr, "ffseg: the surface re-spaces its loops from its first-run mesh, within its reach\n");
  else if (!rq.quiet)
    std::fprintf(stderr, "ffseg: the surfaces ask for mesh resolution %u; refining the first run's meshes to it "
                 "(--mesh-resolution N to fix one)\n", fine);
  run->resolution = fine;
  run->start_from_coarse = true;
  // The finer run given up: the first run goes on to rest at its own
  // resolution, every object placed from its first-run mesh (the same grid:
  // bit for bit), so that no object ends short of its first run.
  auto give_up = [&](const std::string& why) {
    std::fprintf(stderr, "ffseg: warning: %s; the first run goes on at resolution %u instead\n", why.c_str(),
                 kFirstResolution);
    run->resolution = kFirstResolution;
    run->finer_given_up = true;
    run->finer_respaced = false;
    pass(rq.max_steps);
    run->stalled = stalled_objects(*run, nobj);
    run->from_coarse.assign(nobj, 1);
  };
  try {
    // An object that leaves its reach gets the run it would have had
    // without re-spacing: the finer run made again without, or at the first
    // run's resolution the first run itself, whose engine is kept while the
    // pass runs. Stepping on from its surface at rest instead is no such
    // run: the rest rules start afresh and a leaker creeps on (the 3 mm
    // gallbladder 161 -> 180 ml).
    run->respacing = respaceable;
    run->finer_respaced = run->respacing;
    run->left_reach = -1;
    PassRecord first;
    Workspace first_ws;
    if (fine == kFirstResolution) {
      first = *run;
      first_ws = std::move(run->ws);
    }
    pass(rq.max_steps);
    run->respacing = false;
    if (run->left_reach >= 0) {
      run->finer_respaced = false;
      if (!rq.quiet)
        std::fprintf(stderr, "ffseg: object %lld (%s) re-spaced at mesh resolution %u grew past its first run's "
                     "reach (%.1f ml > %.1f ml at step %lld); %s\n",
                     (long long)run->left_reach + 1, rq.names[size_t(run->left_reach)].c_str(), fine,
                     run->left_mm3 / 1000.0, run->reach_mm3[size_t(run->left_reach)] / 1000.0,
                     (long long)run->left_step,
                     fine == kFirstResolution ? "its first run is kept" : "the finer run again without re-spacing");
      if (fine == kFirstResolution) {
        static_cast<PassRecord&>(*run) = first;
        run->ws = std::move(first_ws);
        run->start_from_coarse = false;
        run->first_run_stands = true;
        run_leaker_again(rq, img, run, pass);
      } else {
        pass(rq.max_steps);
      }
    }
  } catch (const NoFinerStart& no) {
    run->respacing = false;
    // Its sphere lies where a neighbour's finer mesh now stands (its own
    // first-run surface moved off it); the first run's work still holds.
    give_up("object " + std::to_string(no.object + 1) + " (" + rq.names[no.object] + ") cannot be placed at mesh " +
            "resolution " + std::to_string(fine) + " beside the others' meshes, from its first-run surface or its " +
            "sphere (" + no.detail + ")");
    return;
  }
  run->stalled = stalled_objects(*run, nobj);
  uint32_t lost = nobj;  // an object that cannot be put back
  std::string why;
  for (uint32_t k = 0; k < nobj; ++k) {
    if (!run->stalled[k] || run->coarse_stalled[k]) continue;
    const SphereArg& sp = rq.spheres[k];
    if (ffseg_init_mesh(run->ws.e, k, run->centres_mm[k].data(), sp.c[3], run->coarse[k].data(),
                        run->coarse[k].size() / 3) != FFSEG_OK) {
      if (lost == nobj) {
        lost = k;
        why = placement_message(rq, ffseg_last_error(run->ws.e));
      }
      continue;
    }
    run->stalled[k] = 0;
    run->from_coarse[k] = 1;
    if (!rq.quiet)
      std::fprintf(stderr, "ffseg: object %u (%s) stalled at mesh resolution %u; kept on its surface "
                   "from resolution %u\n", k + 1, rq.names[k].c_str(), fine, kFirstResolution);
  }
  // An object that stalled where its first run did not and cannot be put
  // back on its first-run surface at the finer resolution would end short of
  // its first run: its surface resampled there crosses itself (the chords of
  // a finer mesh cut across a tight fold of the coarse one: the 1 mm CT's
  // gluteus medius right at n = 38, which then grew from its sphere, jammed
  // and ended at 109 ml against the first run's 125), or it meets a
  // neighbour's finer mesh. The finer run is then given up.
  if (lost == nobj) return;
  give_up("object " + std::to_string(lost + 1) + " (" + rq.names[lost] + ") stalled at mesh resolution " +
          std::to_string(fine) + " and cannot be put back on its surface from resolution " +
          std::to_string(kFirstResolution) + " there (" + why + ")");
}

// The run, from the start again with twice the memory budget each time an
// organ outgrows what the budget gave it (OutgrewBudget): 16 organs
// of the abdominal CT at 1 mm outgrow 400 MB (a liver crop of 4.2 M voxels
// against 3.4 M), which ended the run with exit 4 after a minute's work.
// Once the budget holds whole-scan buffers the sizes are no longer the
// budget's, and the engine's error ends the run as before.
void run_engine(const SegmentRequest& rq, const ffseg_tools::NiftiImage& img, EngineRun* run) {
  run->memory_bytes = rq.memory_bytes;
  run->budget_raises = 0;
  for (;;) {
    try {
      run_engine_once(rq, img, run);
      return;
    } catch (const OutgrewBudget& o) {
      run->memory_bytes *= 2;
      ++run->budget_raises;
      std::fprintf(stderr, "ffseg: warning: an organ outgrew the memory budget (%s); starting again with a "
                   "budget of %.0f MB (--max-roi-voxels N fixes the crops instead)\n", o.detail.c_str(),
                   run->memory_bytes / 1e6);
    }
  }
}

// A run that found nothing is not a segmentation, by the engine's flags
// (FFSEG_DEGENERATE at rest; as of the last step when stopped at
// --max-steps): no vertex of an object ever met a boundary (its mesh stayed
// the sphere), or the object fills most of the grid (a sphere around the
// whole scan: every voxel labelled). Exit 5, nothing written.
void refuse_degenerate(const SegmentRequest& rq, const EngineRun& run, const std::vector<ObjectResult>& res,
                       uint64_t nvox) {
  const uint32_t nobj = rq.objects();
  const ffseg_step_info& info = run.info;
  for (uint32_t k = 0; k < nobj && k < FFSEG_REPORT_OBJECTS; ++k) {
    const std::string who = "object " + std::to_string(k + 1) + " (" + rq.names[k] + ")";
    if (info.object_flags[k] & FFSEG_OBJECT_NO_BOUNDARY)
      fail(kExitNoResult, who + ": no vertex found a boundary along its normal in " + std::to_string(run.steps) +
                              " steps; the sphere is not inside or near an object of the target (check --sphere and --target)");
    if (info.object_flags[k] & FFSEG_OBJECT_FILLS_GRID)
      fail(kExitNoResult, who + " fills " + std::to_string(int(100.0 * double(res[k].voxels) / double(nvox) + 0.5)) +
                              "% of the volume grid: no organ boundary held it (is the sphere larger than the organ?)");
  }
  if ((info.flags_all & ~uint32_t(FFSEG_OBJECT_STALLED)) != 0)  // an object past the engine's per-object report
    fail(kExitNoResult, "one of objects " + std::to_string(FFSEG_REPORT_OBJECTS + 1) + ".." + std::to_string(nobj) +
                            (info.flags_all & FFSEG_OBJECT_NO_BOUNDARY
                                 ? ": no vertex found a boundary along its normal (check --sphere and --target)"
                                 : " fills most of the volume grid: no organ boundary held it"));
}

// A new directory beside DIR (mode as mkdir's) that the outputs go into
// before they are moved into place.
void make_temp_dir(const SegmentRequest& rq, TempDir* tmp) {
  std::string templ = rq.out_parent + "/." + base_name(rq.out_dir) + ".ffseg-tmp-XXXXXX";
  std::vector<char> buf(templ.begin(), templ.end());
  buf.push_back('\0');
  if (!::mkdtemp(buf.data()))
    fail(kExitFailure, "cannot create a temporary directory in " + rq.out_parent + ": " + std::strerror(errno));
  tmp->path = buf.data();
  const mode_t mask = ::umask(0);  // mkdtemp makes 0700; use the usual mode
  ::umask(mask);
  ::chmod(tmp->path.c_str(), 0777 & ~mask);
}

// Times of the run's phases, seconds.
struct Times {
  double read = 0;
  std::chrono::steady_clock::time_point start, outputs0;
};

// An object's "metrics" in report.json: mask (object k's voxels) against
// its --truth label.
ffseg_tools::Json truth_metrics_json(const SegmentRequest& rq, const Inputs& in, uint32_t k,
                                     const std::vector<uint8_t>& mask) {
  check_interrupted();
  const ffseg_tools::NiftiImage& img = in.img;
  const MaskMetrics m = compare_masks_cropped(mask.data(), in.truth_masks[k].data(), img.dims, img.spacing);
  ffseg_tools::Json mj = ffseg_tools::Json::object();
  mj.set("truth_label", rq.labels[k]);
  mj.set("truth_voxels", uint64_t(m.voxels_b));
  mj.set("truth_volume_ml", m.vol_b_ml);
  set_metric_fields(mj, m);
  return mj;
}

// report.json: the request, the input, every object's sphere, mesh, volume
// and metrics, the engine's configuration and the times.
ffseg_tools::Json make_report(int argc, char** argv, const SegmentRequest& rq, const Inputs& in,
                              const DicomWritten& dw, const EngineRun& run, const std::vector<ObjectResult>& res,
                              const std::vector<std::string>& mesh_files, const double window[2], size_t shared_voxels,
                              const Times& times) {
  using ffseg_tools::Json;
  const uint32_t nobj = rq.objects();
  const ffseg_tools::NiftiImage& img = in.img;
  const double vox_mm3 = voxel_volume_mm3(img);
  Json objects = Json::array();
  for (uint32_t k = 0; k < nobj; ++k) {
    const ObjectResult& r = res[k];
    Json o = Json::object();
    o.set("index", k + 1);
    o.set("name", rq.names[k]);
    o.set("label", rq.labels[k]);
    const SphereArg& sa = rq.spheres[k];
    o.set("sphere_source",
          sa.label_path.empty() ? std::string("command line")
                                : "label " + std::to_string(sa.label) + " of " + base_name(sa.label_path));
    Json sp = Json::object();
    sp.set("center_mm", Json::array_of(run.centres_mm[k].data(), 3));
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
      o.set("final_mean_displacement_mm", run.info.mean_displacement_mm[k]);
      o.set("final_vertices_with_target", run.info.vertices_with_target[k]);
      // A stall (FFSEG_OBJECT_STALLED): at rest, targets still beyond.
      o.set("stalled", run.stalled[k] != 0);
      o.set("final_far_outward", uint64_t(run.far[k][0]));
      o.set("final_far_inward", uint64_t(run.far[k][1]));
      o.set("respaced_steps", run.respaced_steps[k]);
      if (rq.params.target_mode != FFSEG_TARGET_BINARY) o.set("grows_freely", run.grows_freely[k] != 0);
    }
    // refinement_reach.h: its re-spaced pass left its first run's reach.
    if (run.leaker_voxels > 0) o.set("leak_suspected", true);
    if (run.start_from_coarse) {
      o.set("kept_first_run_surface", run.from_coarse[k] != 0);
      o.set("first_run_voxels", run.coarse_voxels[k]);  // the order of placement: larger first
      o.set("started_from", start_name(run.start[k]));
      if (run.start[k] == kStartFirstRun) o.set("first_run_scale", run.first_run_scale[k]);
    }
    if (nobj > 1) {
      if (k < FFSEG_REPORT_OBJECTS) o.set("border_vertices", r.border_vertices);  // ffseg_step_info's reach
      o.set("shared_voxels", uint64_t(r.shared_voxels));
    }
    if (!in.truth_masks.empty()) o.set("metrics", truth_metrics_json(rq, in, k, r.mask));
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
  Json input = Json::object();
  input.set("path", rq.volume_path);
  input.set("format", ffseg_tools::image_format_name(in.format));
  input.set("dims", Json::array_of(img.dims, 3));
  input.set("spacing_mm", Json::array_of(img.spacing, 3));
  input.set("datatype", datatype_name(img.datatype));
  input.set("affine_source", img.which_affine);
  input.set("orientation", orientation_code(img.index_to_world));
  Json aff = Json::array();
  for (int r = 0; r < 4; ++r) aff.push(Json::array_of(img.index_to_world + 4 * r, 4));
  input.set("index_to_world", std::move(aff));
  input.set("rescale_slope", img.scl_slope);
  input.set("rescale_intercept", img.scl_inter);
  rep.set("input", std::move(input));
  if (!rq.truth_path.empty()) rep.set("truth", rq.truth_path);
  rep.set("target", target_name(rq.params.target_mode));
  rep.set("non_finite_voxels", uint64_t(in.nonfinite_voxels));
  rep.set("steps", run.steps);
  rep.set("steps_all_passes", run.steps_all);
  rep.set("passes", run.passes);
  rep.set("max_steps", rq.max_steps);
  rep.set("converged", run.converged);
  uint64_t stalled = 0;
  for (uint8_t st : run.stalled) stalled += st;
  rep.set("stalled_objects", stalled);
  rep.set("objects", std::move(objects));
  if (nobj > 1) rep.set("shared_voxels", uint64_t(shared_voxels));
  Json tj = Json::object();
  Json stages = Json::object();
  uint64_t stage_total = 0;
  for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) {
    stages.set(kStageNames[g], double(run.stage_us[g]) / 1000.0);
    stage_total += run.stage_us[g];
  }
  tj.set("read", ms(times.read));
  tj.set("setup", ms(run.t_setup));
  tj.set("stepping", ms(run.t_stepping));  // the last pass's (its stages below)
  tj.set("stepping_all_passes", ms(run.t_stepping_all));
  tj.set("stages", std::move(stages));
  tj.set("stages_total", double(stage_total) / 1000.0);
  tj.set("outputs", ms(seconds_since(times.outputs0)));
  tj.set("total", ms(seconds_since(times.start)));
  rep.set("time_ms", std::move(tj));
  rep.set("workspace_bytes", uint64_t(run.ws_bytes));
  Json cj = Json::object();
  cj.set("max_objects", run.cfg.max_objects);
  cj.set("mesh_resolution", run.resolution);
  const bool automatic = rq.mesh_resolution == 0;
  cj.set("mesh_resolution_source", automatic ? "automatic" : "--mesh-resolution");
  // Coarse to fine: grown at kFirstResolution, then refined at this one.
  cj.set("refined_from_first_run", run.start_from_coarse && !run.finer_given_up);
  // The finer run was made and given up for the first run's resolution.
  if (run.start_from_coarse) cj.set("finer_run_given_up", run.finer_given_up);
  // The finer run that stands re-spaced its loops (refinement_reach.h); or
  // the object whose re-spacing left its first run's reach, and the finer
  // run was made again without (first_run_stands: the pass at the first
  // run's own resolution left it, and the first run was kept). leaker_run:
  // that first run made again from the sphere at kLeakerResolution
  // (refinement_reach.h), its voxels and whether it stands.
  const bool second_pass = run.start_from_coarse || run.first_run_stands || run.leaker_run_stands;
  if (second_pass) cj.set("finer_run_respaced", run.finer_respaced);
  if (second_pass) cj.set("first_run_stands", run.first_run_stands);
  if (second_pass && run.left_reach >= 0) {
    ffseg_tools::Json lr = ffseg_tools::Json::object();
    lr.set("object", run.left_reach + 1);
    lr.set("name", rq.names[size_t(run.left_reach)]);
    lr.set("step", run.left_step);
    lr.set("volume_ml", run.left_mm3 / 1000.0);
    lr.set("reach_ml", run.reach_mm3[size_t(run.left_reach)] / 1000.0);
    cj.set("finer_run_left_reach", lr);
  }
  if (run.leaker_voxels > 0) {
    ffseg_tools::Json lk = ffseg_tools::Json::object();
    lk.set("mesh_resolution", kLeakerResolution);
    lk.set("voxels", run.leaker_voxels);
    lk.set("first_run_voxels", run.coarse_voxels[0]);
    lk.set("stands", run.leaker_run_stands);
    cj.set("leaker_run", lk);
  }
  if (automatic) {
    // The first run's resolution and what its surfaces asked for (mesh_resolution.h).
    cj.set("first_mesh_resolution", kFirstResolution);
    cj.set("asked_mesh_resolution", run.wanted_resolution);

  }
  cj.set("max_roi_voxels", run.cfg.max_roi_voxels);
  cj.set("max_region_voxels", run.cfg.max_region_voxels);
  cj.set("memory_budget_bytes", run.memory_bytes);
  cj.set("memory_budget_raised", run.budget_raises);
  rep.set("config", std::move(cj));
  rep.set("parameters", params_json(rq.params));
  Json outs = Json::object();
  Json mf = Json::array();
  for (const std::string& f : mesh_files) mf.push(f);
  outs.set("meshes", std::move(mf));
  outs.set("mesh_format", ffseg_tools::mesh_format_extension(rq.mesh_format));
  outs.set("labels", in.labels_file);
  outs.set("overlay", "overlay.png");
  outs.set("overlay_window", Json::array_of(window, 2));
  outs.set("overlay_window_source", rq.have_window ? "--window" : "objects");
  outs.set("overlay_view", ffseg_tools::overlay_view_name(rq.view));
  if (!dw.seg.empty()) outs.set("dicom_seg", dw.seg);
  if (!dw.rtstruct.empty()) {
    outs.set("rtstruct", dw.rtstruct);
    outs.set("rtstruct_contours", uint64_t(dw.contours));
  }
  if (!dw.seg.empty() || !dw.rtstruct.empty()) {
    outs.set("dicom_references", in.dicom.generated() ? "generated study" : "source series");
    if (!in.dicom.note.empty()) outs.set("dicom_note", in.dicom.note);
  }
  if (!rq.regions_path.empty()) outs.set("regions", rq.regions_path);
  rep.set("outputs", std::move(outs));
  return rep;
}

// The temporary directory becomes DIR (with --force the old DIR is set
// aside first and deleted after), then each file beside it (SideFile) takes
// its name.
void move_into_place(const SegmentRequest& rq, TempDir* tmp, SideFiles* sides) {
  const std::string& out_dir = rq.out_dir;
  if (rq.out_nonempty) {
    const std::string aside = rq.out_parent + "/." + base_name(out_dir) + ".ffseg-old-" + std::to_string(::getpid());
    remove_tree(aside);
    if (std::rename(out_dir.c_str(), aside.c_str()) != 0)
      fail(kExitFailure, "cannot move the old " + out_dir + " aside: " + std::strerror(errno));
    if (std::rename(tmp->path.c_str(), out_dir.c_str()) != 0) {
      const int e = errno;
      std::rename(aside.c_str(), out_dir.c_str());
      fail(kExitFailure, "cannot rename the results to " + out_dir + ": " + std::strerror(e));
    }
    tmp->keep = true;
    remove_tree(aside);
  } else {
    // rename() replaces an empty directory.
    if (std::rename(tmp->path.c_str(), out_dir.c_str()) != 0)
      fail(kExitFailure, "cannot rename the results to " + out_dir + ": " + std::strerror(errno));
    tmp->keep = true;
  }
  for (const auto& f : *sides) {
    if (std::rename(f->tmp.path.c_str(), f->dest.c_str()) != 0)
      fail(kExitFailure, "cannot rename " + f->tmp.path + " to " + f->dest + ": " + std::strerror(errno));
    f->tmp.keep = true;
  }
}

// A stalled object (FFSEG_OBJECT_STALLED that no way out removed): a
// warning on stderr, also with --quiet; true when there is one.
bool warn_stalls(const SegmentRequest& rq, const EngineRun& run) {
  bool any = false;
  for (uint32_t k = 0; k < rq.objects() && k < run.stalled.size(); ++k) {
    if (!run.stalled[k]) continue;
    any = true;
    const bool out = run.far[k][0] >= run.far[k][1];
    std::fprintf(stderr,
                 "ffseg: warning: object %u (%s) stalled: it came to rest (grey levels: again, after its contour loops "
                 "were re-spaced) with %.0f vertices pointing more than a "
                 "voxel %s and %.0f %s; its mesh %s its boundary (outputs written; exit status %d)\n",
                 k + 1, rq.names[k].c_str(), out ? run.far[k][0] : run.far[k][1], out ? "outward" : "inward",
                 out ? run.far[k][1] : run.far[k][0], out ? "inward" : "outward",
                 out ? "stops short of" : "overshoots", kExitStalled);
  }
  return any;
}

// An object whose re-spaced pass left its first run's reach (the result
// is the smaller of its first run and its run at kLeakerResolution,
// refinement_reach.h): its grey level goes on past where its mesh rested,
// so the result may hold part of a neighbour of that grey level. A
// warning on stderr, also with --quiet; the outputs are a segmentation
// (exit status unchanged).
void warn_leak(const SegmentRequest& rq, const EngineRun& run) {
  if (run.leaker_voxels == 0) return;
  const uint64_t first = run.coarse_voxels[0];
  std::fprintf(stderr,
               "ffseg: warning: object 1 (%s): its grey level goes on past the surface it rested at (re-spaced, it "
               "grew past its first run's reach), so it may hold part of a neighbour of that grey level; of its run "
               "at mesh resolution %u (%llu voxels) and its run at %u (%llu voxels) the one at %u stands "
               "(report.json: leak_suspected)\n",
               rq.names[0].c_str(), kFirstResolution, (unsigned long long)first, kLeakerResolution,
               (unsigned long long)run.leaker_voxels, run.leaker_run_stands ? kLeakerResolution : kFirstResolution);
}

// A grey-level object whose mesh grew freely by the automatic rule (its
// boundary in view: a tube, duct or cavity of its own contrast) may also
// have followed its grey level out of the organ; the user is told how to
// keep it from doing so.
void note_free_growth(const SegmentRequest& rq, const EngineRun& run) {
  if (rq.quiet || rq.params.grey_respacing != 0) return;
  for (uint32_t k = 0; k < rq.objects() && k < run.grows_freely.size(); ++k)
    if (run.grows_freely[k])
      std::fprintf(stderr, "ffseg: note: object %u (%s): its grey level is rare around its sphere and unlike its "
                   "neighbours', so its mesh grew freely along it, as along a vessel or a ventricle "
                   "(--param grey_respacing=2 keeps it compact)\n", k + 1, rq.names[k].c_str());
}

// The summary on stdout: one line per object, from the report.
void print_summary(const SegmentRequest& rq, const EngineRun& run, const std::vector<ObjectResult>& res,
                   const ffseg_tools::Json& rep, size_t shared_voxels) {
  const uint32_t nobj = rq.objects();
  bool stalled = false;
  for (uint8_t st : run.stalled) stalled = stalled || st;
  std::printf("%s after %lld step%s in %.2f s", stalled ? "stalled" : run.converged ? "converged" : "stopped",
              static_cast<long long>(run.steps), run.steps == 1 ? "" : "s", run.t_stepping);
  if (run.passes > 1)
    std::printf(" (%d passes: %lld steps in %.2f s)", run.passes, static_cast<long long>(run.steps_all),
                run.t_stepping_all);
  std::printf("; outputs in %s/\n", rq.out_dir.c_str());
  for (uint32_t k = 0; k < nobj; ++k) {
    const ffseg_tools::Json& o = (*rep.get("objects"))[k];
    std::printf("  %-16s %8.3f ml  %6llu vertices", rq.names[k].c_str(), o.get("volume_ml")->as_number(),
                static_cast<unsigned long long>(res[k].xyz.size() / 3));
    if (const ffseg_tools::Json* m = o.get("metrics"))
      std::printf("  dice %.4f  voe %.4f  assd %.3f mm  hd95 %.3f mm", m->get("dice")->as_number(),
                  m->get("voe")->as_number(), m->get("assd_mm")->as_number(), m->get("hd95_mm")->as_number());
    if (nobj > 1) std::printf("  border %u", res[k].border_vertices);
    if (const ffseg_tools::Json* sc = rep.get("seed_check"))
      std::printf("  seed check %.3f%s", (*sc->get("objects"))[k].get("lowest_dice")->as_number(),
                  (*sc->get("objects"))[k].get("below_floor")->as_bool() ? " (unstable)" : "");
    if (const ffseg_tools::Json* c = rep.get("consensus")) {
      const ffseg_tools::Json& co = (*c->get("objects"))[k];
      std::printf("  consensus %.3f ml", co.get("volume_ml")->as_number());
      if (const ffseg_tools::Json* m = co.get("metrics")) std::printf(" dice %.4f", m->get("dice")->as_number());
    }
    std::printf("\n");
  }
  if (nobj > 1) {
    uint64_t rest = 0;
    for (int g = 0; g < FFSEG_STAGE_COUNT; ++g) rest += g == FFSEG_STAGE_REGIONS ? 0 : run.stage_us[g];
    std::printf("  %u objects in one engine: bounding regions %.2f s, the rest of the steps %.2f s; "
                "%llu voxel%s inside two meshes (labelled as the first)%s%s\n",
                nobj, double(run.stage_us[FFSEG_STAGE_REGIONS]) / 1e6, double(rest) / 1e6,
                static_cast<unsigned long long>(shared_voxels), shared_voxels == 1 ? "" : "s",
                rq.regions_path.empty() ? "" : "; regions in ", rq.regions_path.c_str());
  }
}

// report.json's "consensus": the file, the runs and share that voted and, per
// object, its voxels, volume and (with --truth) metrics, as the objects' own.
ffseg_tools::Json consensus_json(const SegmentRequest& rq, const Inputs& in, const SeedCheck& seeds,
                                 const std::vector<ObjectResult>& consensus, const std::string& file) {
  using ffseg_tools::Json;
  const ffseg_tools::NiftiImage& img = in.img;
  Json j = Json::object();
  j.set("file", file);
  j.set("runs", seeds.runs);
  j.set("share", kConsensusShare);
  Json objects = Json::array();
  for (uint32_t k = 0; k < rq.objects(); ++k) {
    const std::vector<uint8_t>& m = consensus[k].mask;
    Json o = Json::object();
    o.set("name", rq.names[k]);
    const uint64_t voxels = uint64_t(std::count(m.begin(), m.end(), uint8_t(1)));
    o.set("voxels", voxels);
    o.set("volume_ml", double(voxels) * voxel_volume_mm3(img) / 1000.0);
    if (!in.truth_masks.empty()) o.set("metrics", truth_metrics_json(rq, in, k, m));
    objects.push(std::move(o));
  }
  j.set("objects", std::move(objects));
  return j;
}

// --seed-check (seed_check.h): the request run again from each perturbation
// of its spheres, each object's mask compared with the result's; a line per
// object on stderr (with --quiet too when it falls below the floor).
SeedCheck run_seed_check(const SegmentRequest& rq, const ffseg_tools::NiftiImage& img, const EngineRun& run,
                         const std::vector<ObjectResult>& res, std::vector<std::vector<uint8_t>>* votes) {
  const uint32_t nobj = rq.objects();
  if (!rq.quiet)
    std::fprintf(stderr, "ffseg: seed check: segmenting again from %u perturbed copies of the sphere%s\n",
                 kSeedVariants, nobj > 1 ? "s" : "");
  std::vector<std::vector<uint8_t>> result(nobj);
  for (uint32_t k = 0; k < nobj; ++k) result[k] = res[k].mask;
  const SeedCheck sc = check_seeds(rq, run.centres_mm, result, [&](const SegmentRequest& q) {
    EngineRun r;
    run_engine(q, img, &r);
    std::vector<ObjectResult> rr = read_results(r.ws.e, img, q.objects(), r.centres_mm);
    std::vector<std::vector<uint8_t>> masks(rr.size());
    for (size_t k = 0; k < rr.size(); ++k) masks[k] = std::move(rr[k].mask);
    return masks;
  }, votes, rq.jobs ? rq.jobs : std::max(1u, std::thread::hardware_concurrency()));
  for (uint32_t v = 0; v < kSeedVariants; ++v)
    if (!sc.failed[v].empty())
      std::fprintf(stderr, "ffseg: warning: seed check: the run from %s failed: %s\n", kSeedVariant[v].name,
                   sc.failed[v].c_str());
  for (uint32_t k = 0; k < nobj; ++k) {
    double lo = 1, hi = 0;
    const char* worst = "";
    for (uint32_t v = 0; v < kSeedVariants; ++v) {
      const double d = sc.dice[k][v];
      if (d < 0) continue;
      if (d <= lo) lo = d, worst = kSeedVariant[v].name;
      hi = std::max(hi, d);
    }
    if (lo < kSeedCheckFloor)
      std::fprintf(stderr, "ffseg: warning: seed check: %s agrees with the perturbed runs at Dice %.3f-%.3f, below %.2f "
                   "(from the sphere's %s): the contour depends on where the sphere was put; check it, or place the "
                   "sphere elsewhere in the organ\n", rq.names[k].c_str(), lo, hi, kSeedCheckFloor, worst);
    else if (!rq.quiet)
      std::fprintf(stderr, "ffseg: seed check: %s agrees with the perturbed runs at Dice %.3f-%.3f\n",
                   rq.names[k].c_str(), lo, hi);
  }
  return sc;
}

}  // namespace

// Request, inputs, engine, results in memory, outputs written into a
// temporary directory, moved into place: a failed run leaves no output behind.
int cmd_segment(int argc, char** argv) {
  Times times;
  times.start = std::chrono::steady_clock::now();
  SegmentRequest rq = parse_segment_request(argc, argv);
  if (rq.help) return kExitOk;
  const std::string viewer_js = rq.html ? find_report_viewer() : "";
  if (rq.html && viewer_js.empty())
    fail(kExitUsage, "--html: the viewer script report-viewer.js was not found beside the tool (build it with "
                     "`make web-dist`, or set FFSEG_VIEWER_JS to its path)");
  install_interrupt_handlers();
  Inputs in;
  read_inputs(&rq, &in);
  const ffseg_tools::NiftiImage& img = in.img;
  times.read = seconds_since(times.start);
  check_interrupted();

  EngineRun run;
  run_engine(rq, img, &run);
  check_interrupted();

  // ---- results in memory ----------------------------------------------------------
  times.outputs0 = std::chrono::steady_clock::now();
  const uint32_t nobj = rq.objects();
  std::vector<ObjectResult> res = read_results(run.ws.e, img, nobj, run.centres_mm);
  size_t shared_voxels = 0;
  for (uint32_t k = 0; k < nobj; ++k) {
    res[k].border_vertices = run.border_vertices[k];
    shared_voxels += res[k].shared_voxels;
  }
  refuse_degenerate(rq, run, res, img.voxel_count());
  SeedCheck seeds;
  std::vector<ObjectResult> consensus;  // --consensus: masks only
  if (rq.seed_check) {
    std::vector<std::vector<uint8_t>> votes;
    seeds = run_seed_check(rq, img, run, res, rq.consensus ? &votes : nullptr);
    if (rq.consensus) {
      std::vector<std::vector<uint8_t>> masks = consensus_masks(votes, seeds.runs);
      consensus.resize(nobj);
      for (uint32_t k = 0; k < nobj; ++k) consensus[k].mask = std::move(masks[k]);
    }
  }
  ffseg_tools::NiftiImage regions_map;
  if (!rq.regions_path.empty()) regions_map = region_label_map(run.ws.e, img, rq.labels);
  check_interrupted();

  // ---- write everything into a temporary directory --------------------------------
  TempDir tmp;
  make_temp_dir(rq, &tmp);
  std::string err;
  std::vector<std::string> mesh_files;
  for (uint32_t k = 0; k < nobj; ++k) {
    const ObjectResult& r = res[k];
    const std::string file = rq.names[k] + "." + ffseg_tools::mesh_format_extension(rq.mesh_format);
    if (!ffseg_tools::mesh_write_file(tmp.path + "/" + file, rq.mesh_format, r.xyz.data(), r.xyz.size() / 3,
                                      r.tris.data(), r.tris.size() / 3, "SPACE=RAS", &err))
      fail(kExitFailure, err);
    mesh_files.push_back(file);
  }
  check_interrupted();

  // Label map: object k -> labels[k], each voxel claimed once (read_results).
  const ffseg_tools::NiftiImage lab = object_label_map(img, res, rq.labels);
  if (!ffseg_tools::image_write_file(tmp.path + "/" + in.labels_file, in.labels_format, lab, &err))
    fail(kExitFailure, err);
  const std::string consensus_file = "consensus" + in.labels_file.substr(in.labels_file.find('.'));
  if (rq.consensus &&
      !ffseg_tools::image_write_file(tmp.path + "/" + consensus_file, in.labels_format,
                                     object_label_map(img, consensus, rq.labels), &err))
    fail(kExitFailure, err);
  check_interrupted();

  double window[2] = {rq.window[0], rq.window[1]};
  if (!rq.have_window) object_window(img, res, &window[0], &window[1]);
  if (!write_overlay(tmp.path + "/overlay.png", img, res, rq.names, in.truth_masks, window[0], window[1], rq.view, &err))
    fail(kExitFailure, err);
  check_interrupted();

  // Beside DIR, renamed into place after it: the bounding regions and the
  // DICOM objects asked for by name.
  SideFiles sides;
  if (!rq.regions_path.empty() &&
      !ffseg_tools::image_write_file(add_side_file(&sides, rq.regions_path),
                                     ffseg_tools::image_format_of_path(rq.regions_path), regions_map, &err))
    fail(kExitFailure, err);
  DicomWritten dicom_written;
  if (!rq.dicom_seg_path.empty() || in.format == ffseg_tools::ImageFormat::Dicom) {
    const bool inside = rq.dicom_seg_path.empty();
    dicom_written.seg = inside ? kAutoSegFile : rq.dicom_seg_path;
    write_dicom_seg(inside ? tmp.path + "/" + kAutoSegFile : add_side_file(&sides, rq.dicom_seg_path), img, res,
                    rq.names, rq.labels, in.dicom);
    check_interrupted();
  }
  if (!rq.rtstruct_path.empty()) {
    dicom_written.rtstruct = rq.rtstruct_path;
    write_rtstruct(add_side_file(&sides, rq.rtstruct_path), img, res, rq.names, rq.labels, in.dicom,
                   &dicom_written.contours);
    check_interrupted();
  }
  if ((!dicom_written.seg.empty() || !dicom_written.rtstruct.empty()) && !in.dicom.note.empty() && !rq.quiet)
    std::fprintf(stderr, "ffseg: note: the DICOM objects are %s\n", in.dicom.note.c_str());

  ffseg_tools::Json rep = make_report(argc, argv, rq, in, dicom_written, run, res, mesh_files, window, shared_voxels, times);
  if (rq.seed_check) rep.set("seed_check", seed_check_json(seeds, rq.names));
  if (rq.consensus) rep.set("consensus", consensus_json(rq, in, seeds, consensus, consensus_file));
  if (!write_text_file(tmp.path + "/report.json", rep.dump(), &err)) fail(kExitFailure, err);
  if (rq.html && !write_report_html(tmp.path, viewer_js, rq.volume_path, in.labels_file, mesh_files, rep.dump(), &err))
    fail(kExitFailure, err);
  check_interrupted();

  check_interrupted();
  move_into_place(rq, &tmp, &sides);
  print_summary(rq, run, res, rep, shared_voxels);
  note_free_growth(rq, run);
  warn_leak(rq, run);
  return warn_stalls(rq, run) ? kExitStalled : kExitOk;
}

}  // namespace ffseg_cli
