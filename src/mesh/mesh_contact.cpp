#include "mesh_contact.h"

#include <cmath>
#include <cstring>

#include "triangle_crossing.h"
#include "triangulation.h"

namespace ffseg {

namespace {
// At most total / kBigShare + 16 obstacle triangles lie outside the grid
// (its cell size doubles until they do); a query box over more than
// kMaxQueryCells cells scans the obstacles' triangles instead.
constexpr uint32_t kBigShare = 64;
constexpr double kMaxQueryCells = 64;
// Ray directions of the parity test: +x tilted by small irrational-looking
// slopes, so that a ray does not run in a plane of the mesh's symmetry
// (the cube-sphere's edges lie on great circles through the axes); the next
// one when a ray meets an edge or a vertex.
constexpr int kRays = 3;
constexpr double kSlope[kRays][2] = {{0.0173205081, 0.0223606798}, {-0.0264575131, 0.0141421356},
                                     {0.0316227766, -0.0244948974}};
// Vertices of the query mesh tried as the ray origin when the one before
// lies on the obstacle's surface or all its rays are degenerate.
constexpr int kOrigins = 8;

inline void vertex_box(const double* x, uint32_t nv, double eps, double* lo, double* hi) {
  // Locals (not lo / hi, which may alias x as far as the compiler knows).
  double l0 = x[0], l1 = x[1], l2 = x[2], h0 = x[0], h1 = x[1], h2 = x[2];
  for (uint32_t v = 1; v < nv; ++v) {
    const double* p = x + 3 * size_t(v);
    l0 = p[0] < l0 ? p[0] : l0;
    h0 = p[0] > h0 ? p[0] : h0;
    l1 = p[1] < l1 ? p[1] : l1;
    h1 = p[1] > h1 ? p[1] : h1;
    l2 = p[2] < l2 ? p[2] : l2;
    h2 = p[2] > h2 ? p[2] : h2;
  }
  lo[0] = l0 - eps;
  lo[1] = l1 - eps;
  lo[2] = l2 - eps;
  hi[0] = h0 + eps;
  hi[1] = h1 + eps;
  hi[2] = h2 + eps;
}

// On which sides of the box [lo, hi] point p lies (bits: below, above per
// axis); outcodes(): every vertex's. The box of a face misses the box
// exactly when the codes of its vertices share a bit.
inline uint8_t outcode(const double* p, const double* lo, const double* hi) {
  return uint8_t(int(p[0] < lo[0]) | int(p[0] > hi[0]) << 1 | int(p[1] < lo[1]) << 2 | int(p[1] > hi[1]) << 3 |
                 int(p[2] < lo[2]) << 4 | int(p[2] > hi[2]) << 5);
}

inline void outcodes(const double* x, uint32_t nv, const double* lo, const double* hi, uint8_t* code) {
  const double l[3] = {lo[0], lo[1], lo[2]}, h[3] = {hi[0], hi[1], hi[2]};
  for (uint32_t v = 0; v < nv; ++v) code[v] = outcode(x + 3 * size_t(v), l, h);
}

// Whether face f's box meets the box of the codes.
inline bool face_meets(const CubeSphere& m, uint32_t f, const uint8_t* code) {
  const uint32_t* q = m.faces + 4 * size_t(f);
  uint8_t c = uint8_t(code[q[0]] & code[q[1]] & code[q[2]]);
  if (q[3] != kNone) c &= code[q[3]];
  return c == 0;
}

// The triangle of mesh m with index t lies in this face.
inline uint32_t face_of(const CubeSphere& m, uint32_t t) {
  const uint32_t quads = m.nfaces - 8;
  return t < 2 * quads ? t / 2 : t - quads;
}

// Box [la, ha] inside box [lb, hb] (closed).
inline bool box_inside(const double* la, const double* ha, const double* lb, const double* hb) {
  return la[0] >= lb[0] && la[1] >= lb[1] && la[2] >= lb[2] && ha[0] <= hb[0] && ha[1] <= hb[1] && ha[2] <= hb[2];
}

// One ray from p along direction (1, sy, sz): 1 or 0 (the parity of its
// crossings), -1 when it meets an edge or a vertex of a triangle (cast
// another), -2 when p lies on the mesh.
int ray_parity(const double* p, const double* x, const uint32_t* tris, const double* lo, const double* hi, uint32_t nt,
               double sy, double sz) {
  double xmax = p[0];
  for (uint32_t t = 0; t < nt; ++t) xmax = hi[3 * size_t(t)] > xmax ? hi[3 * size_t(t)] : xmax;
  if (!(xmax > p[0])) return 0;  // nothing ahead: outside
  // Past every triangle: q lies beyond all boxes, so no triangle holds it.
  const double L = 2 * (xmax - p[0]) + 1;
  const double q[3] = {p[0] + L, p[1] + L * sy, p[2] + L * sz};
  const double ylo = p[1] < q[1] ? p[1] : q[1], yhi = p[1] < q[1] ? q[1] : p[1];
  const double zlo = p[2] < q[2] ? p[2] : q[2], zhi = p[2] < q[2] ? q[2] : p[2];
  int parity = 0;
  for (uint32_t t = 0; t < nt; ++t) {
    const double *l = lo + 3 * size_t(t), *h = hi + 3 * size_t(t);
    if (h[0] < p[0] || l[1] > yhi || h[1] < ylo || l[2] > zhi || h[2] < zlo) continue;
    const uint32_t* id = tris + 3 * size_t(t);
    const double *t0 = x + 3 * size_t(id[0]), *t1 = x + 3 * size_t(id[1]), *t2 = x + 3 * size_t(id[2]);
    const double dp = detail::orient(t0, t1, t2, p), dq = detail::orient(t0, t1, t2, q);
    if ((dp > 0 && dq > 0) || (dp < 0 && dq < 0) || dq == 0) continue;
    const double e0 = detail::orient(p, q, t0, t1), e1 = detail::orient(p, q, t1, t2), e2 = detail::orient(p, q, t2, t0);
    const bool pos = e0 >= 0 && e1 >= 0 && e2 >= 0, neg = e0 <= 0 && e1 <= 0 && e2 <= 0;
    if (!pos && !neg) continue;  // the line misses the closed triangle
    if (dp == 0) return -2;      // p on the triangle's plane, within it
    if (e0 == 0 || e1 == 0 || e2 == 0) return -1;
    parity ^= 1;
  }
  return parity;
}

// Whether some vertex of the mesh at y (nv vertices) lies inside the closed
// mesh (x, tris, boxes): 1, 0, or -1 when no tried vertex decides (each on
// the surface or every ray degenerate).
int vertices_inside(const double* y, uint32_t nv, const double* x, const uint32_t* tris, const double* lo,
                    const double* hi, uint32_t nt) {
  for (int o = 0; o < kOrigins; ++o) {
    const double* p = y + 3 * size_t((uint64_t(o) * nv) / kOrigins);
    for (int r = 0; r < kRays; ++r) {
      const int k = ray_parity(p, x, tris, lo, hi, nt, kSlope[r][0], kSlope[r][1]);
      if (k >= 0) return k;
      if (k == -2) break;  // on the surface: another origin
    }
  }
  return -1;
}

// The query mesh's face f split at x (alt: the caller's splits, may be
// nullptr) and its triangles boxed (once per query).
inline void prepare_face(const CubeSphere& m, const double* x, ContactScratch& s, uint32_t f, const uint8_t* alt) {
  if (s.qface[f]) return;
  s.qface[f] = 1;
  const uint32_t t0 = m.first_triangle(f);
  uint32_t* tri = s.qtris + 3 * size_t(t0);
  const int c = alt ? face_split(m, f, alt[f] != 0, tri) : face_triangles(m, f, tri, x);
  for (int i = 0; i < c; ++i) {
    const uint32_t* id = tri + 3 * i;
    detail::triangle_box(x + 3 * size_t(id[0]), x + 3 * size_t(id[1]), x + 3 * size_t(id[2]), s.eps,
                         s.qlo + 3 * size_t(t0 + i), s.qhi + 3 * size_t(t0 + i));
  }
}

// Whether face f's corners are at the same positions in x and y, bit for bit.
inline bool same_corners(const CubeSphere& m, uint32_t f, const double* x, const double* y) {
  const uint32_t* q = m.faces + 4 * size_t(f);
  const int k = q[3] == kNone ? 3 : 4;
  for (int i = 0; i < k; ++i)
    if (std::memcmp(x + 3 * size_t(q[i]), y + 3 * size_t(q[i]), 3 * sizeof(double)) != 0) return false;
  return true;
}

// Obstacle k's face f split at its positions (as its caller's splits have
// it where they hold its corners) and its triangles boxed (widened by eps);
// returns how many triangles.
inline int obstacle_face(const CubeSphere& m, ContactScratch& s, uint32_t k, uint32_t f, double eps) {
  const double* y = s.pos[k];
  const size_t t0 = size_t(k) * s.nt + m.first_triangle(f);
  uint32_t* tri = s.tris + 3 * t0;
  const ObstacleSplits& sp = s.splits[k];
  const int c = sp.alt && same_corners(m, f, sp.key, y) ? face_split(m, f, sp.alt[f] != 0, tri)
                                                         : face_triangles(m, f, tri, y);
  for (int i = 0; i < c; ++i) {
    const uint32_t* id = tri + 3 * i;
    detail::triangle_box(y + 3 * size_t(id[0]), y + 3 * size_t(id[1]), y + 3 * size_t(id[2]), eps,
                         s.lo + 3 * (t0 + i), s.hi + 3 * (t0 + i));
  }
  s.fdone[size_t(k) * m.nfaces + f] = 1;
  return c;
}

// Calls f(id) for every triangle of the obstacles set up (faces done).
template <class F>
void for_each_done(const CubeSphere& m, const ContactScratch& s, F&& fn) {
  for (uint32_t k = 0; k < s.count; ++k) {
    if (!(s.state[k] & ContactScratch::kActive)) continue;
    const uint8_t* done = s.fdone + size_t(k) * m.nfaces;
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      if (!done[f]) continue;
      const uint32_t t0 = k * s.nt + m.first_triangle(f);
      fn(t0);
      if (m.faces[4 * size_t(f) + 3] != kNone) fn(t0 + 1);
    }
  }
}

// Obstacle k whole (every face split and boxed), for the ray test. The
// scan of a query too wide for the grid then meets these triangles too:
// the tracked pairs, found without them, end.
void complete(const CubeSphere& m, ContactScratch& s, uint32_t k) {
  if (s.state[k] & ContactScratch::kComplete) return;
  s.tracked = false;
  const uint8_t* done = s.fdone + size_t(k) * m.nfaces;
  for (uint32_t f = 0; f < m.nfaces; ++f)
    if (!done[f]) obstacle_face(m, s, k, f, s.eps);
  s.state[k] |= ContactScratch::kComplete;
}

}  // namespace

