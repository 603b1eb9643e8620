// ffseg tools: mesh contours on slice planes (slice_contours.h).
#include "slice_contours.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace ffseg_tools {

namespace {
uint64_t edge_key(uint32_t a, uint32_t b) {
    if (a > b) std::swap(a, b);
    return uint64_t(a) << 32 | b;
}
}  // namespace

bool plane_contours(const float* xyz, size_t nv, const uint32_t* tris, size_t nt, const double n[3], double d,
                    std::vector<Polygon>* out, std::string* err) {
    out->clear();
    std::vector<double> s(nv);
    for (size_t v = 0; v < nv; ++v)
        s[v] = n[0] * double(xyz[3 * v]) + n[1] * double(xyz[3 * v + 1]) + n[2] * double(xyz[3 * v + 2]) - d;
    const auto above = [&](uint32_t v) { return s[v] >= 0; };
    // Each crossed edge meets the two edges it is joined to through its two
    // triangles.
    std::unordered_map<uint64_t, std::array<uint64_t, 2>> next;
    std::unordered_map<uint64_t, int> degree;
    for (size_t t = 0; t < nt; ++t) {
        const uint32_t* v = tris + 3 * t;
        uint64_t cut[2];
        int m = 0;
        for (int e = 0; e < 3; ++e) {
            const uint32_t a = v[e], b = v[(e + 1) % 3];
            if (above(a) != above(b) && m < 2) cut[m++] = edge_key(a, b);
        }
        if (m != 2) continue;
        for (int q = 0; q < 2; ++q) {
            int& deg = degree[cut[q]];
            if (deg >= 2) {
                *err = "the mesh is not closed: an edge belongs to more than two triangles";
                return false;
            }
            next[cut[q]][size_t(deg++)] = cut[1 - q];
        }
    }
    for (const auto& e : degree)
        if (e.second != 2) {
            *err = "the mesh is not closed: a cut edge belongs to one triangle only";
            return false;
        }
    const auto point = [&](uint64_t key) {
        const uint32_t a = uint32_t(key >> 32), b = uint32_t(key & 0xffffffffu);
        const double t = s[a] / (s[a] - s[b]);
        std::array<double, 3> p;
        for (int c = 0; c < 3; ++c) p[size_t(c)] = double(xyz[3 * a + c]) + t * (double(xyz[3 * b + c]) - double(xyz[3 * a + c]));
        return p;
    };
    // Walk each cycle once, in the order of the first edges met.
    std::vector<uint64_t> keys;
    keys.reserve(degree.size());
    for (const auto& e : degree) keys.push_back(e.first);
    std::sort(keys.begin(), keys.end());
    std::unordered_map<uint64_t, bool> seen;
    for (uint64_t start : keys) {
        if (seen[start]) continue;
        Polygon poly;
        uint64_t prev = ~uint64_t(0), cur = start;
        do {
            seen[cur] = true;
            const std::array<double, 3> p = point(cur);
            // A cut through a vertex gives the same point twice in a row.
            if (poly.empty() || p != poly.back()) poly.push_back(p);
            const std::array<uint64_t, 2>& nb = next[cur];
            const uint64_t to = nb[0] != prev ? nb[0] : nb[1];
            prev = cur;
            cur = to;
        } while (cur != start);
        if (poly.size() > 1 && poly.front() == poly.back()) poly.pop_back();
        if (poly.size() >= 3) out->push_back(std::move(poly));
    }
    return true;
}

bool grid_slice_contours(const float* xyz, size_t nv, const uint32_t* tris, size_t nt, const NiftiImage& grid,
                         std::vector<SliceContour>* out, std::string* err) {
    out->clear();
    const double* A = grid.index_to_world;
    const double u[3] = {A[0], A[4], A[8]}, w[3] = {A[1], A[5], A[9]};
    double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(len > 0)) {
        *err = "the grid's i and j axes are parallel: no slice plane";
        return false;
    }
    for (double& c : n) c /= len;
    // The mesh's extent along the normal: only the slices within it are cut.
    double lo = HUGE_VAL, hi = -HUGE_VAL;
    for (size_t v = 0; v < nv; ++v) {
        const double p = n[0] * xyz[3 * v] + n[1] * xyz[3 * v + 1] + n[2] * xyz[3 * v + 2];
        lo = std::min(lo, p);
        hi = std::max(hi, p);
    }
    for (int k = 0; k < grid.dims[2]; ++k) {
        const double d = n[0] * (A[2] * k + A[3]) + n[1] * (A[6] * k + A[7]) + n[2] * (A[10] * k + A[11]);
        if (d < lo || d > hi) continue;
        std::vector<Polygon> polys;
        if (!plane_contours(xyz, nv, tris, nt, n, d, &polys, err)) return false;
        for (Polygon& p : polys) out->push_back({k, std::move(p)});
    }
    return true;
}

}  // namespace ffseg_tools
