// Several organs at once (thesis chapter 6) on Colin27: the eight deep nuclei
// of the AAL atlas (caudate 71/72, putamen 73/74, pallidum 75/76, thalamus
// 77/78), each from its protocol sphere (centre = the label voxel farthest
// from the label's border, radius = half that distance), grey-level targets,
// mesh n = 12, default parameters. Segmented alone (one engine each) and
// together (one engine, eight objects, bounding regions), in the same
// process: Dice and ASSD per structure, voxels shared by two objects,
// crossings between two objects' meshes after every step, and the regions
// stage's time against the rest of the step (the deformation).
//
//   bench_colin27_together [--n 12] [--labels 71,72,...] [--steps 100]
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "label_list.h"
#include "../tests/support/mesh_check.h"
#include "../tests/test_util.h"
#include "ffseg.h"
#include "metrics.h"
#include "nifti.h"

namespace {

const char* kCh2 = "/usr/share/mricron/templates/ch2.nii.gz";
const char* kAal = "/usr/share/mricron/templates/aal.nii.gz";

ffseg_volume volume_of(const ffseg_tools::NiftiImage& img) {
  const int64_t dims[3] = {img.dims[0], img.dims[1], img.dims[2]};
  ffseg_volume v = ffseg_test::make_volume(img.data.data(), uint32_t(img.voxel_type), dims, img.index_to_world);
  v.rescale_slope = img.scl_slope;
  v.rescale_intercept = img.scl_inter;
  return v;
}

struct Structure {
  int label;
  const char* name;
};
const Structure kNuclei[] = {{71, "caudate L"},  {72, "caudate R"},  {73, "putamen L"},  {74, "putamen R"},
                             {75, "pallidum L"}, {76, "pallidum R"}, {77, "thalamus L"}, {78, "thalamus R"}};

// The protocol sphere of a label, world mm.
bool protocol_sphere(const ffseg_tools::NiftiImage& t1, const ffseg_tools::NiftiImage& aal, int label, double c[3],
                     double* r) {
  std::vector<uint8_t> truth(aal.data.size());
  for (size_t i = 0; i < truth.size(); ++i) truth[i] = aal.data[i] == label;
  std::array<int, 3> ijk{};
  double depth = 0;
  if (!ffseg_tools::find_deepest_voxel(truth.data(), aal.dims, aal.spacing, &ijk, &depth)) return false;
  for (int q = 0; q < 3; ++q)
    c[q] = t1.index_to_world[4 * q] * ijk[0] + t1.index_to_world[4 * q + 1] * ijk[1] +
           t1.index_to_world[4 * q + 2] * ijk[2] + t1.index_to_world[4 * q + 3];
  *r = depth / 2;
  return true;
}


bool g_verbose = false;
double g_width = 0, g_border = 0;
uint32_t g_interval = 0;

struct Outcome {
  std::vector<ffseg_tools::SegMetrics> m;
  std::vector<std::vector<uint8_t>> masks;
  int steps = 0;
  double regions_ms = 0, other_ms = 0;  // summed over the steps
  size_t worst_crossings = 0;           // between two objects, worst step
  bool ok = false;
};

// Objects [0, k) of the labels in one engine (k = 1: alone).
Outcome run(const ffseg_tools::NiftiImage& t1, const ffseg_tools::NiftiImage& aal, const std::vector<int>& labels,
            uint32_t n, int max_steps, bool check_meshes) {
  Outcome out;
  const uint32_t k = uint32_t(labels.size());
  ffseg_config cfg;
  ffseg_config_init_default(&cfg);
  cfg.max_objects = k;
  cfg.mesh_resolution = n;
  size_t bytes = 0;
  if (ffseg_workspace_size(&cfg, &bytes) != FFSEG_OK) return out;
  void* ws = std::aligned_alloc(64, (bytes + 63) / 64 * 64);
  ffseg_engine* e = nullptr;
  if (ffseg_create(&cfg, ws, bytes, &e) != FFSEG_OK) {
    std::free(ws);
    return out;
  }
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  if (g_width > 0) p.region_width_mm = g_width;
  if (g_border > 0) p.border_weight = g_border;
  if (g_interval > 0) p.region_interval = g_interval;
  ffseg_volume v = volume_of(t1);
  bool ok = ffseg_set_params(e, &p) == FFSEG_OK && ffseg_set_volume(e, &v) == FFSEG_OK;
  for (uint32_t o = 0; o < k && ok; ++o) {
    double c[3], r = 0;
    ok = protocol_sphere(t1, aal, labels[o], c, &r) && ffseg_init_sphere(e, o, c, r) == FFSEG_OK;
  }
  ffseg_status st = ok ? FFSEG_OK : FFSEG_ERR_INVALID_ARGUMENT;
  std::vector<std::vector<float>> xyz(k);
  std::vector<std::vector<uint32_t>> tris(k);
  while (st == FFSEG_OK && out.steps < max_steps) {
    ffseg_step_info info;
    info.struct_size = sizeof info;
    st = ffseg_step(e, &info);
    ++out.steps;
    if (st < 0) break;
    for (int s = 0; s < FFSEG_STAGE_COUNT; ++s)
      (s == FFSEG_STAGE_REGIONS ? out.regions_ms : out.other_ms) += double(info.stage_us[s]) / 1000.0;
    if (g_verbose && k > 1) {
      std::fprintf(stderr, "step %d:", out.steps);
      for (uint32_t o = 0; o < k && o < FFSEG_REPORT_OBJECTS; ++o)
        std::fprintf(stderr, " [%u] %.2f mm b%u t%u", o, info.mean_displacement_mm[o], info.border_vertices[o],
                     info.vertices_with_target[o]);
      std::fprintf(stderr, "\n");
    }
    if (check_meshes && k > 1) {
      for (uint32_t o = 0; o < k; ++o) ffseg_test::extract(e, o, &xyz[o], &tris[o]);
      size_t worst = 0;
      for (uint32_t a = 0; a < k; ++a)
        for (uint32_t b = a + 1; b < k; ++b) worst = std::max(worst, ffseg_test::crossings_between(xyz[a], tris[a], xyz[b], tris[b]));
      out.worst_crossings = std::max(out.worst_crossings, worst);
    }
  }
  if (st < 0) std::fprintf(stderr, "bench_colin27_together: %s\n", ffseg_last_error(e));
  out.ok = st == FFSEG_CONVERGED || st == FFSEG_OK;
  for (uint32_t o = 0; o < k && out.ok; ++o) {
    std::vector<uint8_t> mask(aal.data.size()), truth(aal.data.size());
    ffseg_rasterize(e, o, mask.data(), nullptr);
    for (size_t i = 0; i < truth.size(); ++i) truth[i] = aal.data[i] == labels[o];
    out.m.push_back(ffseg_tools::compare_masks(mask.data(), truth.data(), aal.dims, aal.spacing));
    out.masks.push_back(std::move(mask));
  }
  ffseg_destroy(e);
  std::free(ws);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t n = 12;
  int max_steps = 100;
  std::vector<int> labels;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--n") && a + 1 < argc) {
      n = uint32_t(std::atoi(argv[++a]));
    } else if (!std::strcmp(argv[a], "--width") && a + 1 < argc) {
      g_width = std::atof(argv[++a]);
    } else if (!std::strcmp(argv[a], "--border") && a + 1 < argc) {
      g_border = std::atof(argv[++a]);
    } else if (!std::strcmp(argv[a], "--interval") && a + 1 < argc) {
      g_interval = uint32_t(std::atoi(argv[++a]));
    } else if (!std::strcmp(argv[a], "--verbose")) {
      g_verbose = true;
    } else if (!std::strcmp(argv[a], "--steps") && a + 1 < argc) {
      max_steps = std::max(1, std::atoi(argv[++a]));
    } else if (!std::strcmp(argv[a], "--labels") && a + 1 < argc) {
      parse_label_list(argv[++a], &labels);
    } else {
      std::fprintf(stderr, "usage: bench_colin27_together [--n 12] [--steps 100] [--labels 71,72,...]\n");
      return 2;
    }
  }
  if (labels.empty())
    for (const Structure& s : kNuclei) labels.push_back(s.label);
  ffseg_tools::NiftiImage t1, aal;
  std::string err;
  if (!ffseg_tools::nifti_read_file(kCh2, &t1, &err) ||
      !ffseg_tools::nifti_read_file(kAal, &aal, &err)) {
    std::printf("bench_colin27_together: Colin27 not found (%s); install mricron-data (make deps)\n", err.c_str());
    return 0;
  }
  std::printf("Colin27, %zu structures, n = %u, grey levels, default parameters: alone (one engine each) and "
              "together (one engine, bounding regions)\n\n",
              labels.size(), n);
  std::vector<Outcome> alone;
  double alone_ms = 0;
  int alone_steps = 0;
  for (int label : labels) {
    alone.push_back(run(t1, aal, {label}, n, max_steps, false));
    alone_ms += alone.back().other_ms;
    alone_steps += alone.back().steps;
    std::fprintf(stderr, "alone %d: %d steps\n", label, alone.back().steps);
  }
  const Outcome both = run(t1, aal, labels, n, max_steps, true);
  if (!both.ok) {
    std::printf("together: failed\n");
    return 1;
  }
  std::printf("| structure | AAL | Dice alone | Dice together | ASSD alone mm | ASSD together mm |\n|---|---|---|---|---|---|\n");
  double da = 0, dt = 0, aa = 0, at = 0;
  for (size_t i = 0; i < labels.size(); ++i) {
    const char* name = "";
    for (const Structure& s : kNuclei)
      if (s.label == labels[i]) name = s.name;
    const ffseg_tools::SegMetrics& a = alone[i].m.at(0);
    const ffseg_tools::SegMetrics& t = both.m[i];
    std::printf("| %s | %d | %.3f | %.3f | %.2f | %.2f |\n", name, labels[i], a.dice, t.dice, a.assd_mm, t.assd_mm);
    da += a.dice, dt += t.dice, aa += a.assd_mm, at += t.assd_mm;
  }
  const double k = double(labels.size());
  std::printf("| **mean** | | **%.3f** | **%.3f** | %.2f | %.2f |\n\n", da / k, dt / k, aa / k, at / k);
  // Voxels claimed twice: alone (what the regions prevent) and together.
  size_t shared_alone = 0, shared_both = 0;
  for (size_t a = 0; a < labels.size(); ++a)
    for (size_t b = a + 1; b < labels.size(); ++b)
      for (size_t q = 0; q < aal.data.size(); ++q) {
        shared_alone += alone[a].masks[0][q] && alone[b].masks[0][q];
        shared_both += both.masks[a][q] && both.masks[b][q];
      }
  std::printf("voxels inside two objects' meshes: alone %zu, together %zu\n", shared_alone, shared_both);
  std::printf("crossing triangle pairs between two objects, worst step together: %zu\n", both.worst_crossings);
  std::printf("together: %d steps; regions stage %.1f ms in all (%.2f ms per step), the rest of the step %.1f ms "
              "(%.2f ms per step): regions / deformation = %.2fx\n",
              both.steps, both.regions_ms, both.regions_ms / both.steps, both.other_ms, both.other_ms / both.steps,
              both.regions_ms / both.other_ms);
  std::printf("alone: %d steps in all, %.1f ms of steps\n", alone_steps, alone_ms);
  std::printf("mean Dice together - alone: %+.4f\n", (dt - da) / k);
  return 0;
}