void ContactScratch::carve(Arena& a, const CubeSphere& m, uint32_t max_obst) {
  max_obstacles = max_obst;
  count = 0;
  nt = m.triangle_count();
  const size_t total = size_t(nt) * max_obst;
  pos = a.alloc<const double*>(max_obst);
  splits = a.alloc<ObstacleSplits>(max_obst);
  box = a.alloc<double>(size_t(6) * max_obst);
  state = a.alloc<uint8_t>(max_obst);
  fdone = a.alloc<uint8_t>(size_t(m.nfaces) * max_obst);
  entered = a.alloc<uint32_t>(total);
  tris = a.alloc<uint32_t>(3 * total);
  lo = a.alloc<double>(3 * total);
  hi = a.alloc<double>(3 * total);
  big_cap = uint32_t(total / kBigShare) + 16;
  big = a.alloc<uint32_t>(big_cap);
  big_grid.carve(a, big_cap);
  grid.carve(a, uint32_t(total));
  qtris = a.alloc<uint32_t>(size_t(3) * nt);
  qlo = a.alloc<double>(size_t(3) * nt);
  qhi = a.alloc<double>(size_t(3) * nt);
  qface = a.alloc<uint8_t>(m.nfaces);
  qcode = a.alloc<uint8_t>(m.nv);
  crossed = a.alloc<uint8_t>(max_obst);
  zone = a.alloc<double>(size_t(6) * max_obst);
  // Beyond it a tracked call starts afresh (a step pressed deep into a
  // neighbour; the guard halves it anyway).
  pair_cap = nt + 64;
  pairs = a.alloc<uint32_t>(2 * size_t(pair_cap));
  npairs = 0;
  tracked = false;
  reach = a.alloc<uint8_t>(m.nfaces);
  swept = false;
}

