// A validated, read-only view of the caller's voxel buffer: any of six types,
// any byte strides, a 4x4 index-to-world affine (voxel centres, mm) and a
// rescale slope/intercept. Nothing outside [data, data + bytes) is ever read.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "affine.h"

namespace ffseg {

enum class VoxelType : uint32_t { U8 = 1, I16 = 2, U16 = 3, I32 = 4, F32 = 5, F64 = 6 };

struct VolumeDesc {  // the caller's description, already copied out of the C struct
  uint32_t type;
  const void* data;
  uint64_t data_bytes;
  int64_t offset;
  int64_t dims[3];
  int64_t strides[3];
  double index_to_world[16];
  double slope, intercept;
};

class VolumeView {
 public:
  // Validates d; on failure writes a message and returns false (view unchanged).
  bool assign(const VolumeDesc& d, char* msg, size_t msg_len);

  bool valid() const { return origin_ != nullptr; }
  void reset() { origin_ = nullptr; }

  const int64_t* dims() const { return dims_; }
  int64_t voxel_count() const { return dims_[0] * dims_[1] * dims_[2]; }
  VoxelType type() const { return type_; }

  // Rescaled value of voxel (i,j,k); the indices must be inside the grid.
  double at(int64_t i, int64_t j, int64_t k) const {
    const unsigned char* p = origin_ + i * strides_[0] + j * strides_[1] + k * strides_[2];
    return slope_ * raw(p) + intercept_;
  }
  // Rescaled value, or `outside` beyond the grid.
  double at_or(int64_t i, int64_t j, int64_t k, double outside) const {
    if (i < 0 || j < 0 || k < 0 || i >= dims_[0] || j >= dims_[1] || k >= dims_[2]) return outside;
    return at(i, j, k);
  }

  // Calls f(t, value) for the n voxels (i, j, k) + t e_axis, t = 0 .. n-1, with
  // the value at() gives; all of them must be inside the grid. One type switch
  // per row instead of one per voxel.
  template <class F>
  void for_each_in_row(int64_t i, int64_t j, int64_t k, int axis, int64_t n, F&& f) const {
    const unsigned char* p = origin_ + i * strides_[0] + j * strides_[1] + k * strides_[2];
    const int64_t s = strides_[axis];
    switch (type_) {
      case VoxelType::U8: row_loop<uint8_t>(p, s, n, f); break;
      case VoxelType::I16: row_loop<int16_t>(p, s, n, f); break;
      case VoxelType::U16: row_loop<uint16_t>(p, s, n, f); break;
      case VoxelType::I32: row_loop<int32_t>(p, s, n, f); break;
      case VoxelType::F32: row_loop<float>(p, s, n, f); break;
      case VoxelType::F64: row_loop<double>(p, s, n, f); break;
    }
  }

  // Inline: the deformation maps every vertex, target or sample through
  // them, and a call each was as much work as the map.
  void world_to_index(const double w[3], double ijk[3]) const { affine_point(Ainv_, w, ijk); }
  void index_to_world(const double ijk[3], double w[3]) const { affine_point(A_, ijk, w); }
  // Direction in index space for a world-space direction (no translation).
  void world_dir_to_index(const double w[3], double ijk[3]) const { affine_direction(Ainv_, w, ijk); }

  double sample_nearest(const double w[3], double outside = 0.0) const;
  double sample_linear(const double w[3], double outside = 0.0) const;

  // Length in mm of one voxel step along each index axis.
  const double* spacing() const { return spacing_; }
  double min_spacing() const;
  // The largest: a voxel's extent for "more than a voxel away".
  double max_spacing() const;
  double slope() const { return slope_; }
  double intercept() const { return intercept_; }
  const double* affine() const { return A_; }      // 3x4 row-major
  // Raw access for typed inner loops: the address of voxel (0,0,0) and the strides.
  const unsigned char* origin() const { return origin_; }
  const int64_t* strides() const { return strides_; }
  const double* inverse() const { return Ainv_; }  // 3x4 row-major

  // The grid of cells of f[a] voxels along each index axis a: cell c holds
  // voxels f c .. f c + f - 1 (the last one may hold fewer), its centre lies at
  // voxel f c + (f - 1) / 2, and there are ceil(dims / f) of them. Geometry
  // only (world <-> index maps, spacing, dims): the view has no voxels, so
  // valid() is false and at() must not be called. For code that only maps
  // points, as the rasteriser does for a bounding region on coarser cells.
  VolumeView cell_geometry(const int64_t f[3]) const;

  // True when the ball (centre c, radius r in mm) meets the grid's box
  // [-0.5, dims - 0.5] in index space.
  bool ball_meets_grid(const double c[3], double r) const;

 private:
  double raw(const unsigned char* p) const;
  template <class T, class F>
  void row_loop(const unsigned char* p, int64_t s, int64_t n, F& f) const {
    for (int64_t t = 0; t < n; ++t, p += s) {
      T v;
      std::memcpy(&v, p, sizeof v);
      f(t, slope_ * double(v) + intercept_);
    }
  }

  VoxelType type_ = VoxelType::U8;
  const unsigned char* origin_ = nullptr;  // address of voxel (0,0,0)
  int64_t dims_[3] = {0, 0, 0};
  int64_t strides_[3] = {0, 0, 0};
  double A_[12] = {};
  double Ainv_[12] = {};
  double spacing_[3] = {0, 0, 0};
  double slope_ = 1, intercept_ = 0;
};

size_t voxel_type_size(uint32_t type);  // 0 for an unknown type

}  // namespace ffseg
