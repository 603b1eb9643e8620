// Tests for tools/report/overlay's views: radiological order by default puts
// an object on the patient's right on the image's left; neurological order
// on the right.
#include <doctest/doctest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "overlay.h"

using namespace ffseg_tools;

namespace {

// The mean x of the object's colour in the first (axial) panel, for an
// object at the patient's right (RAS +x); *width: the picture's width.
double mean_object_x(OverlayView view, int* width) {
  OverlayVolume vol;
  vol.dims[0] = vol.dims[1] = vol.dims[2] = 40;
  vol.value = [](size_t) { return 0.5; };
  vol.view = view;
  std::vector<uint8_t> mask(40 * 40 * 40, 0);
  // RAS identity affine: i grows to the patient's right.
  for (int k = 16; k < 24; ++k)
    for (int j = 16; j < 24; ++j)
      for (int i = 30; i < 36; ++i) mask[size_t(i + 40 * (j + 40 * k))] = 1;
  std::vector<OverlayObject> objects(1);
  objects[0].name = "right";
  objects[0].mask = mask.data();
  objects[0].center_ijk[0] = 33, objects[0].center_ijk[1] = 20, objects[0].center_ijk[2] = 20;
  overlay_palette(0, objects[0].rgb);
  RgbImage img;
  std::string err;
  REQUIRE(overlay_render(vol, objects, &img, &err));
  *width = img.width;
  // The axial panel is the first third of the picture.
  double sum = 0;
  size_t n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width / 3; ++x) {
      const uint8_t* p = &img.rgb[size_t(3 * (y * img.width + x))];
      if (p[0] == objects[0].rgb[0] && p[1] == objects[0].rgb[1] && p[2] == objects[0].rgb[2]) sum += x, ++n;
    }
  REQUIRE(n > 0);
  return sum / double(n);
}

}  // namespace

TEST_CASE("overlay: radiological view by default, neurological on request") {
  CHECK(OverlayVolume().view == OverlayView::Radiological);
  OverlayView v;
  CHECK(overlay_view_from_name("neurological", &v));
  CHECK(v == OverlayView::Neurological);
  CHECK(std::string(overlay_view_name(OverlayView::Radiological)) == "radiological");
  CHECK_FALSE(overlay_view_from_name("left", &v));
  int w = 0;
  const double radiological = mean_object_x(OverlayView::Radiological, &w);
  const double neurological = mean_object_x(OverlayView::Neurological, &w);
  const double panel = w / 3.0;
  // The object is 10-16 voxels to the patient's right of the centre.
  CHECK(radiological < panel / 2);
  CHECK(neurological > panel / 2);
}