void build_obstacles(const CubeSphere& m, const double* const* xs, uint32_t count, ContactScratch& s,
                     const double* region, const ObstacleSplits* splits) {
  s.count = count < s.max_obstacles ? count : s.max_obstacles;
  s.tracked = false;
  s.swept = false;
  const uint32_t nt = s.nt;
  // The region, widened against the rounding of positions blended inside it.
  double rlo[3], rhi[3];
  if (region) {
    double r = 0;
    for (int a = 0; a < 3; ++a) r = std::fmax(r, std::fmax(std::fabs(region[a]), std::fabs(region[3 + a])));
    for (int a = 0; a < 3; ++a) {
      rlo[a] = region[a] - 1e-6 * r;
      rhi[a] = region[3 + a] + 1e-6 * r;
    }
  }
  double emean = 0, extent = 0;
  s.nentered = 0;
  for (uint32_t k = 0; k < s.count; ++k) {
    s.pos[k] = xs[k];
    s.splits[k] = splits && splits[k].key ? splits[k] : ObstacleSplits{};
    double* b = s.box + 6 * size_t(k);
    vertex_box(xs[k], m.nv, 0.0, b, b + 3);
    s.state[k] = 0;
    if (region && !detail::boxes_overlap(b, b + 3, rlo, rhi)) continue;  // never met: nothing to enter
    for (int a = 0; a < 3; ++a) extent = std::fmax(extent, b[3 + a] - b[a]);
    s.state[k] = uint8_t(ContactScratch::kActive | (region ? 0 : ContactScratch::kComplete));
    uint8_t* done = s.fdone + size_t(k) * m.nfaces;
    if (region) outcodes(xs[k], m.nv, rlo, rhi, s.qcode);
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      done[f] = 0;
      if (region && !face_meets(m, f, s.qcode)) continue;
      const int c = obstacle_face(m, s, k, f, 0.0);
      const size_t t0 = size_t(k) * nt + m.first_triangle(f);
      for (int i = 0; i < c; ++i) {
        const size_t g = 3 * (t0 + i);
        emean += (s.hi[g] - s.lo[g]) + (s.hi[g + 1] - s.lo[g + 1]) + (s.hi[g + 2] - s.lo[g + 2]);
        s.entered[s.nentered++] = uint32_t(t0 + i);
      }
    }
  }
  const uint32_t entered = s.nentered;
  s.nbig = 0;
  s.eps = 0;
  if (entered == 0) {
    s.grid.set_cell_size(1);
    s.grid.size_table(0);
    s.grid.build_from(s.lo, s.hi, s.entered, 0);
    return;
  }
  emean /= 3.0 * double(entered);
  // Candidates: boxes that overlap, each widened by a hair against rounding
  // (the query mesh's by the same).
  s.eps = std::isfinite(emean + extent) ? 1e-9 * (emean + extent) : 0.0;
  for (uint32_t j = 0; j < entered; ++j) {
    const size_t t = s.entered[j];
    for (int a = 0; a < 3; ++a) {
      s.lo[3 * t + a] -= s.eps;
      s.hi[3 * t + a] += s.eps;
    }
  }
  for (uint32_t k = 0; k < s.count; ++k)
    for (int a = 0; a < 3; ++a) {
      s.box[6 * size_t(k) + a] -= s.eps;
      s.box[6 * size_t(k) + 3 + a] += s.eps;
    }
  // The grid's cells twice the mean box extent, doubled until at most
  // big_cap boxes outgrow them (those are tested against every query).
  double h = 2 * emean + 1e-9 * extent;
  if (!(h > 0) || !std::isfinite(h)) h = 1;
  for (;;) {
    s.grid.set_cell_size(h);
    s.nbig = 0;
    bool over = false;
    for (uint32_t j = 0; j < entered && !over; ++j) {
      const uint32_t t = s.entered[j];
      if (s.grid.fits(s.lo + 3 * size_t(t), s.hi + 3 * size_t(t))) continue;
      if (s.nbig == s.big_cap) over = true;
      else s.big[s.nbig++] = t;
    }
    if (!over) break;
    h *= 2;
  }
  // The grid enters the triangles set up that fit its cells; the big ones
  // (listed in ascending order, as entered) go to their own.
  s.grid.size_table(entered);
  s.grid.build_from(s.lo, s.hi, s.entered, entered);
  // The big ones at cells as wide as the widest of them (each then spans at
  // most two per axis).
  double wide = 2 * h;
  for (uint32_t j = 0; j < s.nbig; ++j)
    for (int a = 0; a < 3; ++a) wide = std::fmax(wide, s.hi[3 * size_t(s.big[j]) + a] - s.lo[3 * size_t(s.big[j]) + a]);
  s.big_grid.set_cell_size(std::isfinite(wide) ? wide : 1.0);
  s.big_fit = true;
  for (uint32_t j = 0; j < s.nbig; ++j)
    s.big_fit = s.big_fit && s.big_grid.fits(s.lo + 3 * size_t(s.big[j]), s.hi + 3 * size_t(s.big[j]));
  s.big_grid.build_from(s.lo, s.hi, s.big, s.big_fit ? s.nbig : 0);
}


