// Overlay picture: orthogonal slices, contours, PNG output (see overlay.h).
#include "overlay.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

// stb_image_write's own deflate is weak; give it zlib's.
static unsigned char* ffseg_stbiw_zlib_compress(unsigned char* data, int data_len, int* out_len,
                                                int quality) {
  uLongf bound = compressBound(uLong(data_len));
  unsigned char* out = static_cast<unsigned char*>(std::malloc(bound));
  if (!out) return nullptr;
  const int level = quality < 1 ? 1 : quality > 9 ? 9 : quality;
  if (compress2(out, &bound, data, uLong(data_len), level) != Z_OK) {
    std::free(out);
    return nullptr;
  }
  *out_len = int(bound);
  return out;
}

#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STBIW_ZLIB_COMPRESS ffseg_stbiw_zlib_compress
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#endif
#include <stb/stb_image_write.h>
#include <stb/stb_easy_font.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace ffseg_tools {

namespace {

struct Orientation {
  int voxel_axis_of_world[3];  // world axis w is closest to voxel axis voxel_axis_of_world[w]
  int sign_of_world[3];        // +1 if that voxel index grows along +w
};

// Greedy match of voxel axes to world axes by the largest affine entries.
Orientation orientation_of(const double* A) {
  Orientation o{};
  bool wused[3] = {false, false, false}, vused[3] = {false, false, false};
  for (int round = 0; round < 3; ++round) {
    int bw = -1, bv = -1;
    double best = -1;
    for (int w = 0; w < 3; ++w)
      for (int v = 0; v < 3; ++v)
        if (!wused[w] && !vused[v] && std::fabs(A[4 * w + v]) > best) {
          best = std::fabs(A[4 * w + v]);
          bw = w;
          bv = v;
        }
    wused[bw] = vused[bv] = true;
    o.voxel_axis_of_world[bw] = bv;
    o.sign_of_world[bw] = A[4 * bw + bv] < 0 ? -1 : 1;
  }
  return o;
}

struct ViewSpec {
  const char* title;
  int ws, wu, wv;  // world axes: slice normal, screen x, screen y (down)
  int du, dv;      // +1: screen coordinate grows with the world coordinate
  const char *left, *right, *top, *bottom;
};

// Neurological order: the patient's left on the screen's left.
const ViewSpec kNeurologicalViews[3] = {
    {"axial", 2, 0, 1, +1, -1, "L", "R", "A", "P"},
    {"coronal", 1, 0, 2, +1, -1, "L", "R", "S", "I"},
    {"sagittal", 0, 1, 2, -1, -1, "A", "P", "S", "I"},
};
// Radiological order: the patient's right on the screen's left, as if facing
// the patient (CT and most radiology viewers).
const ViewSpec kRadiologicalViews[3] = {
    {"axial", 2, 0, 1, -1, -1, "R", "L", "A", "P"},
    {"coronal", 1, 0, 2, -1, -1, "R", "L", "S", "I"},
    {"sagittal", 0, 1, 2, -1, -1, "A", "P", "S", "I"},
};
const char* kWorldName[3] = {"x", "y", "z"};

struct Canvas {
  RgbImage* img;
  void set(int x, int y, const uint8_t* c) {
    if (x < 0 || y < 0 || x >= img->width || y >= img->height) return;
    uint8_t* p = &img->rgb[(size_t(y) * size_t(img->width) + size_t(x)) * 3];
    p[0] = c[0];
    p[1] = c[1];
    p[2] = c[2];
  }
  // Text with stb_easy_font (quads of `scale` pixels) and a dark shadow.
  void text(int x, int y, const std::string& s, const uint8_t* c, int scale) {
    std::string ascii;
    for (char ch : s) ascii += (ch >= 32 && ch < 127) ? ch : '?';
    std::vector<char> buf(ascii.begin(), ascii.end());
    buf.push_back('\0');
    std::vector<char> vb(ascii.size() * 300 + 64);
    const int quads = stb_easy_font_print(0, 0, buf.data(), nullptr, vb.data(), int(vb.size()));
    static const uint8_t shadow[3] = {0, 0, 0};
    for (int pass = 0; pass < 2; ++pass) {
      const int off = pass == 0 ? 1 : 0;
      for (int q = 0; q < quads; ++q) {
        float v0[2], v2[2];
        std::memcpy(v0, vb.data() + size_t(q) * 64, 8);
        std::memcpy(v2, vb.data() + size_t(q) * 64 + 32, 8);
        const int x0 = x + int(std::lround(std::min(v0[0], v2[0]) * scale)) + off;
        const int x1 = x + int(std::lround(std::max(v0[0], v2[0]) * scale)) + off;
        const int y0 = y + int(std::lround(std::min(v0[1], v2[1]) * scale)) + off;
        const int y1 = y + int(std::lround(std::max(v0[1], v2[1]) * scale)) + off;
        for (int yy = y0; yy < y1; ++yy)
          for (int xx = x0; xx < x1; ++xx) set(xx, yy, pass == 0 ? shadow : c);
      }
    }
  }
};

int text_width(const std::string& s, int scale) {
  std::vector<char> buf;
  for (char ch : s) buf.push_back((ch >= 32 && ch < 127) ? ch : '?');
  buf.push_back('\0');
  return stb_easy_font_width(buf.data()) * scale;
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

}  // namespace

const char* overlay_view_name(OverlayView v) {
  return v == OverlayView::Neurological ? "neurological" : "radiological";
}

bool overlay_view_from_name(const std::string& name, OverlayView* v) {
  if (name == "radiological") *v = OverlayView::Radiological;
  else if (name == "neurological") *v = OverlayView::Neurological;
  else return false;
  return true;
}

void overlay_palette(size_t k, uint8_t rgb[3]) {
  static const uint8_t pal[12][3] = {
      {255, 40, 40},  {40, 220, 40},  {60, 140, 255}, {255, 60, 255}, {0, 230, 230},   {255, 140, 0},
      {170, 110, 255}, {160, 255, 120}, {255, 150, 170}, {0, 150, 130}, {140, 90, 40}, {255, 255, 255}};
  std::memcpy(rgb, pal[k % 12], 3);
}

namespace {
const uint8_t kTruthRgb[3] = {255, 215, 0};  // yellow: no object's colour
}

void overlay_truth_colour(uint8_t rgb[3]) { std::memcpy(rgb, kTruthRgb, 3); }

void percentile_window(const std::function<double(size_t)>& value, size_t n, double q_lo,
                       double q_hi, double* lo, double* hi) {
  const size_t cap = size_t(2) << 20;
  const size_t stride = n > cap ? (n + cap - 1) / cap : 1;
  std::vector<double> s;
  s.reserve(n / stride + 1);
  for (size_t i = 0; i < n; i += stride) {
    const double v = value(i);
    if (std::isfinite(v)) s.push_back(v);
  }
  if (s.empty()) {
    *lo = 0;
    *hi = 1;
    return;
  }
  const auto at = [&](double q) {
    q = std::min(1.0, std::max(0.0, q));
    const size_t k = size_t(std::floor(q * double(s.size() - 1) + 0.5));
    std::nth_element(s.begin(), s.begin() + std::ptrdiff_t(k), s.end());
    return s[k];
  };
  *lo = at(q_lo);
  *hi = at(q_hi);
  if (!(*hi > *lo)) *hi = *lo + 1;
}

bool overlay_render(const OverlayVolume& vol, const std::vector<OverlayObject>& objects,
                    RgbImage* out, std::string* err) {
  for (int a = 0; a < 3; ++a)
    if (vol.dims[a] < 1 || !(vol.spacing[a] > 0) || !std::isfinite(vol.spacing[a])) {
      if (err) *err = "overlay: bad grid";
      return false;
    }
  if (!vol.value) {
    if (err) *err = "overlay: no intensities";
    return false;
  }
  for (const OverlayObject& o : objects)
    if (!o.mask) {
      if (err) *err = "overlay: object '" + o.name + "' has no mask";
      return false;
    }
  const Orientation ori = orientation_of(vol.index_to_world);
  const ViewSpec* kViews = vol.view == OverlayView::Neurological ? kNeurologicalViews : kRadiologicalViews;

  // Square pixels of pix_mm, enlarged for small grids, reduced for huge ones.
  double base = std::min({vol.spacing[0], vol.spacing[1], vol.spacing[2]});
  double max_mm = 0;
  for (int a = 0; a < 3; ++a) max_mm = std::max(max_mm, vol.dims[a] * vol.spacing[a]);
  int factor = 1;
  while (max_mm / base * factor < 320 && factor < 8) ++factor;
  double pix_mm = base / factor;
  if (max_mm / pix_mm > 900) pix_mm = max_mm / 900;
  const auto extent_px = [&](int voxel_axis) {
    return std::max(1, int(std::lround(vol.dims[voxel_axis] * vol.spacing[voxel_axis] / pix_mm)));
  };

  int pw[3], ph[3];
  for (int v = 0; v < 3; ++v) {
    pw[v] = extent_px(ori.voxel_axis_of_world[kViews[v].wu]);
    ph[v] = extent_px(ori.voxel_axis_of_world[kViews[v].wv]);
  }
  const int panel_h = std::max({ph[0], ph[1], ph[2]});
  const int ts = panel_h >= 200 ? 2 : 1;  // text scale
  const int margin = 8, gap = 8, header = 12 * ts + 8;
  const int lw = panel_h >= 350 ? 2 : 1;  // contour half-width in pixels

  // One row per object (or one through the grid centre if none).
  std::vector<std::array<int, 3>> centres;
  for (const OverlayObject& o : objects) {
    std::array<int, 3> c;
    for (int a = 0; a < 3; ++a) c[a] = std::min(vol.dims[a] - 1, std::max(0, o.center_ijk[a]));
    centres.push_back(c);
  }
  if (centres.empty()) centres.push_back({vol.dims[0] / 2, vol.dims[1] / 2, vol.dims[2] / 2});
  const int rows = int(centres.size());

  RgbImage& img = *out;
  img.width = margin * 2 + pw[0] + pw[1] + pw[2] + gap * 2;
  img.height = margin + rows * (header + panel_h + margin);
  img.rgb.assign(size_t(img.width) * size_t(img.height) * 3, 24);
  Canvas cv{&img};

  const double lo = vol.window_lo, hi = vol.window_hi > vol.window_lo ? vol.window_hi : vol.window_lo + 1;
  const size_t nobj = objects.size();
  const int64_t sj = vol.dims[0], sk = int64_t(vol.dims[0]) * vol.dims[1];
  static const uint8_t white[3] = {235, 235, 235};
  static const uint8_t grey_text[3] = {190, 190, 190};

  std::vector<uint8_t> pmask;  // per object, panel-sized
  for (int r = 0; r < rows; ++r) {
    const std::array<int, 3>& c = centres[size_t(r)];
    const int y_top = margin + r * (header + panel_h + margin);
    // Row header: the object's name in its colour and the centre in mm.
    double world[3];
    for (int w = 0; w < 3; ++w)
      world[w] = vol.index_to_world[4 * w] * c[0] + vol.index_to_world[4 * w + 1] * c[1] +
                 vol.index_to_world[4 * w + 2] * c[2] + vol.index_to_world[4 * w + 3];
    std::string head = objects.empty() ? std::string("grid centre") : objects[size_t(r)].name;
    head += "   slices through voxel (" + std::to_string(c[0]) + ", " + std::to_string(c[1]) + ", " +
            std::to_string(c[2]) + ") = (" + fmt("%.1f", world[0]) + ", " + fmt("%.1f", world[1]) +
            ", " + fmt("%.1f", world[2]) + ") mm";
    cv.text(margin, y_top + 4, head, objects.empty() ? white : objects[size_t(r)].rgb, ts);

    int x0 = margin;
    for (int v = 0; v < 3; ++v) {
      const ViewSpec& V = kViews[v];
      const int au = ori.voxel_axis_of_world[V.wu], av = ori.voxel_axis_of_world[V.wv];
      const int as = ori.voxel_axis_of_world[V.ws];
      const bool flip_u = V.du * ori.sign_of_world[V.wu] < 0;
      const bool flip_v = V.dv * ori.sign_of_world[V.wv] < 0;
      const int W = pw[v], H = ph[v];
      const int y0 = y_top + header;
      // Pixel -> voxel index along the panel's axes.
      std::vector<int> iu(static_cast<size_t>(W)), iv(static_cast<size_t>(H));
      for (int x = 0; x < W; ++x) {
        int i = int(std::lround((x + 0.5) * pix_mm / vol.spacing[au] - 0.5));
        i = std::min(vol.dims[au] - 1, std::max(0, i));
        iu[size_t(x)] = flip_u ? vol.dims[au] - 1 - i : i;
      }
      for (int y = 0; y < H; ++y) {
        int i = int(std::lround((y + 0.5) * pix_mm / vol.spacing[av] - 0.5));
        i = std::min(vol.dims[av] - 1, std::max(0, i));
        iv[size_t(y)] = flip_v ? vol.dims[av] - 1 - i : i;
      }
      const auto linear = [&](int x, int y) {
        int ijk[3];
        ijk[au] = iu[size_t(x)];
        ijk[av] = iv[size_t(y)];
        ijk[as] = c[size_t(as)];
        return size_t(ijk[0] + sj * ijk[1] + sk * ijk[2]);
      };
      pmask.assign(size_t(W) * size_t(H) * nobj, 0);
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const size_t idx = linear(x, y);
          double g = (vol.value(idx) - lo) / (hi - lo);
          g = std::isfinite(g) ? std::min(1.0, std::max(0.0, g)) : 0.0;
          double px[3] = {g * 255, g * 255, g * 255};
          for (size_t o = nobj; o-- > 0;) {
            const bool in = objects[o].mask[idx] != 0;
            pmask[o * size_t(W) * size_t(H) + size_t(y) * size_t(W) + size_t(x)] = in;
            if (in)
              for (int ch = 0; ch < 3; ++ch) px[ch] = 0.88 * px[ch] + 0.12 * objects[o].rgb[ch];
          }
          const uint8_t col[3] = {uint8_t(std::lround(px[0])), uint8_t(std::lround(px[1])),
                                  uint8_t(std::lround(px[2]))};
          cv.set(x0 + x, y0 + y, col);
        }
      // The reference contour of this row's object: yellow dashes straddling
      // its boundary like the object contours, drawn under them.
      if (!objects.empty() && objects[size_t(r)].truth) {
        const uint8_t* yellow = kTruthRgb;
        const uint8_t* tm = objects[size_t(r)].truth;
        std::vector<uint8_t> tin(size_t(W) * size_t(H));
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) tin[size_t(y) * size_t(W) + size_t(x)] = tm[linear(x, y)] != 0;
        const auto at = [&](int x, int y) {
          return x >= 0 && y >= 0 && x < W && y < H && tin[size_t(y) * size_t(W) + size_t(x)];
        };
        const int dash = 4 * lw + 2;
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) {
            if ((x + y) % (2 * dash) >= dash + dash / 2) continue;  // gaps a third of the period
            const bool in = at(x, y);
            const int rr = in ? lw : lw - 1;
            bool edge = false;
            for (int dy = -rr; dy <= rr && !edge; ++dy)
              for (int dx = -rr; dx <= rr && !edge; ++dx)
                if (at(x + dx, y + dy) != in) edge = true;
            if (edge) cv.set(x0 + x, y0 + y, yellow);
          }
      }
      // Contours: pixels with a pixel of the other side within lw (Chebyshev),
      // so the line straddles the boundary; the lowest index is drawn last,
      // so it is on top where objects touch.
      for (size_t o = nobj; o-- > 0;) {
        const uint8_t* m = &pmask[o * size_t(W) * size_t(H)];
        const auto at = [&](int x, int y) {
          return x >= 0 && y >= 0 && x < W && y < H && m[size_t(y) * size_t(W) + size_t(x)];
        };
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) {
            const bool in = m[size_t(y) * size_t(W) + size_t(x)] != 0;
            const int r = in ? lw : lw - 1;  // lw pixels inside, lw - 1 outside
            bool edge = false;
            for (int dy = -r; dy <= r && !edge; ++dy)
              for (int dx = -r; dx <= r && !edge; ++dx)
                if (at(x + dx, y + dy) != in) edge = true;
            if (edge) cv.set(x0 + x, y0 + y, objects[o].rgb);
          }
      }
      // Labels: view and slice position, orientation letters at the edges.
      const double slice_mm = world[V.ws];
      cv.text(x0 + 4, y0 + 4,
              std::string(V.title) + " " + kWorldName[V.ws] + "=" + fmt("%.1f", slice_mm) + " mm",
              grey_text, ts);
      const int th = 7 * ts;
      cv.text(x0 + 4, y0 + H / 2 - th / 2, V.left, white, ts);
      cv.text(x0 + W - 4 - text_width(V.right, ts), y0 + H / 2 - th / 2, V.right, white, ts);
      cv.text(x0 + W / 2 - text_width(V.top, ts) / 2, y0 + 4 + 12 * ts + 4, V.top, white, ts);
      cv.text(x0 + W / 2 - text_width(V.bottom, ts) / 2, y0 + H - 4 - th, V.bottom, white, ts);
      x0 += W + gap;
    }
  }
  return true;
}

bool png_write_file(const std::string& path, const RgbImage& img, std::string* err) {
  if (img.width < 1 || img.height < 1 ||
      img.rgb.size() != size_t(img.width) * size_t(img.height) * 3) {
    if (err) *err = "png: empty or inconsistent image";
    return false;
  }
  errno = 0;
  if (!stbi_write_png(path.c_str(), img.width, img.height, 3, img.rgb.data(), img.width * 3)) {
    if (err) *err = "cannot write " + path + (errno ? std::string(": ") + std::strerror(errno) : "");
    return false;
  }
  return true;
}

}  // namespace ffseg_tools
