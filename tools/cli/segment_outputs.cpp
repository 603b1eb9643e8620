// `ffseg segment`'s results (segment_outputs.h).
#include "segment_outputs.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "cli.h"
#include "overlay.h"

namespace ffseg_cli {

[[noreturn]] void engine_fail(const ffseg_engine* e, ffseg_status st, const std::string& what) {
  const std::string detail = ffseg_last_error(e);
  const std::string hint = st == FFSEG_ERR_ROI_TOO_LARGE
                               ? "; the engine was sized by --memory (or --max-roi-voxels / --max-region-voxels): raise it"
                               : "";
  fail(kExitEngine, what + ": " + ffseg_status_string(st) + (detail.empty() ? "" : " (" + detail + ")") + hint);
}

std::vector<ObjectResult> read_results(const ffseg_engine* e, const ffseg_tools::NiftiImage& img, uint32_t nobj,
                                       const std::vector<std::array<double, 3>>& centres_mm) {
  const size_t nvox = size_t(img.voxel_count());
  std::vector<ObjectResult> res(nobj);
  std::vector<uint8_t> claimed(nobj > 1 ? nvox : 0, 0);
  for (uint32_t k = 0; k < nobj; ++k) {
    ObjectResult& r = res[k];
    size_t nv = 0, nt = 0;
    ffseg_status st = ffseg_extract_mesh(e, k, nullptr, 0, nullptr, 0, &nv, &nt);
    if (st != FFSEG_OK) engine_fail(e, st, "ffseg_extract_mesh");
    r.xyz.resize(nv * 3);
    r.tris.resize(nt * 3);
    st = ffseg_extract_mesh(e, k, r.xyz.data(), nv, r.tris.data(), nt, &nv, &nt);
    if (st != FFSEG_OK) engine_fail(e, st, "ffseg_extract_mesh");
    r.mask.assign(nvox, 0);
    st = ffseg_rasterize(e, k, r.mask.data(), nullptr);
    if (st != FFSEG_OK) engine_fail(e, st, "ffseg_rasterize");
    double sum[3] = {0, 0, 0};
    size_t idx = 0;
    for (int kk = 0; kk < img.dims[2]; ++kk)
      for (int j = 0; j < img.dims[1]; ++j)
        for (int i = 0; i < img.dims[0]; ++i, ++idx) {
          if (!r.mask[idx]) continue;
          if (nobj > 1) {
            if (claimed[idx]) {  // an earlier object's voxel
              r.mask[idx] = 0;
              ++r.shared_voxels;
              continue;
            }
            claimed[idx] = 1;
          }
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
  return res;
}

ffseg_tools::NiftiImage make_label_image(const ffseg_tools::NiftiImage& img, const std::vector<int64_t>& labels,
                                         const char* descrip) {
  const int64_t max_label = labels.empty() ? 1 : *std::max_element(labels.begin(), labels.end());
  const int ltype = max_label <= 255 ? ffseg_tools::kNiftiVoxU8
                    : max_label <= 65535 ? ffseg_tools::kNiftiVoxU16 : ffseg_tools::kNiftiVoxI32;
  ffseg_tools::NiftiImage lab = ffseg_tools::nifti_make_label_image(img, ltype);
  lab.descrip = descrip;
  return lab;
}

void put_label(ffseg_tools::NiftiImage* lab, size_t i, int64_t v) {
  switch (lab->voxel_type) {
    case ffseg_tools::kNiftiVoxU8: lab->data[i] = uint8_t(v); break;
    case ffseg_tools::kNiftiVoxU16: reinterpret_cast<uint16_t*>(lab->data.data())[i] = uint16_t(v); break;
    default: reinterpret_cast<int32_t*>(lab->data.data())[i] = int32_t(v); break;
  }
}

ffseg_tools::NiftiImage object_label_map(const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                                         const std::vector<int64_t>& labels) {
  ffseg_tools::NiftiImage lab = make_label_image(img, labels, "ffseg labels");
  for (size_t k = 0; k < res.size(); ++k) {
    const uint8_t* m = res[k].mask.data();
    for (size_t i = 0; i < res[k].mask.size(); ++i)
      if (m[i]) put_label(&lab, i, labels[k]);
  }
  return lab;
}

ffseg_tools::NiftiImage region_label_map(const ffseg_engine* e, const ffseg_tools::NiftiImage& img,
                                         const std::vector<int64_t>& labels) {
  ffseg_tools::NiftiImage lab = make_label_image(img, labels, "ffseg bounding regions");
  std::vector<uint8_t> m(size_t(img.voxel_count()));
  for (uint32_t k = 0; k < uint32_t(labels.size()); ++k) {
    const ffseg_status st = ffseg_region_mask(e, k, m.data(), nullptr);
    if (st != FFSEG_OK) engine_fail(e, st, "ffseg_region_mask (object " + std::to_string(k + 1) + ")");
    for (size_t i = 0; i < m.size(); ++i)
      if (m[i]) put_label(&lab, i, labels[k]);
  }
  return lab;
}

void object_window(const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res, double* lo, double* hi) {
  const size_t n = size_t(img.voxel_count());
  auto value = [&img](size_t i) { return voxel_value(img, i); };
  double glo, ghi;
  ffseg_tools::percentile_window(value, n, 0.01, 0.99, &glo, &ghi);
  *lo = glo;
  *hi = ghi;
  std::vector<size_t> inside;
  for (size_t i = 0; i < n; ++i)
    for (const ObjectResult& r : res)
      if (r.mask[i]) {
        inside.push_back(i);
        break;
      }
  if (inside.empty()) return;
  double olo, ohi;
  ffseg_tools::percentile_window([&](size_t k) { return voxel_value(img, inside[k]); }, inside.size(), 0.01, 0.99,
                                 &olo, &ohi);
  const double w = ohi - olo;
  *lo = std::max(glo, olo - w);
  *hi = std::min(ghi, ohi + w);
  if (!(*hi > *lo)) *lo = glo, *hi = ghi;
}

bool write_overlay(const std::string& path, const ffseg_tools::NiftiImage& img, const std::vector<ObjectResult>& res,
                   const std::vector<std::string>& names, const std::vector<std::vector<uint8_t>>& truth_masks,
                   double lo, double hi, ffseg_tools::OverlayView view, std::string* err) {
  ffseg_tools::OverlayVolume ov;
  ov.value = [&img](size_t i) { return voxel_value(img, i); };
  for (int a = 0; a < 3; ++a) {
    ov.dims[a] = img.dims[a];
    ov.spacing[a] = img.spacing[a];
  }
  std::memcpy(ov.index_to_world, img.index_to_world, sizeof ov.index_to_world);
  ov.window_lo = lo;
  ov.window_hi = hi;
  ov.view = view;
  std::vector<ffseg_tools::OverlayObject> oo(res.size());
  for (size_t k = 0; k < res.size(); ++k) {
    oo[k].name = names[k];
    ffseg_tools::overlay_palette(k, oo[k].rgb);
    oo[k].mask = res[k].mask.data();
    if (k < truth_masks.size()) oo[k].truth = truth_masks[k].data();
    for (int a = 0; a < 3; ++a) oo[k].center_ijk[a] = res[k].centre_ijk[size_t(a)];
  }
  ffseg_tools::RgbImage picture;
  return ffseg_tools::overlay_render(ov, oo, &picture, err) && ffseg_tools::png_write_file(path, picture, err);
}

}  // namespace ffseg_cli