namespace {

// Whether the box [lo, hi] meets the box of an obstacle triangle entered by
// build_obstacles() (the grid's or a big one; the triangles complete() adds
// for the ray test lie outside the region, where no query reaches). A box
// over too many cells answers yes unasked.
bool box_meets_obstacles(const ContactScratch& s, const double* lo, const double* hi) {
  bool near = false;
  for (uint32_t k = 0; k < s.count && !near; ++k) {
    const double* b = s.box + 6 * size_t(k);
    near = (s.state[k] & ContactScratch::kActive) && detail::boxes_overlap(lo, hi, b, b + 3);
  }
  if (!near) return false;
  auto meets = [&](uint32_t u) {
    return detail::boxes_overlap(lo, hi, s.lo + 3 * size_t(u), s.hi + 3 * size_t(u));
  };
  const BoxGrid::Range r = s.grid.range_of(lo, hi);
  if (BoxGrid::count(r) > kMaxQueryCells) return true;
  if (s.grid.any_entry(r, meets)) return true;
  if (s.nbig == 0) return false;
  if (s.big_fit) {
    const BoxGrid::Range rb = s.big_grid.range_of(lo, hi);
    if (BoxGrid::count(rb) <= kMaxQueryCells) return s.big_grid.any_entry(rb, meets);
  }
  for (uint32_t j = 0; j < s.nbig; ++j)
    if (meets(s.big[j])) return true;
  return false;
}

}  // namespace

