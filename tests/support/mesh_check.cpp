// Geometric validity checks for triangle meshes. See mesh_check.h.
//
// Triangle-triangle test: a plane/interval test in the spirit of Moller (1997),
// computed in double: each triangle is cut by the other's plane, both cuts are
// segments on the planes' common line, and the triangles meet iff the segments
// overlap. Coplanar pairs use a 2D closed-set overlap test with orientation
// predicates. Candidate pairs come from a uniform grid over bounding boxes; a
// pair is tested only in the cell that holds the maximum corner of the two box
// minima, so no pair is tested twice.
#include "mesh_check.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace ffseg_test {
namespace {

struct V3 {
  double x, y, z;
};
inline V3 operator-(const V3& a, const V3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator+(const V3& a, const V3& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator*(const V3& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(const V3& a, const V3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 cross(const V3& a, const V3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm(const V3& a) { return std::sqrt(dot(a, a)); }

inline V3 vtx(const float* xyz, uint32_t i) {
  return {double(xyz[3 * size_t(i)]), double(xyz[3 * size_t(i) + 1]), double(xyz[3 * size_t(i) + 2])};
}

// Relative tolerances (all scaled by the pair's longest edge).
constexpr double kPlaneEps = 1e-12;    // |signed distance| below this * L counts as on the plane
constexpr double kOverlapEps = 1e-9;   // overlap length beyond a shared vertex must exceed this * L
constexpr double kDegenEps = 1e-12;    // |cross| <= this * L^2: zero-area triangle

double max_edge(const V3 t[3]) {
  double l = 0.0;
  for (int i = 0; i < 3; ++i) l = std::max(l, norm(t[(i + 1) % 3] - t[i]));
  return l;
}

bool degenerate(const V3 t[3]) {
  double l = max_edge(t);
  return norm(cross(t[1] - t[0], t[2] - t[0])) <= kDegenEps * l * l;
}

// ---- 2D helpers (coplanar case) ----------------------------------------------
struct V2 {
  double u, v;
};
inline double orient2d(const V2& a, const V2& b, const V2& c) {
  return (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
}
inline int sgn(double x) { return (x > 0) - (x < 0); }

// c lies within the bounding box of segment ab (used when a, b, c are collinear)
inline bool in_box(const V2& a, const V2& b, const V2& c) {
  return std::min(a.u, b.u) <= c.u && c.u <= std::max(a.u, b.u) && std::min(a.v, b.v) <= c.v &&
         c.v <= std::max(a.v, b.v);
}

// Closed segments p1p2 and q1q2 intersect.
bool seg_seg_2d(const V2& p1, const V2& p2, const V2& q1, const V2& q2) {
  int o1 = sgn(orient2d(p1, p2, q1)), o2 = sgn(orient2d(p1, p2, q2));
  int o3 = sgn(orient2d(q1, q2, p1)), o4 = sgn(orient2d(q1, q2, p2));
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  if (o1 == 0 && in_box(p1, p2, q1)) return true;
  if (o2 == 0 && in_box(p1, p2, q2)) return true;
  if (o3 == 0 && in_box(q1, q2, p1)) return true;
  if (o4 == 0 && in_box(q1, q2, p2)) return true;
  return false;
}

// Closed triangle contains p (either winding).
bool point_in_tri_2d(const V2 t[3], const V2& p) {
  int s0 = sgn(orient2d(t[0], t[1], p)), s1 = sgn(orient2d(t[1], t[2], p)),
      s2 = sgn(orient2d(t[2], t[0], p));
  bool has_neg = s0 < 0 || s1 < 0 || s2 < 0;
  bool has_pos = s0 > 0 || s1 > 0 || s2 > 0;
  return !(has_neg && has_pos);
}

// Project onto the coordinate plane that drops the dominant normal axis.
void project(const V3 t[3], const V3& n, V2 out[3]) {
  double ax = std::fabs(n.x), ay = std::fabs(n.y), az = std::fabs(n.z);
  for (int i = 0; i < 3; ++i) {
    if (ax >= ay && ax >= az) out[i] = {t[i].y, t[i].z};
    else if (ay >= az) out[i] = {t[i].z, t[i].x};
    else out[i] = {t[i].x, t[i].y};
  }
}

bool coplanar_overlap(const V3 a[3], const V3 b[3], const V3& n) {
  V2 p[3], q[3];
  project(a, n, p);
  project(b, n, q);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (seg_seg_2d(p[i], p[(i + 1) % 3], q[j], q[(j + 1) % 3])) return true;
  return point_in_tri_2d(q, p[0]) || point_in_tri_2d(p, q[0]);
}

// Coplanar triangles a, b with a[0] == b[0] == origin (the shared vertex):
// do the open wedges at the origin overlap (i.e. the triangles share area)?
bool coplanar_wedges_overlap(const V3 a[3], const V3 b[3], const V3& n) {
  V2 p[3], q[3];
  project(a, n, p);
  project(b, n, q);
  // direction w strictly inside the wedge spanned by u1, u2 (angle < pi)
  auto strictly_inside = [](const V2& o, const V2& u1, const V2& u2, const V2& w) {
    int s = sgn(orient2d(o, u1, u2));
    return s != 0 && sgn(orient2d(o, u1, w)) == s && sgn(orient2d(o, w, u2)) == s;
  };
  auto same_ray = [](const V2& o, const V2& u, const V2& w) {
    return orient2d(o, u, w) == 0.0 &&
           (u.u - o.u) * (w.u - o.u) + (u.v - o.v) * (w.v - o.v) > 0.0;
  };
  for (int k = 1; k < 3; ++k) {
    if (strictly_inside(p[0], p[1], p[2], q[k])) return true;
    if (strictly_inside(q[0], q[1], q[2], p[k])) return true;
  }
  // identical wedges (both boundary rays coincide)
  if ((same_ray(p[0], p[1], q[1]) && same_ray(p[0], p[2], q[2])) ||
      (same_ray(p[0], p[1], q[2]) && same_ray(p[0], p[2], q[1])))
    return true;
  return false;
}

// Interval of triangle t cut by the plane with signed distances d (0 = on it),
// projected on the unit direction D.
void cut_interval(const V3 t[3], const double d[3], const V3& D, double* lo, double* hi) {
  double mn = std::numeric_limits<double>::infinity(), mx = -mn;
  for (int i = 0; i < 3; ++i) {
    if (d[i] == 0.0) {
      double s = dot(D, t[i]);
      mn = std::min(mn, s);
      mx = std::max(mx, s);
    }
    int j = (i + 1) % 3;
    if ((d[i] > 0 && d[j] < 0) || (d[i] < 0 && d[j] > 0)) {
      V3 p = t[i] + (t[j] - t[i]) * (d[i] / (d[i] - d[j]));
      double s = dot(D, p);
      mn = std::min(mn, s);
      mx = std::max(mx, s);
    }
  }
  *lo = mn;
  *hi = mx;
}

// Triangles a and b (non-degenerate, already translated near the origin).
// shared == true: a[0] and b[0] are the same vertex; the result is whether
// they intersect in more than that vertex. Otherwise: closed-set intersection.
bool tri_tri(const V3 a[3], const V3 b[3], bool shared) {
  const double L = std::max(max_edge(a), max_edge(b));
  const V3 n1 = cross(a[1] - a[0], a[2] - a[0]);
  const V3 n2 = cross(b[1] - b[0], b[2] - b[0]);
  const double ln1 = norm(n1), ln2 = norm(n2);

  double d2[3], d1[3];
  int pos = 0, neg = 0;
  for (int i = 0; i < 3; ++i) {
    d2[i] = dot(n1, b[i] - a[0]);
    if (std::fabs(d2[i]) <= kPlaneEps * ln1 * L) d2[i] = 0.0;
    pos += d2[i] > 0;
    neg += d2[i] < 0;
  }
  if (pos == 3 || neg == 3) return false;
  const bool coplanar = pos == 0 && neg == 0;

  const V3 Dn = cross(n1, n2);
  const double lD = norm(Dn);
  if (coplanar || lD <= kPlaneEps * ln1 * ln2) {
    return shared ? coplanar_wedges_overlap(a, b, n1) : coplanar_overlap(a, b, n1);
  }

  pos = neg = 0;
  for (int i = 0; i < 3; ++i) {
    d1[i] = dot(n2, a[i] - b[0]);
    if (std::fabs(d1[i]) <= kPlaneEps * ln2 * L) d1[i] = 0.0;
    pos += d1[i] > 0;
    neg += d1[i] < 0;
  }
  if (pos == 3 || neg == 3) return false;
  if (shared) {  // the shared vertex lies on both planes exactly
    d1[0] = 0.0;
    d2[0] = 0.0;
  }

  const V3 D = Dn * (1.0 / lD);
  double lo1, hi1, lo2, hi2;
  cut_interval(a, d1, D, &lo1, &hi1);
  cut_interval(b, d2, D, &lo2, &hi2);
  if (!(lo1 <= hi1) || !(lo2 <= hi2)) return false;  // empty cut (numerically inconsistent)
  const double overlap = std::min(hi1, hi2) - std::max(lo1, lo2);
  if (shared) return overlap > kOverlapEps * L;
  return overlap >= 0.0;
}

bool index_ok(const uint32_t* t, std::size_t nv) { return t[0] < nv && t[1] < nv && t[2] < nv; }

}  // namespace

SelfIntersectionReport check_self_intersections(const float* xyz, std::size_t nv,
                                                const uint32_t* tris, std::size_t nt,
                                                std::size_t max_pairs) {
  SelfIntersectionReport rep;
  for (std::size_t t = 0; t < nt; ++t)
    if (!index_ok(tris + 3 * t, nv)) throw std::out_of_range("check_self_intersections: vertex index >= nv");
  if (nt < 2) return rep;

  // Bounding boxes; degenerate triangles are left out of the grid.
  std::vector<std::array<double, 6>> box(nt);
  std::vector<uint8_t> skip(nt, 0);
  double gmin[3] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity()};
  double gmax[3] = {-gmin[0], -gmin[1], -gmin[2]};
  double ext_sum = 0.0;
  std::size_t n_live = 0;
  for (std::size_t t = 0; t < nt; ++t) {
    const uint32_t* f = tris + 3 * t;
    V3 v[3] = {vtx(xyz, f[0]), vtx(xyz, f[1]), vtx(xyz, f[2])};
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || degenerate(v) ||
        !std::isfinite(v[0].x + v[0].y + v[0].z + v[1].x + v[1].y + v[1].z + v[2].x + v[2].y + v[2].z)) {
      skip[t] = 1;
      ++rep.degenerate_triangles;
      continue;
    }
    auto& b = box[t];
    b = {std::min({v[0].x, v[1].x, v[2].x}), std::min({v[0].y, v[1].y, v[2].y}),
         std::min({v[0].z, v[1].z, v[2].z}), std::max({v[0].x, v[1].x, v[2].x}),
         std::max({v[0].y, v[1].y, v[2].y}), std::max({v[0].z, v[1].z, v[2].z})};
    for (int k = 0; k < 3; ++k) {
      gmin[k] = std::min(gmin[k], b[k]);
      gmax[k] = std::max(gmax[k], b[k + 3]);
    }
    ext_sum += std::max({b[3] - b[0], b[4] - b[1], b[5] - b[2]});
    ++n_live;
  }
  if (n_live < 2) return rep;

  // Grid: cell about the mean box extent, at most ~4 cells per triangle.
  double cell = std::max(ext_sum / double(n_live), 1e-30);
  const double span = std::max({gmax[0] - gmin[0], gmax[1] - gmin[1], gmax[2] - gmin[2], 1e-30});
  cell = std::max(cell, span / 1024.0);
  int gd[3];
  const double max_cells = 4.0 * double(n_live) + 64.0;
  for (;;) {
    double total = 1.0;
    for (int k = 0; k < 3; ++k) {
      gd[k] = int(std::floor((gmax[k] - gmin[k]) / cell)) + 1;
      total *= gd[k];
    }
    if (total <= max_cells) break;
    cell *= 1.26;
  }
  auto cell_of = [&](double c, int k) {
    int i = int(std::floor((c - gmin[k]) / cell));
    return std::min(std::max(i, 0), gd[k] - 1);
  };
  const std::size_t ncell = std::size_t(gd[0]) * gd[1] * gd[2];
  std::vector<uint32_t> start(ncell + 1, 0);
  std::vector<std::array<int, 6>> crange(nt);
  std::vector<uint32_t> items;
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<uint32_t> fill;
    if (pass == 1) fill.assign(start.begin(), start.end() - 1);
    for (std::size_t t = 0; t < nt; ++t) {
      if (skip[t]) continue;
      auto& r = crange[t];
      if (pass == 0)
        for (int k = 0; k < 3; ++k) {
          r[k] = cell_of(box[t][k], k);
          r[k + 3] = cell_of(box[t][k + 3], k);
        }
      for (int z = r[2]; z <= r[5]; ++z)
        for (int y = r[1]; y <= r[4]; ++y)
          for (int x = r[0]; x <= r[3]; ++x) {
            std::size_t c = (std::size_t(z) * gd[1] + y) * gd[0] + x;
            if (pass == 0) ++start[c + 1];
            else items[fill[c]++] = uint32_t(t);
          }
    }
    if (pass == 0) {
      for (std::size_t c = 0; c < ncell; ++c) start[c + 1] += start[c];
      items.assign(start[ncell], 0);
    }
  }

  auto record = [&](uint32_t a, uint32_t b) {
    if (rep.first_pairs.size() < max_pairs) rep.first_pairs.emplace_back(std::min(a, b), std::max(a, b));
  };

  for (std::size_t c = 0; c < ncell; ++c) {
    const uint32_t s = start[c], e = start[c + 1];
    if (e - s < 2) continue;
    const int cx = int(c % gd[0]), cy = int((c / gd[0]) % gd[1]), cz = int(c / (std::size_t(gd[0]) * gd[1]));
    for (uint32_t i = s; i < e; ++i) {
      const uint32_t ta = items[i];
      const auto& ba = box[ta];
      for (uint32_t j = i + 1; j < e; ++j) {
        const uint32_t tb = items[j];
        const auto& bb = box[tb];
        if (ba[0] > bb[3] || bb[0] > ba[3] || ba[1] > bb[4] || bb[1] > ba[4] || ba[2] > bb[5] ||
            bb[2] > ba[5])
          continue;
        // owner cell: the cell of the max of the two minima
        if (cell_of(std::max(ba[0], bb[0]), 0) != cx || cell_of(std::max(ba[1], bb[1]), 1) != cy ||
            cell_of(std::max(ba[2], bb[2]), 2) != cz)
          continue;
        const uint32_t* fa = tris + 3 * std::size_t(ta);
        const uint32_t* fb = tris + 3 * std::size_t(tb);
        int shared = 0, sa = -1, sb = -1;
        for (int p = 0; p < 3; ++p)
          for (int q = 0; q < 3; ++q)
            if (fa[p] == fb[q]) {
              ++shared;
              sa = p;
              sb = q;
            }
        if (shared >= 2) continue;
        ++rep.candidate_pairs;
        // rotate (keeping the winding) so that the shared vertex comes first;
        // translate so that it (or a's first vertex) is the origin
        const int ra = shared ? sa : 0, rb = shared ? sb : 0;
        const V3 o = vtx(xyz, fa[ra]);
        V3 A[3], B[3];
        for (int k = 0; k < 3; ++k) {
          A[k] = vtx(xyz, fa[(ra + k) % 3]) - o;
          B[k] = vtx(xyz, fb[(rb + k) % 3]) - o;
        }
        if (shared) B[0] = A[0];
        if (tri_tri(A, B, shared == 1)) {
          if (shared) ++rep.shared_vertex_pairs;
          else ++rep.disjoint_pairs;
          record(ta, tb);
        }
      }
    }
  }
  return rep;
}

std::size_t count_self_intersections(const float* xyz, std::size_t nv, const uint32_t* tris,
                                     std::size_t nt,
                                     std::vector<std::pair<uint32_t, uint32_t>>* first_pairs,
                                     std::size_t max_pairs) {
  SelfIntersectionReport rep =
      check_self_intersections(xyz, nv, tris, nt, first_pairs ? max_pairs : 0);
  if (first_pairs) *first_pairs = std::move(rep.first_pairs);
  return rep.disjoint_pairs;
}

bool is_closed_oriented_manifold(const float* /*xyz*/, std::size_t nv, const uint32_t* tris,
                                 std::size_t nt) {
  if (nt == 0) return false;
  std::vector<uint64_t> e;
  e.reserve(3 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const uint32_t* f = tris + 3 * t;
    if (!index_ok(f, nv) || f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) return false;
    for (int k = 0; k < 3; ++k) e.push_back((uint64_t(f[k]) << 32) | f[(k + 1) % 3]);
  }
  std::sort(e.begin(), e.end());
  if (std::adjacent_find(e.begin(), e.end()) != e.end()) return false;  // directed edge used twice
  for (uint64_t k : e) {
    const uint64_t rev = (k << 32) | (k >> 32);
    if (!std::binary_search(e.begin(), e.end(), rev)) return false;  // boundary edge
  }
  return true;
}

std::size_t count_normal_flips(const float* xyz, std::size_t nv, const uint32_t* tris,
                               std::size_t nt, double cos_limit, std::size_t* degenerate_out) {
  std::vector<V3> nrm(nt, V3{0, 0, 0});
  std::vector<uint8_t> ok(nt, 0);
  std::size_t ndeg = 0;
  std::vector<std::pair<uint64_t, uint32_t>> edges;
  edges.reserve(3 * nt);
  for (std::size_t t = 0; t < nt; ++t) {
    const uint32_t* f = tris + 3 * t;
    if (!index_ok(f, nv)) continue;
    V3 v[3] = {vtx(xyz, f[0]), vtx(xyz, f[1]), vtx(xyz, f[2])};
    if (degenerate(v) || f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
      ++ndeg;
      continue;
    }
    V3 n = cross(v[1] - v[0], v[2] - v[0]);
    nrm[t] = n * (1.0 / norm(n));
    ok[t] = 1;
    for (int k = 0; k < 3; ++k) {
      uint32_t a = f[k], b = f[(k + 1) % 3];
      edges.emplace_back((uint64_t(std::min(a, b)) << 32) | std::max(a, b), uint32_t(t));
    }
  }
  if (degenerate_out) *degenerate_out = ndeg;
  // Edges next to a degenerate triangle are left out: an edge with one good
  // and one degenerate neighbour looks like a boundary edge here.
  std::sort(edges.begin(), edges.end());
  std::size_t flips = 0;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j].first == edges[i].first) ++j;
    if (j - i == 2 && dot(nrm[edges[i].second], nrm[edges[i + 1].second]) < cos_limit) ++flips;
    i = j;
  }
  return flips;
}

