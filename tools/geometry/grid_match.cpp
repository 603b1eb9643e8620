// ffseg tools: voxel-centre matching of two grids (grid_match.h).
#include "grid_match.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace ffseg_tools {
namespace {

void centre(const double A[16], const double ijk[3], double w[3]) {
    for (int r = 0; r < 3; ++r) w[r] = A[4 * r] * ijk[0] + A[4 * r + 1] * ijk[1] + A[4 * r + 2] * ijk[2] + A[4 * r + 3];
}

std::string dims_text(const int d[3]) {
    return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

// The other grid's index of reference voxel ijk under m.
void other_index(const NiftiImage& other, const AxisMap& m, const double ijk[3], double out[3]) {
    for (int a = 0; a < 3; ++a) {
        const int c = m.axis[a];
        out[c] = m.reversed[a] ? double(other.dims[c] - 1) - ijk[a] : ijk[a];
    }
}

// The largest distance (mm) between the centres ref and other give the
// eight corner voxels under m; *where the first corner at that distance.
double corner_gap(const NiftiImage& ref, const NiftiImage& other, const AxisMap& m, int where[3]) {
    double worst = -1;
    for (int corner = 0; corner < 8; ++corner) {
        double ijk[3], oijk[3], a[3], b[3];
        for (int d = 0; d < 3; ++d) ijk[d] = (corner >> d & 1) ? double(ref.dims[d] - 1) : 0.0;
        other_index(other, m, ijk, oijk);
        centre(ref.index_to_world, ijk, a);
        centre(other.index_to_world, oijk, b);
        const double g = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
        if (!(g <= worst)) {
            worst = std::isnan(g) ? HUGE_VAL : g;
            for (int d = 0; d < 3; ++d) where[d] = int(ijk[d]);
        }
    }
    return worst;
}

// other's voxel type, data and rescale on ref's grid description.
NiftiImage with_geometry_of(const NiftiImage& ref, const NiftiImage& other) {
    NiftiImage out = other;
    std::copy(ref.dims, ref.dims + 3, out.dims);
    std::memcpy(out.index_to_world, ref.index_to_world, sizeof out.index_to_world);
    std::copy(ref.spacing, ref.spacing + 3, out.spacing);
    std::copy(ref.pixdim, ref.pixdim + 8, out.pixdim);
    out.which_affine = ref.which_affine;
    out.sform_code = ref.sform_code;
    out.qform_code = ref.qform_code;
    out.raw_header.clear();
    return out;
}

}  // namespace

bool AxisMap::identity() const {
    for (int a = 0; a < 3; ++a)
        if (axis[a] != a || reversed[a]) return false;
    return true;
}

bool match_voxel_centres(const NiftiImage& ref, const NiftiImage& other, AxisMap* m, std::string* why) {
    int sr[3], so[3];
    std::copy(ref.dims, ref.dims + 3, sr);
    std::copy(other.dims, other.dims + 3, so);
    std::sort(sr, sr + 3);
    std::sort(so, so + 3);
    if (!std::equal(sr, sr + 3, so)) {
        *why = "dimensions differ (" + dims_text(ref.dims) + " vs " + dims_text(other.dims) + ")";
        return false;
    }
    const double tol = kCentreTolerance * std::min({ref.spacing[0], ref.spacing[1], ref.spacing[2]});
    static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    double best = HUGE_VAL;
    AxisMap best_map;
    int best_where[3] = {0, 0, 0};
    for (const auto& p : perms) {
        if (other.dims[p[0]] != ref.dims[0] || other.dims[p[1]] != ref.dims[1] || other.dims[p[2]] != ref.dims[2]) continue;
        for (int flips = 0; flips < 8; ++flips) {
            // A reversed axis of one voxel is the same axis: tried once.
            if ((flips & 1 && ref.dims[0] == 1) || (flips & 2 && ref.dims[1] == 1) || (flips & 4 && ref.dims[2] == 1)) continue;
            AxisMap c;
            for (int a = 0; a < 3; ++a) {
                c.axis[a] = p[a];
                c.reversed[a] = flips >> a & 1;
            }
            int where[3] = {0, 0, 0};
            const double g = corner_gap(ref, other, c, where);
            if (g < best) {
                best = g;
                best_map = c;
                std::copy(where, where + 3, best_where);
            }
        }
    }
    if (best <= tol) {
        *m = best_map;
        return true;
    }
    char b[320];
    double ijk[3] = {double(best_where[0]), double(best_where[1]), double(best_where[2])}, oijk[3], wa[3], wb[3];
    other_index(other, best_map, ijk, oijk);
    centre(ref.index_to_world, ijk, wa);
    centre(other.index_to_world, oijk, wb);
    std::snprintf(b, sizeof b,
                  "voxel centres differ (%s vs %s): in the closest storage order voxel (%d, %d, %d) is at "
                  "(%.6g, %.6g, %.6g) vs (%.6g, %.6g, %.6g) mm, %.4g mm apart (more than %g voxel)",
                  ref.which_affine.c_str(), other.which_affine.c_str(), best_where[0], best_where[1], best_where[2],
                  wa[0], wa[1], wa[2], wb[0], wb[1], wb[2], best, kCentreTolerance);
    *why = b;
    return false;
}

NiftiImage reindex_to(const NiftiImage& ref, const NiftiImage& other, const AxisMap& m) {
    NiftiImage out = with_geometry_of(ref, other);
    if (m.identity()) return out;
    const size_t bpv = size_t(other.bytes_per_voxel);
    // Step (in other's voxels) along each reference axis, and the start.
    const int64_t ostride[3] = {1, int64_t(other.dims[0]), int64_t(other.dims[0]) * other.dims[1]};
    int64_t step[3], start = 0;
    for (int a = 0; a < 3; ++a) {
        const int c = m.axis[a];
        step[a] = m.reversed[a] ? -ostride[c] : ostride[c];
        if (m.reversed[a]) start += int64_t(other.dims[c] - 1) * ostride[c];
    }
    uint8_t* dst = out.data.data();
    const uint8_t* src = other.data.data();
    size_t q = 0;
    for (int k = 0; k < ref.dims[2]; ++k)
        for (int j = 0; j < ref.dims[1]; ++j) {
            int64_t o = start + k * step[2] + j * step[1];
            for (int i = 0; i < ref.dims[0]; ++i, ++q, o += step[0])
                std::memcpy(dst + q * bpv, src + size_t(o) * bpv, bpv);
        }
    return out;
}

NiftiImage resample_nearest(const NiftiImage& ref, const NiftiImage& other, size_t* outside) {
    NiftiImage out = with_geometry_of(ref, other);
    const size_t bpv = size_t(other.bytes_per_voxel);
    out.data.assign(size_t(ref.voxel_count()) * bpv, 0);
    // other's world -> index: the inverse of its 3x3 part.
    const double* A = other.index_to_world;
    const double a = A[0], b = A[1], c = A[2], d = A[4], e = A[5], f = A[6], g = A[8], h = A[9], i = A[10];
    const double det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    const double inv[9] = {(e * i - f * h) / det,  -(b * i - c * h) / det, (b * f - c * e) / det,
                           -(d * i - f * g) / det, (a * i - c * g) / det,  -(a * f - c * d) / det,
                           (d * h - e * g) / det,  -(a * h - b * g) / det, (a * e - b * d) / det};
    size_t n_out = 0, q = 0;
    for (int k = 0; k < ref.dims[2]; ++k)
        for (int j = 0; j < ref.dims[1]; ++j)
            for (int ii = 0; ii < ref.dims[0]; ++ii, ++q) {
                const double ijk[3] = {double(ii), double(j), double(k)};
                double w[3];
                centre(ref.index_to_world, ijk, w);
                const double p[3] = {w[0] - A[3], w[1] - A[7], w[2] - A[11]};
                int64_t o = 0, mult = 1;
                bool in = true;
                for (int r = 0; r < 3; ++r) {
                    const double x = inv[3 * r] * p[0] + inv[3 * r + 1] * p[1] + inv[3 * r + 2] * p[2];
                    const double rx = std::floor(x + 0.5);
                    if (!(rx >= 0 && rx <= double(other.dims[r] - 1))) {
                        in = false;
                        break;
                    }
                    o += int64_t(rx) * mult;
                    mult *= other.dims[r];
                }
                if (!in) {
                    ++n_out;
                    continue;
                }
                std::memcpy(out.data.data() + q * bpv, other.data.data() + size_t(o) * bpv, bpv);
            }
    if (outside) *outside = n_out;
    return out;
}

}  // namespace ffseg_tools