void sweep_obstacles(const CubeSphere& m, const double* a, const double* b, ContactScratch& s) {
  s.swept = false;
  if (s.count == 0) return;
  const size_t nv = m.nv;
  // A blended position strays from its segment by a few units in the last
  // place of the largest coordinate; build_obstacles() widens its region by
  // 1e-6 of that for the same reason. The query's boxes are widened by eps.
  double r = 0;
  bool finite = true;
  for (size_t q = 0; q < 3 * nv; ++q) {
    const double p = std::fabs(a[q]), e = std::fabs(b[q]);
    finite = finite & (p - p == 0) & (e - e == 0);  // neither infinite nor NaN
    r = p > r ? p : r;
    r = e > r ? e : r;
  }
  if (!finite) return;  // no filter: every face is tested
  const double w = 1e-6 * r + s.eps;
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    const uint32_t* q = m.faces + 4 * size_t(f);
    const int k = q[3] == kNone ? 3 : 4;
    double lo[3], hi[3];
    for (int c = 0; c < 3; ++c) {
      double l = a[3 * size_t(q[0]) + c], h = l;
      for (int i = 0; i < k; ++i) {
        const double p = a[3 * size_t(q[i]) + c], e = b[c * nv + q[i]];
        l = p < l ? p : l;
        h = p > h ? p : h;
        l = e < l ? e : l;
        h = e > h ? e : h;
      }
      lo[c] = l - w;
      hi[c] = h + w;
    }
    s.reach[f] = box_meets_obstacles(s, lo, hi);
  }
  s.swept = true;
}

