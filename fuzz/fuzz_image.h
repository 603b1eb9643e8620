// The checks every image-reader fuzz target makes on what its reader returns
// (fuzz_nifti, fuzz_nrrd, fuzz_metaimage): a refusal has a message; an
// accepted image is self-consistent (known voxel type, positive dims, a buffer
// of dims x voxel size within the reader's byte bound, finite affine and
// rescale) and is accepted by the engine as a volume, whose 8 corner voxels are
// then read through ffseg_sample.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "ffseg.h"
#include "engine_volume.h"
#include "nifti.h"

namespace ffseg_fuzz {

[[noreturn]] inline void reader_finding(const char* target, const char* what, const std::string& detail) {
  std::fprintf(stderr, "%s: %s: %s\n", target, what, detail.c_str());
  std::abort();
}

// One small engine reused across inputs (set_volume does not depend on n).
inline ffseg_engine* reader_engine() {
  static ffseg_engine* e = [] {
    ffseg_config c;
    ffseg_config_init_default(&c);
    c.mesh_resolution = 2;
    size_t bytes = 0;
    void* ws = nullptr;
    ffseg_engine* out = nullptr;
    if (ffseg_workspace_size(&c, &bytes) != FFSEG_OK || posix_memalign(&ws, 64, bytes) != 0 ||
        ffseg_create(&c, ws, bytes, &out) != FFSEG_OK)
      std::abort();
    return out;
  }();
  return e;
}

// The limits every reader target runs with: 64 MiB, so a decompression bomb or
// a lying header must be refused by that bound (libFuzzer's -rss_limit_mb and
// -malloc_limit_mb catch any attempt to allocate beyond it).
inline ffseg_tools::NiftiLimits reader_limits() {
  ffseg_tools::NiftiLimits lim;
  lim.max_bytes = uint64_t(64) << 20;
  return lim;
}

inline int check_read(const char* target, bool ok, const ffseg_tools::NiftiImage& img, const std::string& err,
                      const ffseg_tools::NiftiLimits& lim) {
  if (!ok) {
    if (err.empty()) reader_finding(target, "refused without a message", "");
    return 0;
  }
  const int es = ffseg_tools::nifti_voxel_type_size(img.voxel_type);
  if (es == 0 || es != img.bytes_per_voxel) reader_finding(target, "bad voxel type", std::to_string(img.voxel_type));
  for (int a = 0; a < 3; ++a)
    if (img.dims[a] < 1) reader_finding(target, "non-positive dim", std::to_string(img.dims[a]));
  if (img.data.size() != img.voxel_count() * uint64_t(es))
    reader_finding(target, "data size does not match dims", std::to_string(img.data.size()));
  if (img.data.size() > lim.max_bytes) reader_finding(target, "image beyond max_bytes", std::to_string(img.data.size()));
  for (int q = 0; q < 16; ++q)
    if (!std::isfinite(img.index_to_world[q])) reader_finding(target, "non-finite affine", img.which_affine);
  if (!std::isfinite(img.scl_slope) || !std::isfinite(img.scl_inter) || img.scl_slope == 0)
    reader_finding(target, "bad rescale", std::to_string(img.scl_slope));

  // The engine accepts what the reader accepts (but a single slice).
  const ffseg_volume v = ffseg_tools::engine_volume(img);
  ffseg_engine* e = reader_engine();
  const ffseg_status sv = ffseg_set_volume(e, &v);
  // The engine refuses a single slice along any axis (ddb44bf: a closed
  // surface bounds nothing in it); the readers accept such images.
  const bool one_slice = img.dims[0] == 1 || img.dims[1] == 1 || img.dims[2] == 1;
  if (sv != FFSEG_OK && !(one_slice && sv == FFSEG_ERR_INVALID_VOLUME && std::strstr(ffseg_last_error(e), "single slice")))
    reader_finding(target, "engine refused an accepted image", ffseg_last_error(e));
  if (sv != FFSEG_OK) return 0;
  const double* A = img.index_to_world;
  for (int c = 0; c < 8; ++c) {
    double ijk[3], w[3], val = 0;
    for (int a = 0; a < 3; ++a) ijk[a] = (c >> a) & 1 ? double(img.dims[a] - 1) : 0.0;
    for (int r = 0; r < 3; ++r) w[r] = A[4 * r] * ijk[0] + A[4 * r + 1] * ijk[1] + A[4 * r + 2] * ijk[2] + A[4 * r + 3];
    if (ffseg_sample(e, w, FFSEG_SAMPLE_NEAREST, &val) != FFSEG_OK)
      reader_finding(target, "sample failed", ffseg_last_error(e));
  }
  // The engine still borrows img.data after this returns; it is never read
  // again: the next accepted image replaces the volume before any sampling.
  return 0;
}

}  // namespace ffseg_fuzz
