// `ffseg info VOLUME`: what the reader sees in an image (NIfTI-1, NRRD, MetaImage, DICOM series).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "cli.h"

namespace ffseg_cli {

const char* const kInfoUsage =
    "usage: ffseg info VOLUME\n"
    "\n"
    "Prints the image as ffseg reads it (NIfTI-1 .nii/.nii.gz, NRRD .nrrd/.nhdr,\n"
    "MetaImage .mha/.mhd, or a directory holding one DICOM series): format,\n"
    "datatype, dimensions, voxel spacing, the index-to-world affine in RAS mm and\n"
    "where it comes from (sform, qform, pixdim, space directions, TransformMatrix,\n"
    "DICOM positions), the orientation, the world extent of the voxel centres, the\n"
    "intensity scaling, the intensity range after scaling, and the number of\n"
    "non-zero voxels.\n"
    "\n"
    "options:\n"
    "  -h, --help   this text\n";

namespace {
const char* xform_name(int code) {
  switch (code) {
    case 0: return "unknown";
    case 1: return "scanner anatomical";
    case 2: return "aligned anatomical";
    case 3: return "Talairach";
    case 4: return "MNI 152";
    case 5: return "template";
    default: return "?";
  }
}
}  // namespace

int cmd_info(int argc, char** argv) {
  Args args(argc, argv, 2);
  std::string tok, path;
  bool opt;
  while (args.next(&tok, &opt)) {
    if (opt && (tok == "-h" || tok == "--help")) {
      std::fputs(kInfoUsage, stdout);
      return kExitOk;
    }
    if (opt) fail(kExitUsage, "unknown option " + tok + " (see 'ffseg info --help')");
    if (!path.empty()) fail(kExitUsage, "one VOLUME only ('" + tok + "' is extra)");
    path = tok;
  }
  if (path.empty()) fail(kExitUsage, "missing VOLUME");
  ffseg_tools::ImageFormat format;
  const ffseg_tools::NiftiImage img = read_image(path, &format);

  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  size_t nonzero = 0, nonfinite = 0;
  const double a = img.scl_slope, b = img.scl_inter;
  for_each_stored(img, [&](size_t, double v) {
    const double x = a * v + b;
    if (!std::isfinite(x)) {
      ++nonfinite;
      return;
    }
    lo = std::min(lo, x);
    hi = std::max(hi, x);
    if (x != 0) ++nonzero;
  });

  const uint64_t n = img.voxel_count();
  std::printf("file:         %s\n", path.c_str());
  std::printf("format:       %s\n", ffseg_tools::image_format_name(format));
  std::printf("datatype:     %s (NIfTI code %d)", datatype_name(img.datatype), img.datatype);
  if (ffseg_tools::nifti_datatype_for_voxel_type(img.voxel_type) != img.datatype)
    std::printf(", read as %s", datatype_name(ffseg_tools::nifti_datatype_for_voxel_type(img.voxel_type)));
  std::printf("\n");
  std::printf("dims:         %d x %d x %d (%llu voxels)\n", img.dims[0], img.dims[1], img.dims[2],
              static_cast<unsigned long long>(n));
  std::printf("spacing:      %s x %s x %s mm\n", format_double(img.spacing[0]).c_str(),
              format_double(img.spacing[1]).c_str(), format_double(img.spacing[2]).c_str());
  if (format == ffseg_tools::ImageFormat::Nifti)
    std::printf("affine:       %s (sform_code %d %s, qform_code %d %s)\n", img.which_affine.c_str(),
                img.sform_code, xform_name(img.sform_code), img.qform_code, xform_name(img.qform_code));
  else
    std::printf("affine:       %s (world frame RAS mm)\n", img.which_affine.c_str());
  for (int r = 0; r < 4; ++r)
    std::printf("              [ %10.4f %10.4f %10.4f %10.4f ]\n", img.index_to_world[4 * r],
                img.index_to_world[4 * r + 1], img.index_to_world[4 * r + 2], img.index_to_world[4 * r + 3]);
  std::printf("orientation:  %s (voxel axes i, j, k point towards)\n", orientation_code(img.index_to_world).c_str());
  double wlo[3], whi[3];
  for (int w = 0; w < 3; ++w) wlo[w] = std::numeric_limits<double>::infinity(), whi[w] = -wlo[w];
  for (int c = 0; c < 8; ++c) {
    const double ijk[3] = {c & 1 ? img.dims[0] - 1.0 : 0.0, c & 2 ? img.dims[1] - 1.0 : 0.0,
                           c & 4 ? img.dims[2] - 1.0 : 0.0};
    const auto p = voxel_to_world(img.index_to_world, ijk);
    for (int w = 0; w < 3; ++w) wlo[w] = std::min(wlo[w], p[size_t(w)]), whi[w] = std::max(whi[w], p[size_t(w)]);
  }
  std::printf("world extent: x %.2f .. %.2f, y %.2f .. %.2f, z %.2f .. %.2f mm (voxel centres)\n", wlo[0],
              whi[0], wlo[1], whi[1], wlo[2], whi[2]);
  const double mid[3] = {(img.dims[0] - 1) / 2.0, (img.dims[1] - 1) / 2.0, (img.dims[2] - 1) / 2.0};
  const auto pc = voxel_to_world(img.index_to_world, mid);
  std::printf("grid centre:  %.2f, %.2f, %.2f mm\n", pc[0], pc[1], pc[2]);
  std::printf("scaling:      value = %s * stored + %s\n", format_double(img.scl_slope).c_str(),
              format_double(img.scl_inter).c_str());
  if (lo <= hi)
    std::printf("intensity:    %s .. %s (after scaling)\n", format_double(lo).c_str(), format_double(hi).c_str());
  else
    std::printf("intensity:    no finite value\n");
  if (nonfinite) std::printf("non-finite:   %zu voxels\n", nonfinite);
  std::printf("non-zero:     %zu voxels (%.2f%%, %s ml)\n", nonzero, n ? 100.0 * double(nonzero) / double(n) : 0.0,
              format_double(double(nonzero) * voxel_volume_mm3(img) / 1000.0).c_str());
  std::printf("voxel volume: %s mm^3\n", format_double(voxel_volume_mm3(img)).c_str());
  if (img.intent_code) std::printf("intent:       %d%s\n", img.intent_code, img.intent_code == ffseg_tools::kNiftiIntentLabel ? " (label)" : "");
  if (!img.descrip.empty()) std::printf("description:  %s\n", img.descrip.c_str());
  return kExitOk;
}

}  // namespace ffseg_cli