namespace {

// The query's box (xlo, xhi) and the zone: per obstacle whose box meets it,
// the overlap of the two (s.zone), and the box around them all (zlo, zhi);
// only x's triangles meeting an overlap can cross. Clears s.crossed; returns
// how many obstacles met.
uint32_t contact_zone(const CubeSphere& m, const double* x, ContactScratch& s, double xlo[3], double xhi[3],
                      double zlo[3], double zhi[3]) {
  vertex_box(x, m.nv, s.eps, xlo, xhi);
  uint32_t near = 0;
  for (uint32_t k = 0; k < s.count; ++k) {
    const double* b = s.box + 6 * size_t(k);
    s.crossed[k] = 0;
    if (!(s.state[k] & ContactScratch::kActive) || !detail::boxes_overlap(xlo, xhi, b, b + 3)) continue;
    double* z = s.zone + 6 * size_t(near);
    for (int a = 0; a < 3; ++a) {
      const double l = b[a] > xlo[a] ? b[a] : xlo[a], h = b[3 + a] < xhi[a] ? b[3 + a] : xhi[a];
      z[a] = l;
      z[3 + a] = h;
      zlo[a] = near == 0 || l < zlo[a] ? l : zlo[a];
      zhi[a] = near == 0 || h > zhi[a] ? h : zhi[a];
    }
    ++near;
  }
  return near;
}

// Which faces of x meet the zone widened by eps (a face whose box, widened
// by eps, misses it has no triangle to test): face_meets() on its vertices'
// outcodes. Swept, the reach filter leaves few faces to ask about, and
// their own vertices' codes are computed as asked (the same comparisons);
// otherwise every face is asked, and s.qcode holds every vertex's.
struct ZoneFaces {
  const CubeSphere& m;
  const double* x;
  const ContactScratch& s;
  double lo[3], hi[3];
  ZoneFaces(const CubeSphere& mesh, const double* pos, ContactScratch& sc, const double zlo[3], const double zhi[3])
      : m(mesh), x(pos), s(sc) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = zlo[a] - sc.eps;
      hi[a] = zhi[a] + sc.eps;
    }
    if (!sc.swept) outcodes(x, m.nv, lo, hi, sc.qcode);
  }
  bool meets(uint32_t f) const {
    if (!s.swept) return face_meets(m, f, s.qcode);
    const uint32_t* q = m.faces + 4 * size_t(f);
    uint8_t c = uint8_t(outcode(x + 3 * size_t(q[0]), lo, hi) & outcode(x + 3 * size_t(q[1]), lo, hi) &
                        outcode(x + 3 * size_t(q[2]), lo, hi));
    if (q[3] != kNone) c &= outcode(x + 3 * size_t(q[3]), lo, hi);
    return c == 0;
  }
};

// Calls hit(t, u) for every pair of a triangle t of x's face f (boxed by
// prepare_face()) and an obstacle triangle u that cross, while hit returns
// false; returns whether it stopped. One walk of the grid over the box of
// the face's triangles serves them both (a quad's two triangles share most
// of their cells), and meets each obstacle triangle once. A triangle's
// crossings depend on its own vertices only: the zone (near overlaps)
// bounds every obstacle triangle box that its box can meet.
template <class Hit>
bool face_contacts(const CubeSphere& m, const double* x, const ContactScratch& s, uint32_t near, uint32_t f,
                   Hit&& hit) {
  const uint32_t nt = s.nt;
  const uint32_t t0 = m.first_triangle(f);
  const int c = m.faces[4 * size_t(f) + 3] != kNone ? 2 : 1;
  // The triangles whose boxes meet the zone, and the box around them.
  uint32_t tq[2];
  int k = 0;
  double lf[3], hf[3];
  for (int i = 0; i < c; ++i) {
    const uint32_t t = t0 + i;
    const double *lt = s.qlo + 3 * size_t(t), *ht = s.qhi + 3 * size_t(t);
    bool meets = false;
    for (uint32_t j = 0; j < near && !meets; ++j)
      meets = detail::boxes_overlap(lt, ht, s.zone + 6 * size_t(j), s.zone + 6 * size_t(j) + 3);
    if (!meets) continue;
    for (int a = 0; a < 3; ++a) {
      lf[a] = k == 0 || lt[a] < lf[a] ? lt[a] : lf[a];
      hf[a] = k == 0 || ht[a] > hf[a] ? ht[a] : hf[a];
    }
    tq[k++] = t;
  }
  if (k == 0) return false;
  bool stop = false;
  auto test = [&](uint32_t u) {
    const double *lu = s.lo + 3 * size_t(u), *hu = s.hi + 3 * size_t(u);
    const uint32_t* b = s.tris + 3 * size_t(u);
    const double* y = s.pos[u / nt];
    const double* B[3] = {y + 3 * size_t(b[0]), y + 3 * size_t(b[1]), y + 3 * size_t(b[2])};
    for (int i = 0; i < k && !stop; ++i) {
      const uint32_t t = tq[i];
      if (!detail::boxes_overlap(s.qlo + 3 * size_t(t), s.qhi + 3 * size_t(t), lu, hu)) continue;
      const uint32_t* a = s.qtris + 3 * size_t(t);
      const double* A[3] = {x + 3 * size_t(a[0]), x + 3 * size_t(a[1]), x + 3 * size_t(a[2])};
      if (detail::disjoint_triangles_cross(A, B)) stop = hit(t, u);
    }
  };
  // Each obstacle triangle once: in the cell holding the low corner of the
  // intersection of its box and the face's (it lies in both boxes' cells),
  // told by the entries' low-cell bits before their boxes are read.
  auto query = [&](const BoxGrid& g, const BoxGrid::Range& r) {
    g.for_each_owned_entry(r, [&](uint32_t u) {
      if (!stop && detail::boxes_overlap(lf, hf, s.lo + 3 * size_t(u), s.hi + 3 * size_t(u))) test(u);
    });
  };
  const BoxGrid::Range r = s.grid.range_of(lf, hf);
  if (BoxGrid::count(r) <= kMaxQueryCells) {
    query(s.grid, r);
    if (s.nbig == 0 || stop) return stop;
    BoxGrid::Range rb;
    if (s.big_fit && BoxGrid::count(rb = s.big_grid.range_of(lf, hf)) <= kMaxQueryCells) {
      query(s.big_grid, rb);
    } else {
      for (uint32_t j = 0; j < s.nbig && !stop; ++j) {
        const uint32_t u = s.big[j];
        if (detail::boxes_overlap(lf, hf, s.lo + 3 * size_t(u), s.hi + 3 * size_t(u))) test(u);
      }
    }
  } else {
    // Triangles completed for the ray test lie outside the region, so
    // outside every query's boxes.
    for_each_done(m, s, [&](uint32_t u) {
      if (!stop && detail::boxes_overlap(lf, hf, s.lo + 3 * size_t(u), s.hi + 3 * size_t(u))) test(u);
    });
  }
  return stop;
}

