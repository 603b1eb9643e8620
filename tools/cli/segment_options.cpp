// `ffseg segment`'s command line (segment_options.h).
#include "segment_options.h"


#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <memory>

#include "cli.h"
#include "label_grid.h"
#include "metrics.h"
#include "param_args.h"

namespace ffseg_cli {

const char* target_name(uint32_t t) {
  return t == FFSEG_TARGET_BINARY ? "binary" : t == FFSEG_TARGET_INTENSITY ? "intensity" : "unknown";
}

namespace {
// The parameters' names, comma-separated, in the table's order.
std::string param_names(const char* sep = ", ") {
  std::string s;
  for (unsigned i = 0; i < ffseg::kParamCount; ++i) s += std::string(i ? sep : "") + ffseg::kParamSpecs[i].name;
  return s;
}
}  // namespace

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
    write_param(p, f, v);
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
// centre taken to world mm with the map's affine. Each label map is read once,
// onto the volume's grid (label_grid.h) or, with the same dimensions, on its
// own affine; `known` holds maps already read (the --truth map), by path.
void resolve_label_spheres(std::vector<SphereArg>* spheres, const ffseg_tools::NiftiImage& img,
                           const std::string& volume_path,
                           std::map<std::string, const ffseg_tools::NiftiImage*> known, bool resample,
                           bool quiet) {
  std::vector<std::unique_ptr<ffseg_tools::NiftiImage>> owned;
  for (SphereArg& s : *spheres) {
    if (s.label_path.empty()) continue;
    const ffseg_tools::NiftiImage*& lm = known[s.label_path];
    if (!lm) {
      owned.push_back(std::make_unique<ffseg_tools::NiftiImage>(
          read_on_grid(img, volume_path, s.label_path, "--sphere-from-label", resample, quiet, true)));
      lm = owned.back().get();
    }
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

std::vector<int64_t> default_labels(const std::vector<SphereArg>& spheres) {
  std::vector<int64_t> labels(spheres.size(), 0);
  for (size_t k = 0; k < spheres.size(); ++k) {
    if (spheres[k].label_path.empty()) continue;
    for (size_t j = 0; j < k; ++j)
      if (labels[j] == spheres[k].label)
        fail(kExitUsage, "objects " + std::to_string(j + 1) + " and " + std::to_string(k + 1) +
                             " both come from label " + std::to_string(spheres[k].label));
    labels[k] = spheres[k].label;
  }
  for (size_t k = 0; k < spheres.size(); ++k) {
    if (labels[k] != 0) continue;
    int64_t l = int64_t(k) + 1;
    while (std::find(labels.begin(), labels.end(), l) != labels.end()) ++l;
    labels[k] = l;
  }
  return labels;
}

bool valid_name(const std::string& n) {
  if (n.empty() || n.size() > 100 || n[0] == '.' || n[0] == '-') return false;
  for (char c : n)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

namespace {
const char* const kSegmentUsageText =
    "usage: ffseg segment VOLUME (--sphere X,Y,Z,R | --sphere-voxel I,J,K,R |\n"
    "                             --sphere-from-label LABELS:L)... --out DIR [options]\n"
    "\n"
    "Places one sphere mesh per --sphere / --sphere-voxel / --sphere-from-label\n"
    "(object 1, 2, ... in the order given), deforms them all together in one engine\n"
    "until they converge or --max-steps is reached, and writes into DIR:\n"
    "  NAME.ply        each object's closed triangle mesh in world mm (format: --mesh-format)\n"
    "  labels.nii.gz   label map on the input grid, every object in it: object k ->\n"
    "                  its --truth-labels number, else its --sphere-from-label label,\n"
    "                  else k (the next free number on a clash); a voxel inside two\n"
    "                  meshes belongs to the first object only, and the report's\n"
    "                  volumes and metrics measure exactly this map;\n"
    "                  labels.nrrd / labels.mha for NRRD / MetaImage input\n"
    "  overlay.png     axial, coronal and sagittal slices through each object's\n"
    "                  centre with every object's contour in its own colour\n"
    "                  (radiological order: the patient's right on the left; --view)\n"
    "                  (with --truth: the reference label as a dashed yellow contour,\n"
    "                  a colour no object gets)\n"
    "  segmentation.dcm  for a DICOM series as VOLUME: a DICOM Segmentation of the\n"
    "                  label map referencing the series (--dicom-seg)\n"
    "  report.json     input, steps, convergence, volume (ml), mesh size, metrics,\n"
    "                  time per stage (regions: the bounding regions of several\n"
    "                  objects), border vertices and shared voxels per object,\n"
    "                  workspace bytes, version, parameters; steps and stepping are\n"
    "                  the last pass's, steps_all_passes and\n"
    "                  time_ms.stepping_all_passes every pass's (the first run at\n"
    "                  n = 12 and the finer run)\n"
    "Two or more objects deform within bounding regions (thesis chapter 6): each\n"
    "voxel belongs to the object whose fast-marching front reaches it first, and a\n"
    "mesh stops at another object's region (its border vertices). Parameters\n"
    "region_width_mm, border_weight and region_interval below.\n"
    "Everything is written to a temporary directory beside DIR and renamed into\n"
    "place at the end: a failed or interrupted run leaves nothing behind.\n"
    "\n"
    "objects:\n"
    "  --sphere X,Y,Z,R        centre in world mm, radius in mm; world = RAS (the NIfTI sform,\n"
    "                          else qform; NRRD, MetaImage and DICOM LPS converted)\n"
    "  --sphere-voxel I,J,K,R  centre in voxel indices (may be fractional), radius in mm\n"
    "  --sphere-from-label LABELS:L\n"
    "                          the evaluation-protocol sphere of label L of the label\n"
    "                          map LABELS (VOLUME's voxel centres in any storage order, see\n"
    "                          --truth, or VOLUME's dims on any affine): centre = the label's\n"
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
    "  --regions FILE          also write the bounding regions of two or more objects\n"
    "                          as a label map (the labels of labels.nii.gz; format by\n"
    "                          the name: .nii.gz, .nii, .nrrd, .mha)\n"
    "  --dicom-seg FILE        also write a DICOM Segmentation (FILE.dcm): one segment per\n"
    "                          object (name, label, colour), frames on VOLUME's grid; a DICOM\n"
    "                          series as VOLUME writes DIR/segmentation.dcm without it\n"
    "  --rtstruct FILE         also write an RT Structure Set (FILE.dcm): one ROI per object,\n"
    "                          its contours the mesh cut by each slice plane (sub-voxel\n"
    "                          closed polygons, LPS mm). Both reference VOLUME's series and\n"
    "                          images when it is DICOM; other input: a generated study,\n"
    "                          no image referenced (a note says so)\n"
    "  --view MODE             overlay.png's axial and coronal panels: radiological (default:\n"
    "                          the patient's right on the image's left) or neurological\n"
    "  --html                  also write report.html: the volume, the labels, the meshes and the\n"
    "                          report's table in a page that opens from disk (needs the viewer\n"
    "                          script: make web-dist, or FFSEG_VIEWER_JS=report-viewer.js)\n"
    "  -q, --quiet             no progress line (nor the --sphere-from-label lines)\n"
    "\n"
    "algorithm:\n"
    "  --target MODE           binary (non-zero voxels are the object) or intensity\n"
    "                          (grey-level model); default: @TARGET@\n"
    "  --window LO,HI          overlay.png's grey window (default: the objects' p1..p99, widened by\n"
    "                          its width on each side, within the scan's p1..p99)\n"
    "  --mesh-resolution N     each mesh has 6 N^2 vertices; 2..1024, or auto (default): a first run\n"
    "                          at N = 12 measures each surface at rest, and a run again at the N that\n"
    "                          gives quads of about 1.5 voxels a side when that is above 18 (cap 49;\n"
    "                          a surface that grew freely along a tube: its longer quad sides too).\n"
    "                          The finer run (automatic, or N fixed above 12, which also has the\n"
    "                          first run) starts from the N = 12 meshes (coarse to fine); for one\n"
    "                          grey-level object it re-spaces its loops into the corners the first\n"
    "                          run left, and is made again without should it grow past the first\n"
    "                          run's volume plus a shell one coarse quad thick (report.json:\n"
    "                          finer_run_respaced; --param grey_respacing=2 never re-spaces). Where\n"
    "                          auto keeps N = 12, such an object re-spaces in a second pass at 12\n"
    "                          from its first-run mesh, within the same reach; past it (a leak)\n"
    "                          it is run again from its sphere at N = 6, and of that run and the\n"
    "                          first the one with fewer voxels stands; a warning says so, also\n"
    "                          with --quiet (report.json: first_run_stands, leaker_run,\n"
    "                          leak_suspected)\n"
    "  --max-steps K           stop after K deformation steps (default 200)\n"
    "  --param NAME=VALUE      set an engine parameter (repeatable); NAME, default, range:\n"
    "@PARAMS@"
    "                          (full text: include/ffseg.h)\n"
    "  --memory MB             workspace budget of one engine, 10^6 bytes (default 400): crops and\n"
    "                          regions hold the whole scan when that fits, else the\n"
    "                          regions are marched on coarser cells and the crops\n"
    "                          shrink to fit; an organ that outgrows its crop makes the\n"
    "                          run start again with twice the budget (a warning says so;\n"
    "                          report.json: memory_budget_bytes, memory_budget_raised).\n"
    "                          --max-roi-voxels and --max-region-voxels are fixed sizes:\n"
    "                          an organ that outgrows them ends the run (exit 4)\n"
    "  --max-roi-voxels N      engine crop budget per object (default: from --memory)\n"
    "  --max-region-voxels N   voxels of one bounding region's march (default: from\n"
    "                          --memory; a larger box is marched on coarser cells)\n"
    "\n"
    "evaluation:\n"
    "  --truth LABELS          reference label map on VOLUME's grid: the same voxel centres\n"
    "                          (within 0.01 voxel), stored in any axis order and direction\n"
    "                          (re-indexed exactly); another grid is refused unless\n"
    "  --resample-labels       LABELS and --sphere-from-label maps on another grid are\n"
    "                          resampled onto VOLUME's by nearest neighbour (a warning)\n"
    "  --truth-labels a,b,...  its label for each object (default: the labels of\n"
    "                          labels.nii.gz, see above); adds\n"
    "                          Dice, VOE, ASSD and HD95 (mm) per object to the report\n"    "  --seed-check            segment again from five perturbed spheres (every radius x0.6\n"
    "                          and x1.5; every centre +1 mm along x, y, z) and report each\n"
    "                          object's Dice against the result (report.json: seed_check),\n"
    "                          with a warning below 0.85: how much the contour depends on\n"
    "                          where the sphere was put; takes about six times as long\n"
    "  --consensus             with --seed-check's six runs, also write consensus.nii.gz (format\n"
    "                          as labels): each object's voxels inside its mesh in at least 5\n"
    "                          of the 6 runs, a result that depends far less on the sphere;\n"
    "                          report.json: consensus (volumes, metrics with --truth)\n"
    "  -j, --jobs N            the seed check's runs at once, each an engine of its own (memory\n"
    "                          grows with N; default: the CPU count, at most 5)\n"
    "\n"
    "examples:\n"
    "  ffseg segment ch2bet.nii.gz --target binary --sphere 0,-17,19,60 --out brain\n"
    "  ffseg segment ch2.nii.gz --sphere-from-label aal.nii.gz:73 --sphere-from-label aal.nii.gz:75 \\\n"
    "      --truth aal.nii.gz --regions regions.nii.gz --out nuclei\n";
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

}  // namespace ffseg_cli

namespace ffseg_cli {

namespace {

bool ends_with(const std::string& s, const char* suffix) {
  const size_t n = std::strlen(suffix);
  return s.size() >= n && s.compare(s.size() - n, n, suffix) == 0;
}

// --names: one valid, distinct name per object; default object1, object2, ...
std::vector<std::string> object_names(const std::string& names_opt, uint32_t nobj) {
  std::vector<std::string> names;
  if (names_opt.empty()) {
    for (uint32_t k = 0; k < nobj; ++k) names.push_back("object" + std::to_string(k + 1));
    return names;
  }
  names = split(names_opt, ',');
  if (names.size() != nobj)
    fail(kExitUsage, "--names gives " + std::to_string(names.size()) + " name(s) for " + std::to_string(nobj) + " object(s)");
  for (size_t i = 0; i < names.size(); ++i) {
    if (!valid_name(names[i]))
      fail(kExitUsage, "--names: '" + names[i] + "' is not a valid name (letters, digits, '_', '-', '.'; not starting with '.' or '-')");
    for (size_t j = 0; j < i; ++j)
      if (names[i] == names[j]) fail(kExitUsage, "--names: '" + names[i] + "' is given twice");
  }
  return names;
}

// --regions FILE: a new file (or --force) of an image format, in a directory that exists.
void check_regions_path(const std::string& path, uint32_t nobj, bool force) {
  if (nobj < 2) fail(kExitUsage, "--regions: bounding regions exist only for two or more objects (thesis 6.2), got one");
  if (path_exists(path) && !force) fail(kExitUsage, "--regions " + path + " exists (use --force to replace it)");
  if (is_directory(path)) fail(kExitUsage, "--regions " + path + " is a directory");
  if (!ends_with(path, ".nii.gz") && !ends_with(path, ".nii") && !ends_with(path, ".nrrd") && !ends_with(path, ".mha"))
    fail(kExitUsage, "--regions " + path + ": the file name must end in .nii.gz, .nii, .nrrd or .mha");
  if (!is_directory(parent_dir(path)))
    fail(kExitUsage, "--regions: the parent directory " + parent_dir(path) + " does not exist");
}

// --dicom-seg / --rtstruct FILE: a new file (or --force) in an existing
// directory, named *.dcm.
void check_side_path(const std::string& opt, const std::string& path, const char* ext, bool force) {
  if (path.empty()) return;
  if (is_directory(path)) fail(kExitUsage, opt + " " + path + " is a directory");
  if (path_exists(path) && !force) fail(kExitUsage, opt + " " + path + " exists (use --force to replace it)");
  if (!ends_with(path, ext)) fail(kExitUsage, opt + " " + path + ": the file name must end in " + ext);
  if (!is_directory(parent_dir(path)))
    fail(kExitUsage, opt + ": the parent directory " + parent_dir(path) + " does not exist");
}

// --out DIR: refused early, before any work, unless it can take the results.
void check_out_dir(SegmentRequest* rq) {
  std::string& out = rq->out_dir;
  while (out.size() > 1 && out.back() == '/') out.pop_back();
  const bool exists = path_exists(out);
  if (exists && !is_directory(out)) fail(kExitUsage, "--out " + out + " exists and is not a directory");
  rq->out_nonempty = exists && !directory_is_empty(out);
  if (rq->out_nonempty && !rq->force)
    fail(kExitUsage, "output directory " + out + " exists and is not empty (use --force to replace it)");
  rq->out_parent = parent_dir(out);
  if (!is_directory(rq->out_parent)) fail(kExitUsage, "--out: the parent directory " + rq->out_parent + " does not exist");
  if (base_name(out) == "." || base_name(out) == ".." || base_name(out) == "/")
    fail(kExitUsage, "--out: give a directory name, not '" + out + "'");
}

}  // namespace

SegmentRequest parse_segment_request(int argc, char** argv) {
  SegmentRequest rq;
  ffseg_params_init_default(&rq.params);
  rq.params.target_mode = kDefaultTarget;
  Args args(argc, argv, 2);
  std::string tok, names_opt, truth_labels_opt;
  bool have_truth_labels = false;
  bool opt;
  while (args.next(&tok, &opt)) {
    if (!opt) {
      if (!rq.volume_path.empty()) fail(kExitUsage, "one VOLUME only ('" + tok + "' is extra)");
      rq.volume_path = tok;
    } else if (tok == "-h" || tok == "--help") {
      std::fputs(segment_usage().c_str(), stdout);
      rq.help = true;
      return rq;
    } else if (tok == "--sphere" || tok == "--sphere-voxel") {
      rq.spheres.push_back(parse_sphere(tok, args.value(tok)));
    } else if (tok == "--sphere-from-label") {
      rq.spheres.push_back(parse_sphere_from_label(tok, args.value(tok)));
    } else if (tok == "--out" || tok == "-o") {
      rq.out_dir = args.value(tok);
      if (rq.out_dir.empty()) fail(kExitUsage, "--out: empty path");
    } else if (tok == "--force") {
      rq.force = true;
    } else if (tok == "-q" || tok == "--quiet") {
      rq.quiet = true;
    } else if (tok == "--html") {
      rq.html = true;
    } else if (tok == "--seed-check") {
      rq.seed_check = true;
    } else if (tok == "--consensus") {
      rq.consensus = rq.seed_check = true;
    } else if (tok == "--jobs" || tok == "-j") {
      rq.jobs = uint32_t(parse_int(args.value(tok), tok, 1, 1024));
    } else if (tok == "--window") {
      const std::string v = args.value(tok);
      const size_t comma = v.find(',');
      if (comma == std::string::npos) fail(kExitUsage, "--window: expected LO,HI, got '" + v + "'");
      rq.window[0] = parse_double(v.substr(0, comma), tok);
      rq.window[1] = parse_double(v.substr(comma + 1), tok);
      if (!(rq.window[1] > rq.window[0])) fail(kExitUsage, "--window: HI must be above LO, got '" + v + "'");
      rq.have_window = true;
    } else if (tok == "--mesh-resolution") {
      const std::string v = args.value(tok);
      rq.mesh_resolution = v == "auto" ? 0 : uint32_t(parse_int(v, tok, 2, 1024));
    } else if (tok == "--max-steps") {
      rq.max_steps = parse_int(args.value(tok), tok, 1, 1000000);
    } else if (tok == "--max-roi-voxels") {
      rq.max_roi = parse_int(args.value(tok), tok, 0, int64_t(1) << 40);
    } else if (tok == "--max-region-voxels") {
      rq.max_region = parse_int(args.value(tok), tok, 0, int64_t(1) << 40);
    } else if (tok == "--memory") {
      rq.memory_bytes = uint64_t(parse_int(args.value(tok), tok, 1, int64_t(1) << 30)) * 1000000u;
    } else if (tok == "--param") {
      set_param(&rq.params, args.value(tok));
    } else if (tok == "--target") {
      const std::string v = args.value(tok);
      if (v != "binary" && v != "intensity") fail(kExitUsage, "--target: expected binary or intensity, got '" + v + "'");
      rq.params.target_mode = parse_target(v, tok);
    } else if (tok == "--names") {
      names_opt = args.value(tok);
    } else if (tok == "--labels-format") {
      const std::string v = args.value(tok);
      if (!ffseg_tools::image_format_from_name(v, &rq.labels_format) ||
          rq.labels_format == ffseg_tools::ImageFormat::Dicom)
        fail(kExitUsage, "--labels-format: expected nifti, nrrd or metaimage, got '" + v + "'");
      rq.have_labels_format = true;
    } else if (tok == "--mesh-format") {
      const std::string v = args.value(tok);
      if (!ffseg_tools::mesh_format_from_name(v, &rq.mesh_format))
        fail(kExitUsage, "--mesh-format: expected ply, stl, obj or vtk, got '" + v + "'");
    } else if (tok == "--regions") {
      rq.regions_path = args.value(tok);
      if (rq.regions_path.empty()) fail(kExitUsage, "--regions: empty path");
    } else if (tok == "--dicom-seg") {
      rq.dicom_seg_path = args.value(tok);
    } else if (tok == "--rtstruct") {
      rq.rtstruct_path = args.value(tok);
    } else if (tok == "--view") {
      const std::string v = args.value(tok);
      if (!ffseg_tools::overlay_view_from_name(v, &rq.view))
        fail(kExitUsage, "--view: expected radiological or neurological, got '" + v + "'");
    } else if (tok == "--resample-labels") {
      rq.resample_labels = true;
    } else if (tok == "--truth") {
      rq.truth_path = args.value(tok);
    } else if (tok == "--truth-labels") {
      truth_labels_opt = args.value(tok);
      have_truth_labels = true;
    } else {
      fail(kExitUsage, "unknown option " + tok + " (see 'ffseg segment --help')");
    }
  }
  if (rq.volume_path.empty()) fail(kExitUsage, "missing VOLUME");
  if (rq.spheres.empty())
    fail(kExitUsage,
         "no object: give at least one --sphere X,Y,Z,R, --sphere-voxel I,J,K,R or --sphere-from-label LABELS:L");
  if (rq.spheres.size() > 64) fail(kExitUsage, "at most 64 objects, got " + std::to_string(rq.spheres.size()));
  if (rq.out_dir.empty()) fail(kExitUsage, "missing --out DIR");
  const uint32_t nobj = rq.objects();
  rq.names = object_names(names_opt, nobj);
  if (have_truth_labels) {
    if (rq.truth_path.empty()) fail(kExitUsage, "--truth-labels needs --truth LABELS");
    for (const std::string& s : split(truth_labels_opt, ','))
      rq.labels.push_back(parse_int(s, "--truth-labels", 1, 2147483647LL));
    if (rq.labels.size() != nobj)
      fail(kExitUsage, "--truth-labels gives " + std::to_string(rq.labels.size()) + " label(s) for " +
                           std::to_string(nobj) + " object(s)");
  } else {
    rq.labels = default_labels(rq.spheres);
  }
  if (!rq.regions_path.empty()) check_regions_path(rq.regions_path, nobj, rq.force);
  check_side_path("--dicom-seg", rq.dicom_seg_path, ".dcm", rq.force);
  check_side_path("--rtstruct", rq.rtstruct_path, ".dcm", rq.force);
  const std::string side[3] = {rq.regions_path, rq.dicom_seg_path, rq.rtstruct_path};
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b)
      if (!side[a].empty() && side[a] == side[b]) fail(kExitUsage, "two outputs are both written to " + side[a]);
  check_out_dir(&rq);
  return rq;
}

}  // namespace ffseg_cli
