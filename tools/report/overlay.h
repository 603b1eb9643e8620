// Segmentation overlay picture for the ffseg tools (never linked into the core).
//
// One row per object: an axial, a coronal and a sagittal slice through that
// object's centre, side by side, the grey image windowed to [lo, hi], and
// every object's contour drawn in its own colour (with a faint tint inside);
// an object's reference mask, when given, as a dashed yellow contour in its row.
// Slices are resampled to square pixels (the physical aspect is kept for
// anisotropic voxels) and enlarged for small volumes.
//
// Orientation: the voxel axes are matched to the world axes they are closest
// to (the index_to_world affine, assumed RAS as in NIfTI). Axial and coronal
// panels are drawn in radiological order by default (the patient's right on
// the screen's left, as CT and most radiology viewers show it) or in
// neurological order (the patient's left on the left); anterior up in axial,
// superior up in coronal and sagittal, anterior on the left in sagittal;
// letters at the panel edges say so.
#ifndef FFSEG_TOOLS_OVERLAY_H
#define FFSEG_TOOLS_OVERLAY_H

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace ffseg_tools {

struct OverlayObject {
  std::string name;
  uint8_t rgb[3] = {255, 0, 0};
  const uint8_t* mask = nullptr;  // the volume grid, i fastest; non-zero = inside
  int center_ijk[3] = {0, 0, 0};  // the slices of this object's row go through it
  const uint8_t* truth = nullptr; // optional reference mask (same grid): drawn as a dashed
                                  // yellow contour in this object's row, under the object's
};

enum class OverlayView { Radiological, Neurological };
const char* overlay_view_name(OverlayView v);  // "radiological", "neurological"
bool overlay_view_from_name(const std::string& name, OverlayView* v);

struct OverlayVolume {
  std::function<double(size_t)> value;  // intensity of voxel i + dims[0]*(j + dims[1]*k)
  int dims[3] = {0, 0, 0};
  double spacing[3] = {1, 1, 1};  // mm along i, j, k
  double index_to_world[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double window_lo = 0, window_hi = 1;
  OverlayView view = OverlayView::Radiological;
};

struct RgbImage {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;  // 3 bytes per pixel, rows top to bottom
};

// The k-th colour of the overlay palette (distinct, bright; cycles after 12;
// none of them close to the reference contour's yellow).
void overlay_palette(size_t k, uint8_t rgb[3]);
// The colour of the reference contours (OverlayObject::truth).
void overlay_truth_colour(uint8_t rgb[3]);

// [lo, hi] = the q_lo and q_hi quantiles of value(0..n-1) (e.g. 0.01, 0.99),
// estimated on at most ~2 million evenly spaced samples; non-finite values are
// ignored. If hi <= lo, hi = lo + 1.
void percentile_window(const std::function<double(size_t)>& value, size_t n, double q_lo,
                       double q_hi, double* lo, double* hi);

// Renders the picture (one row per object; with no object, one row through the
// grid centre). false with *err when the inputs are inconsistent.
bool overlay_render(const OverlayVolume& vol, const std::vector<OverlayObject>& objects,
                    RgbImage* out, std::string* err);

// Writes an RGB image as PNG (zlib compression). false with *err on failure.
bool png_write_file(const std::string& path, const RgbImage& img, std::string* err);

}  // namespace ffseg_tools

#endif  // FFSEG_TOOLS_OVERLAY_H