// Containment without crossing (s.crossed set for this query): x lies
// inside obstacle k only if its box (xlo, xhi) lies in k's, and encloses k
// only if k's box lies in its own; without a crossing every vertex of one is
// on one side of the other, so one vertex decides. Returns how many, marking
// every vertex of x for each (mark nullptr: stops at the first).
uint32_t contained(const CubeSphere& m, const double* x, ContactScratch& s, const double xlo[3],
                   const double xhi[3], uint8_t* mark, const uint8_t* alt) {
  const uint32_t nt = s.nt;
  uint32_t count = 0;
  bool all_split = false;
  for (uint32_t k = 0; k < s.count; ++k) {
    if (s.crossed[k] || !(s.state[k] & ContactScratch::kActive)) continue;
    const double* b = s.box + 6 * size_t(k);
    if (!detail::boxes_overlap(xlo, xhi, b, b + 3)) continue;
    const size_t g = size_t(k) * nt;
    bool inside = false;
    if (box_inside(xlo, xhi, b, b + 3)) {
      complete(m, s, k);
      inside = vertices_inside(x, m.nv, s.pos[k], s.tris + 3 * g, s.lo + 3 * g, s.hi + 3 * g, nt) == 1;
    }
    if (!inside && box_inside(b, b + 3, xlo, xhi)) {
      if (!all_split)
        for (uint32_t f = 0; f < m.nfaces; ++f) prepare_face(m, x, s, f, alt);
      all_split = true;
      inside = vertices_inside(s.pos[k], m.nv, x, s.qtris, s.qlo, s.qhi, nt) == 1;
    }
    if (!inside) continue;
    ++count;
    if (!mark) return count;
    for (uint32_t v = 0; v < m.nv; ++v) mark[v] = 1;
  }
  return count;
}

