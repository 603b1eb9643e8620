#include "support/stored_variants.h"

#include <cstring>
#include <functional>

#include <doctest/doctest.h>

#include "test_util.h"

namespace ffseg_test {

namespace {

size_t bytes_of(uint32_t type) {
  switch (type) {
    case FFSEG_U8: return 1;
    case FFSEG_I16:
    case FFSEG_U16: return 2;
    case FFSEG_I32:
    case FFSEG_F32: return 4;
    default: return 8;
  }
}

void store(uint32_t type, double x, uint8_t* out) {
  switch (type) {
    case FFSEG_U8: *out = uint8_t(x); return;
    case FFSEG_I16: { const int16_t v = int16_t(x); std::memcpy(out, &v, 2); return; }
    case FFSEG_U16: { const uint16_t v = uint16_t(x); std::memcpy(out, &v, 2); return; }
    case FFSEG_I32: { const int32_t v = int32_t(x); std::memcpy(out, &v, 4); return; }
    case FFSEG_F32: { const float v = float(x); std::memcpy(out, &v, 4); return; }
    default: std::memcpy(out, &x, 8); return;
  }
}

}  // namespace

ffseg_volume StoredVariant::volume() const {
  ffseg_volume v = make_volume(data.data(), type, dims, A);
  v.rescale_slope = rescale_slope;
  v.rescale_intercept = rescale_intercept;
  return v;
}

std::vector<uint8_t> StoredVariant::to_original_grid(const std::vector<uint8_t>& mask) const {
  std::vector<uint8_t> back(to_original.size(), 0);
  for (size_t q = 0; q < mask.size() && q < to_original.size(); ++q) back[to_original[q]] = mask[q];
  return back;
}

std::vector<StoredVariant> stored_variants(const int64_t d[3], const double A0[16], const std::vector<double>& raw,
                                           uint32_t type, double slope, double intercept) {
  const size_t N = raw.size();
  auto idx = [&](int64_t i, int64_t j, int64_t k) { return size_t(i + d[0] * (j + d[1] * k)); };
  std::vector<StoredVariant> out;
  // src: variant voxel -> original voxel; a variant type other than the
  // original's stores the rescaled value with slope 1, intercept 0.
  auto make = [&](const char* name, const int64_t vd[3],
                  const std::function<void(int64_t, int64_t, int64_t, int64_t*)>& src, const double A[16],
                  uint32_t vtype) {
    StoredVariant v;
    v.name = name;
    for (int a = 0; a < 3; ++a) v.dims[a] = vd[a];
    std::memcpy(v.A, A, sizeof v.A);
    v.type = vtype;
    const bool same_type = vtype == type;
    v.rescale_slope = same_type ? slope : 1;
    v.rescale_intercept = same_type ? intercept : 0;
    const size_t b = bytes_of(vtype);
    v.data.assign(N * b, 0);
    v.to_original.resize(N);
    size_t q = 0;
    for (int64_t k = 0; k < vd[2]; ++k)
      for (int64_t j = 0; j < vd[1]; ++j)
        for (int64_t i = 0; i < vd[0]; ++i, ++q) {
          int64_t o[3];
          src(i, j, k, o);
          const size_t oq = idx(o[0], o[1], o[2]);
          v.to_original[q] = oq;
          store(vtype, same_type ? raw[oq] : slope * raw[oq] + intercept, &v.data[b * q]);
        }
    out.push_back(std::move(v));
  };
  auto identity = [](int64_t i, int64_t j, int64_t k, int64_t* o) { o[0] = i, o[1] = j, o[2] = k; };
  make("as stored", d, identity, A0, type);
  for (int ax = 0; ax < 3; ++ax) {
    static const char* names[3] = {"flip i", "flip j", "flip k"};
    // world = A0 i with i_ax = D_ax - 1 - i'_ax: column ax negated, origin moved.
    double A[16];
    std::memcpy(A, A0, sizeof A);
    for (int r = 0; r < 3; ++r) {
      A[4 * r + 3] += A0[4 * r + ax] * double(d[ax] - 1);
      A[4 * r + ax] = -A0[4 * r + ax];
    }
    make(names[ax], d,
         [&, ax](int64_t i, int64_t j, int64_t k, int64_t* o) {
           identity(i, j, k, o);
           o[ax] = d[ax] - 1 - o[ax];
         },
         A, type);
  }
  {
    // Variant axes (a, b, c) = original (j, k, i): variant voxel (a, b, c) is original (c, a, b).
    const int64_t pd[3] = {d[1], d[2], d[0]};
    double A[16] = {};
    for (int r = 0; r < 3; ++r) {
      A[4 * r + 0] = A0[4 * r + 1];
      A[4 * r + 1] = A0[4 * r + 2];
      A[4 * r + 2] = A0[4 * r + 0];
      A[4 * r + 3] = A0[4 * r + 3];
    }
    A[15] = 1;
    make("permute (j,k,i)", pd, [](int64_t a, int64_t b, int64_t c, int64_t* o) { o[0] = c, o[1] = a, o[2] = b; },
         A, type);
  }
  if (type != FFSEG_F32) make("f32", d, identity, A0, FFSEG_F32);
  if (type != FFSEG_F64) make("f64", d, identity, A0, FFSEG_F64);
  return out;
}

std::vector<uint8_t> segment_variant(const StoredVariant& v, const double c[3], double r, uint32_t n,
                                     int max_steps) {
  EngineBox eb(1, n, int64_t(1) << 23);
  REQUIRE(eb.e != nullptr);
  ffseg_params p;
  ffseg_params_init_default(&p);
  p.target_mode = FFSEG_TARGET_INTENSITY;
  REQUIRE(ffseg_set_params(eb.e, &p) == FFSEG_OK);
  const ffseg_volume vol = v.volume();
  REQUIRE(ffseg_set_volume(eb.e, &vol) == FFSEG_OK);
  REQUIRE(ffseg_init_sphere(eb.e, 0, c, r) == FFSEG_OK);
  for (int s = 0; s < max_steps; ++s) {
    const ffseg_status st = ffseg_step(eb.e, nullptr);
    REQUIRE(st >= 0);
    if (st != FFSEG_OK) break;  // at rest
  }
  std::vector<uint8_t> mask(size_t(v.dims[0] * v.dims[1] * v.dims[2]));
  REQUIRE(ffseg_rasterize(eb.e, 0, mask.data(), nullptr) == FFSEG_OK);
  return v.to_original_grid(mask);
}

size_t differing_voxels(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) n += (a[i] != 0) != (b[i] != 0);
  return n + (a.size() > b.size() ? a.size() - b.size() : b.size() - a.size());
}

}  // namespace ffseg_test
