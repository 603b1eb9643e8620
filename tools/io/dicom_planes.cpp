// ffseg tools: a grid's slices in DICOM terms (dicom_planes.h).
#include "dicom_planes.h"

#include <cmath>
#include <cstdio>

#include "image_common.h"

namespace ffseg_tools {

bool dicom_planes(const NiftiImage& grid, DicomPlanes* out, std::string* err) {
    if (grid.dims[0] > 65535 || grid.dims[1] > 65535) {
        *err = "more than 65535 rows or columns: DICOM frames cannot hold them";
        return false;
    }
    double axis[3][3], origin[3];
    img::lps_geometry(grid, axis, origin);
    const double li = std::sqrt(axis[0][0] * axis[0][0] + axis[0][1] * axis[0][1] + axis[0][2] * axis[0][2]);
    const double lj = std::sqrt(axis[1][0] * axis[1][0] + axis[1][1] * axis[1][1] + axis[1][2] * axis[1][2]);
    for (int c = 0; c < 3; ++c) {
        out->row_dir[c] = axis[0][c] / li;
        out->col_dir[c] = axis[1][c] / lj;
    }
    const double cosine = out->row_dir[0] * out->col_dir[0] + out->row_dir[1] * out->col_dir[1] + out->row_dir[2] * out->col_dir[2];
    if (!(std::fabs(cosine) < 1e-4)) {
        *err = "the grid's i and j axes are not orthogonal (a sheared grid): DICOM slices cannot describe it";
        return false;
    }
    out->col_spacing = li;
    out->row_spacing = lj;
    const double* r = out->row_dir;
    const double* c = out->col_dir;
    const double n[3] = {r[1] * c[2] - r[2] * c[1], r[2] * c[0] - r[0] * c[2], r[0] * c[1] - r[1] * c[0]};
    out->slice_thickness = std::fabs(n[0] * axis[2][0] + n[1] * axis[2][1] + n[2] * axis[2][2]);
    out->positions.resize(size_t(grid.dims[2]));
    for (int k = 0; k < grid.dims[2]; ++k)
        for (int q = 0; q < 3; ++q) out->positions[size_t(k)][size_t(q)] = origin[q] + double(k) * axis[2][q];
    return true;
}

std::string dicom_ds(double v) {
    if (v == 0) return "0";
    char b[32];
    for (int digits = 12; digits > 1; --digits) {
        std::snprintf(b, sizeof b, "%.*g", digits, v);
        if (std::string(b).size() <= 16) return b;
    }
    return b;
}

std::string dicom_ds_list(const double* v, size_t n) {
    std::string s;
    for (size_t q = 0; q < n; ++q) {
        if (q) s += '\\';
        s += dicom_ds(v[q]);
    }
    return s;
}

}  // namespace ffseg_tools
