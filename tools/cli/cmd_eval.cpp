// `ffseg eval PRED TRUTH`: accuracy metrics between two label maps.
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "cli.h"
#include "label_grid.h"
#include "report_json.h"

namespace ffseg_cli {

const char* const kEvalUsage =
    "usage: ffseg eval PRED TRUTH [--labels a,b:c,...] [--json] [--resample-labels]\n"
    "\n"
    "Compares two label maps on the same grid (the same voxel centres, within 0.01\n"
    "voxel, stored in any axis order and direction: TRUTH is re-indexed exactly) and\n"
    "prints, per label, the voxel counts and volumes, Dice = 2|A n B|/(|A|+|B|),\n"
    "the volumetric overlap error VOE = 1 - |A n B|/|A u B|, the average\n"
    "symmetric surface distance ASSD and the 95th percentile Hausdorff distance\n"
    "HD95 in mm (border voxels: object voxels with a 26-neighbour outside).\n"
    "\n"
    "options:\n"
    "  --labels LIST   comma-separated; 'a' compares label a in both maps, 'a:b'\n"
    "                  compares label a of PRED with label b of TRUTH\n"
    "                  (default: every non-zero label found in either map)\n"
    "  --json          print the results as JSON instead of a table\n"
    "  --resample-labels  TRUTH on another grid is resampled onto PRED's by nearest\n"
    "                  neighbour (a warning) instead of refused\n"
    "  -h, --help      this text\n";

namespace {

// Distinct values of a label map; fails if a value is not an integer.
std::set<int64_t> labels_in(const ffseg_tools::NiftiImage& img, const std::string& path) {
  std::set<int64_t> out;
  const double a = img.scl_slope, b = img.scl_inter;
  bool bad = false;
  double bad_value = 0;
  for_each_stored(img, [&](size_t, double v) {
    const double x = a * v + b;
    if (x == 0 || bad) return;
    const double r = std::round(x);
    if (!(std::fabs(x - r) < 1e-3) || std::fabs(r) > 2147483647.0) {
      bad = true;
      bad_value = x;
      return;
    }
    out.insert(int64_t(r));
  });
  if (bad) fail(kExitInput, path + " is not a label map (it holds the value " + format_double(bad_value) + ")");
  return out;
}

std::string num(double v, const char* f = "%.4f") {
  if (!std::isfinite(v)) return v > 0 ? "inf" : "nan";
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace

int cmd_eval(int argc, char** argv) {
  Args args(argc, argv, 2);
  std::string tok, labels_opt;
  std::vector<std::string> files;
  bool opt, json = false, have_labels = false, resample = false;
  while (args.next(&tok, &opt)) {
    if (!opt) {
      files.push_back(tok);
    } else if (tok == "-h" || tok == "--help") {
      std::fputs(kEvalUsage, stdout);
      return kExitOk;
    } else if (tok == "--labels") {
      labels_opt = args.value(tok);
      have_labels = true;
    } else if (tok == "--resample-labels") {
      resample = true;
    } else if (tok == "--json") {
      json = true;
    } else {
      fail(kExitUsage, "unknown option " + tok + " (see 'ffseg eval --help')");
    }
  }
  if (files.size() != 2) fail(kExitUsage, "expected PRED and TRUTH, got " + std::to_string(files.size()) + " file(s)");

  std::vector<std::pair<int64_t, int64_t>> pairs;
  if (have_labels) {
    for (const std::string& item : split(labels_opt, ',')) {
      const std::vector<std::string> ab = split(item, ':');
      if (ab.size() > 2 || ab[0].empty()) fail(kExitUsage, "--labels: bad entry '" + item + "' (use a or a:b)");
      const int64_t a = parse_int(ab[0], "--labels", -2147483648LL, 2147483647LL);
      const int64_t b = ab.size() == 2 ? parse_int(ab[1], "--labels", -2147483648LL, 2147483647LL) : a;
      pairs.emplace_back(a, b);
    }
  }

  const ffseg_tools::NiftiImage pred = read_image(files[0]);
  const ffseg_tools::NiftiImage truth = read_on_grid(pred, files[0], files[1], "TRUTH", resample, false);
  if (!have_labels) {
    std::set<int64_t> all = labels_in(pred, files[0]);
    for (int64_t l : labels_in(truth, files[1])) all.insert(l);
    for (int64_t l : all) pairs.emplace_back(l, l);
    if (pairs.empty()) fail(kExitInput, "both label maps are empty (no non-zero voxel)");
  }

  ffseg_tools::Json out = ffseg_tools::Json::object();
  out.set("pred", files[0]);
  out.set("truth", files[1]);
  ffseg_tools::Json list = ffseg_tools::Json::array();
  if (!json)
    std::printf("%-12s %10s %10s %10s %10s %8s %8s %9s %9s\n", "label", "pred_vox", "truth_vox", "pred_ml",
                "truth_ml", "dice", "voe", "assd_mm", "hd95_mm");
  for (const auto& pr : pairs) {
    check_interrupted();
    size_t na = 0, nb = 0;
    const std::vector<uint8_t> a = label_mask(pred, pr.first, &na);
    const std::vector<uint8_t> b = label_mask(truth, pr.second, &nb);
    if (nb == 0)
      std::fprintf(stderr, "ffseg: warning: label %lld has no voxel in %s\n", static_cast<long long>(pr.second), files[1].c_str());
    if (na == 0)
      std::fprintf(stderr, "ffseg: warning: label %lld has no voxel in %s\n", static_cast<long long>(pr.first), files[0].c_str());
    const MaskMetrics m = compare_masks_cropped(a.data(), b.data(), pred.dims, pred.spacing);
    const std::string name =
        pr.first == pr.second ? std::to_string(pr.first) : std::to_string(pr.first) + ":" + std::to_string(pr.second);
    if (json) {
      ffseg_tools::Json e = ffseg_tools::Json::object();
      e.set("pred_label", pr.first);
      e.set("truth_label", pr.second);
      e.set("pred_voxels", uint64_t(na));
      e.set("truth_voxels", uint64_t(nb));
      e.set("pred_ml", m.vol_a_ml);
      e.set("truth_ml", m.vol_b_ml);
      set_metric_fields(e, m);
      list.push(std::move(e));
    } else {
      std::printf("%-12s %10zu %10zu %10s %10s %8s %8s %9s %9s\n", name.c_str(), na, nb, num(m.vol_a_ml, "%.3f").c_str(),
                  num(m.vol_b_ml, "%.3f").c_str(), num(m.dice).c_str(), num(m.voe).c_str(),
                  num(m.assd_mm, "%.3f").c_str(), num(m.hd95_mm, "%.3f").c_str());
    }
  }
  if (json) {
    out.set("labels", std::move(list));
    std::fputs(out.dump().c_str(), stdout);
  }
  return kExitOk;
}

}  // namespace ffseg_cli