// mark_contacts() from scratch; with record, the crossing pairs are kept for
// mark_contacts_tracked() (mark must then be set).
uint32_t contacts_full(const CubeSphere& m, const double* x, ContactScratch& s, uint8_t* mark, const uint8_t* alt,
                       bool record) {
  s.tracked = false;
  if (s.count == 0) return 0;
  const uint32_t nt = s.nt;
  for (uint32_t f = 0; f < m.nfaces; ++f) s.qface[f] = 0;
  s.npairs = 0;
  double xlo[3], xhi[3], zlo[3], zhi[3];
  const uint32_t near = contact_zone(m, x, s, xlo, xhi, zlo, zhi);
  if (near == 0) {
    s.tracked = record;
    return 0;
  }
  const ZoneFaces zone(m, x, s, zlo, zhi);
  uint32_t count = 0;
  bool room = true;
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    if ((s.swept && !s.reach[f]) || !zone.meets(f)) continue;
    prepare_face(m, x, s, f, alt);
    const bool stop = face_contacts(m, x, s, near, f, [&](uint32_t t, uint32_t u) {
      ++count;
      s.crossed[u / nt] = 1;
      if (!mark) return true;
      const uint32_t* a = s.qtris + 3 * size_t(t);
      mark[a[0]] = mark[a[1]] = mark[a[2]] = 1;
      if (record && (room = room && s.npairs < s.pair_cap)) {
        s.pairs[2 * size_t(s.npairs)] = t;
        s.pairs[2 * size_t(s.npairs) + 1] = u;
        ++s.npairs;
      }
      return false;
    });
    if (stop) return count;
  }
  s.tracked = record && room;
  return count + contained(m, x, s, xlo, xhi, mark, alt);
}

// Whether a vertex of face f moved.
inline bool face_moved(const CubeSphere& m, uint32_t f, const uint8_t* moved) {
  const uint32_t* q = m.faces + 4 * size_t(f);
  return moved[q[0]] | moved[q[1]] | moved[q[2]] | (q[3] != kNone && moved[q[3]]);
}

}  // namespace

uint32_t mark_contacts(const CubeSphere& m, const double* x, ContactScratch& s, uint8_t* mark, const uint8_t* alt) {
  return contacts_full(m, x, s, mark, alt, false);
}

uint32_t mark_contacts_tracked(const CubeSphere& m, const double* x, ContactScratch& s, uint8_t* mark,
                               const uint8_t* moved, const uint8_t* alt) {
  if (!moved || !s.tracked) return contacts_full(m, x, s, mark, alt, true);
  if (s.count == 0) return 0;
  const uint32_t nt = s.nt;
  // The faces around moved vertices are split and boxed again when met
  // (their qface cleared by the walk below, which passes every face).
  double xlo[3], xhi[3], zlo[3], zhi[3];
  const uint32_t near = contact_zone(m, x, s, xlo, xhi, zlo, zhi);
  if (near == 0) {
    for (uint32_t f = 0; f < m.nfaces; ++f)
      if (face_moved(m, f, moved)) s.qface[f] = 0;
    s.npairs = 0;
    return 0;
  }
  // Pairs of unmoved triangles stand; the moved ones' are found afresh.
  uint32_t kept = 0;
  for (uint32_t i = 0; i < s.npairs; ++i) {
    const uint32_t t = s.pairs[2 * size_t(i)], u = s.pairs[2 * size_t(i) + 1];
    if (face_moved(m, face_of(m, t), moved)) continue;
    s.pairs[2 * size_t(kept)] = t;
    s.pairs[2 * size_t(kept) + 1] = u;
    ++kept;
    s.crossed[u / nt] = 1;
    const uint32_t* a = s.qtris + 3 * size_t(t);
    mark[a[0]] = mark[a[1]] = mark[a[2]] = 1;
  }
  s.npairs = kept;
  const ZoneFaces zone(m, x, s, zlo, zhi);
  bool room = true;
  for (uint32_t f = 0; f < m.nfaces && room; ++f) {
    if (!face_moved(m, f, moved)) continue;
    s.qface[f] = 0;
    if ((s.swept && !s.reach[f]) || !zone.meets(f)) continue;
    prepare_face(m, x, s, f, alt);
    face_contacts(m, x, s, near, f, [&](uint32_t t, uint32_t u) {
      if (!(room = s.npairs < s.pair_cap)) return true;
      s.pairs[2 * size_t(s.npairs)] = t;
      s.pairs[2 * size_t(s.npairs) + 1] = u;
      ++s.npairs;
      s.crossed[u / nt] = 1;
      const uint32_t* a = s.qtris + 3 * size_t(t);
      mark[a[0]] = mark[a[1]] = mark[a[2]] = 1;
      return false;
    });
  }
  if (!room) return contacts_full(m, x, s, mark, alt, true);
  return s.npairs + contained(m, x, s, xlo, xhi, mark, alt);
}

}  // namespace ffseg