double enclosed_volume(const float* xyz, std::size_t nv, const uint32_t* tris, std::size_t nt) {
  if (nv == 0) return 0.0;
  // reference point: first vertex (the sum is origin-independent for a closed
  // mesh; a nearby origin keeps the products small)
  const V3 o = vtx(xyz, 0);
  double vol = 0.0;
  for (std::size_t t = 0; t < nt; ++t) {
    const uint32_t* f = tris + 3 * t;
    if (!index_ok(f, nv)) continue;
    V3 a = vtx(xyz, f[0]) - o, b = vtx(xyz, f[1]) - o, c = vtx(xyz, f[2]) - o;
    vol += dot(a, cross(b, c));
  }
  return vol / 6.0;
}

double surface_area(const float* xyz, std::size_t nv, const uint32_t* tris, std::size_t nt) {
  double area = 0.0;
  for (std::size_t t = 0; t < nt; ++t) {
    const uint32_t* f = tris + 3 * t;
    if (!index_ok(f, nv)) continue;
    V3 a = vtx(xyz, f[0]), b = vtx(xyz, f[1]), c = vtx(xyz, f[2]);
    area += 0.5 * norm(cross(b - a, c - a));
  }
  return area;
}

std::size_t crossings_between(const std::vector<float>& xa, const std::vector<uint32_t>& ta,
                              const std::vector<float>& xb, const std::vector<uint32_t>& tb) {
  std::vector<float> x = xa;
  x.insert(x.end(), xb.begin(), xb.end());
  std::vector<uint32_t> t = ta;
  const uint32_t off = uint32_t(xa.size() / 3);
  for (uint32_t v : tb) t.push_back(v + off);
  auto count = [](const std::vector<float>& p, const std::vector<uint32_t>& q) {
    const SelfIntersectionReport r = check_self_intersections(p.data(), p.size() / 3, q.data(), q.size() / 3);
    return r.disjoint_pairs + r.shared_vertex_pairs;
  };
  return count(x, t) - count(xa, ta) - count(xb, tb);
}

}  // namespace ffseg_test
