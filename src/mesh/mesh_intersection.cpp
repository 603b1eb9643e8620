#include "mesh_intersection.h"

#include <cmath>
#include <utility>

#include "min_max.h"
#include "triangle_crossing.h"
#include "triangulation.h"

namespace ffseg {

namespace {
// At most nt / kRefShare + 16 triangles outgrow the reference cells (a
// full check doubles its cell size until they do; more in a tracked call:
// start afresh), at most nt / kBigShare + 16 lie outside the grid (its cell
// size doubles until they do).
constexpr uint32_t kRefShare = 256;
constexpr uint32_t kBigShare = 64;
constexpr uint8_t kOutside = 1, kWide = 2;
}  // namespace

void TriangleScratch::carve(Arena& a, const CubeSphere& m) {
  const uint32_t nt = m.triangle_count();
  tris = a.alloc<uint32_t>(size_t(3) * nt);
  centroid = a.alloc<double>(size_t(3) * nt);
  radius = a.alloc<double>(nt);
  normal = a.alloc<double>(size_t(3) * nt);
  lo = a.alloc<double>(size_t(3) * nt);
  hi = a.alloc<double>(size_t(3) * nt);
  big_cap = nt / kBigShare + 16;
  ref_cap = nt / kRefShare + 16;
  big = a.alloc<uint32_t>(big_cap + 1);
  is_big = a.alloc<uint8_t>(nt);
  touched = a.alloc<uint8_t>(nt);
  pair_cap = 2 * nt + 64;
  pairs = a.alloc<uint32_t>(2 * size_t(pair_cap));
  face_flags = a.alloc<uint8_t>(m.nfaces);
  vertex_flags = a.alloc<uint8_t>(m.nv);
  vertex_marks = a.alloc<uint8_t>(m.nv);
  vertex_pending = a.alloc<uint8_t>(m.nv);
  face_n_old = a.alloc<double>(size_t(6) * m.nfaces);
  face_n_new = a.alloc<double>(size_t(6) * m.nfaces);
  face_alt_old = a.alloc<uint8_t>(m.nfaces);
  face_alt_new = a.alloc<uint8_t>(m.nfaces);
  new_key = a.alloc<double>(size_t(3) * m.nv);
  new_key_valid = false;
  grid.carve(a, nt);
  cert.carve(a, m);
  tracked = false;
}

namespace {

// Whether p and q lie, beyond doubt, strictly on one side of the plane of
// the triangle with normal n at o: n . (p - o) and n . (q - o) exceed tol
// with one sign. tol = 1e-13 D^3, D the largest extent of a box holding the
// four points: the exact orientation of (triangle, p) differs from this
// estimate by at most ~50 eps D^3 and from any of the pair test's orient()
// evaluations of it (any argument order, all differences at most D) by at
// most ~50 eps D^3 too, so past tol every evaluation has the estimate's sign.
inline bool same_side_certain(const double* n, const double* o, const double* p, const double* q, double tol) {
  const double dp = n[0] * (p[0] - o[0]) + n[1] * (p[1] - o[1]) + n[2] * (p[2] - o[2]);
  const double dq = n[0] * (q[0] - o[0]) + n[1] * (q[1] - o[1]) + n[2] * (q[2] - o[2]);
  return (dp > tol && dq > tol) || (dp < -tol && dq < -tol);
}

// Triangles sharing exactly one vertex v: the exact test below can report
// such a pair only when the far vertices of each straddle the other's plane,
// as computed: a far edge crossing the other triangle needs its ends on both
// sides of that plane, and its line inside the triangle needs the two edges
// at v on opposite sides of the plane of the far edge and v, the first
// triangle's plane. So when the far vertices of one lie beyond doubt
// (same_side_certain) on one side of the other's plane, the answer is no.

// Triangle t's corners in x.
inline void corners(const double* x, const TriangleScratch& s, uint32_t t, const double* C[3]) {
  const uint32_t* a = s.tris + 3 * size_t(t);
  for (int i = 0; i < 3; ++i) C[i] = x + 3 * size_t(a[i]);
}

bool triangles_cross(const double* x, const TriangleScratch& s, uint32_t t, uint32_t u) {
  const uint32_t* a = s.tris + 3 * size_t(t);
  const uint32_t* b = s.tris + 3 * size_t(u);
  int shared = 0, sa = -1, sb = -1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (a[i] == b[j]) {
        ++shared;
        sa = i;
        sb = j;
      }
  if (shared >= 2) return false;  // neighbours across an edge: the fold test's business
  const double *A[3], *B[3];
  corners(x, s, t, A);
  corners(x, s, u, B);
  if (shared == 1) {
    // Only the edges opposite the shared vertex can cross the other triangle
    // away from that vertex.
    return detail::segment_crosses(A[(sa + 1) % 3], A[(sa + 2) % 3], B[0], B[1], B[2]) ||
           detail::segment_crosses(B[(sb + 1) % 3], B[(sb + 2) % 3], A[0], A[1], A[2]);
  }
  return detail::disjoint_triangles_cross(A, B);
}

// triangles_cross() for a pair already known to share no vertex: its last
// line, without counting the shared vertices again.
inline bool disjoint_cross(const double* x, const TriangleScratch& s, uint32_t t, uint32_t u) {
  const double *A[3], *B[3];
  corners(x, s, t, A);
  corners(x, s, u, B);
  return detail::disjoint_triangles_cross(A, B);
}

}  // namespace

namespace {

// Centroid, bounding box (widened by eps) and bounding radius of triangle t.
void prepare(const double* x, TriangleScratch& s, uint32_t t, double eps) {
  const uint32_t* id = s.tris + 3 * size_t(t);
  double* c = s.centroid + 3 * size_t(t);
  double* lo = s.lo + 3 * size_t(t);
  double* hi = s.hi + 3 * size_t(t);
  const double *p0 = x + 3 * size_t(id[0]), *p1 = x + 3 * size_t(id[1]), *p2 = x + 3 * size_t(id[2]);
  for (int a = 0; a < 3; ++a) c[a] = (p0[a] + p1[a] + p2[a]) / 3.0;
  detail::triangle_box(p0, p1, p2, eps, lo, hi);
  double r2 = 0;
  for (int k = 0; k < 3; ++k) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += (x[3 * size_t(id[k]) + a] - c[a]) * (x[3 * size_t(id[k]) + a] - c[a]);
    r2 = d2 > r2 ? d2 : r2;
  }
  s.radius[t] = std::sqrt(r2);
  const double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
  const double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
  double* n = s.normal + 3 * size_t(t);
  n[0] = e1[1] * e2[2] - e1[2] * e2[1];
  n[1] = e1[2] * e2[0] - e1[0] * e2[2];
  n[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

// Candidate enumeration over the prepared triangles and the grid.
struct Pairs {
  const CubeSphere& m;
  const double* x;
  TriangleScratch& s;
  uint8_t* mark;
  bool record;  // append crossing pairs to s.pairs (s.tracked drops on overflow)
  uint32_t count = 0;

  bool overlap(uint32_t t, uint32_t u) const {
    return detail::boxes_overlap(s.lo + 3 * size_t(t), s.hi + 3 * size_t(t), s.lo + 3 * size_t(u),
                                 s.hi + 3 * size_t(u));
  }
  // Overlapping boxes share the cell of their intersection's low corner: the
  // one cell where the pair counts.
  bool owns(uint32_t t, uint32_t u, const int64_t* c) const {
    const double *lt = s.lo + 3 * size_t(t), *lu = s.lo + 3 * size_t(u);
    for (int a = 0; a < 3; ++a)
      if (s.grid.cell(lt[a] > lu[a] ? lt[a] : lu[a]) != c[a]) return false;
    return true;
  }
  // A pair with overlapping boxes, t < u: the prefilter of bounding spheres,
  // then the exact crossing test. Returns true to stop (first pair, no mark).
  // Pairs sharing one vertex are left to fan_pairs(), pairs sharing an edge
  // are never tested (the fold test's business).
  bool consider(uint32_t t, uint32_t u) {
    if (shared_vertices(t, u) != 0) return false;
    if (!spheres_meet(t, u) || !triangles_cross(x, s, t, u)) return false;
    return hit(t, u);
  }
  bool spheres_meet(uint32_t t, uint32_t u) const {
    const double* cu = s.centroid + 3 * size_t(u);
    const double* ct = s.centroid + 3 * size_t(t);
    const double dc2 = (cu[0] - ct[0]) * (cu[0] - ct[0]) + (cu[1] - ct[1]) * (cu[1] - ct[1]) + (cu[2] - ct[2]) * (cu[2] - ct[2]);
    const double reach = s.radius[t] + s.radius[u];
    return !(dc2 > reach * reach);
  }
  // A crossing pair t < u: count, mark, record.
  bool hit(uint32_t t, uint32_t u) {
    const uint32_t* a = s.tris + 3 * size_t(t);
    const uint32_t* b = s.tris + 3 * size_t(u);
    ++count;
    if (!mark) return true;
    for (int k = 0; k < 3; ++k) mark[a[k]] = mark[b[k]] = 1;
    if (record) {
      if (s.npairs < s.pair_cap) {
        s.pairs[2 * size_t(s.npairs)] = t;
        s.pairs[2 * size_t(s.npairs) + 1] = u;
        ++s.npairs;
      } else {
        s.tracked = false;
      }
    }
    return false;
  }
  // Every pair of triangles sharing exactly one vertex v, found in v's fan
  // (the triangles of its four faces that hold it), each once; with touched,
  // only the pairs with a touched triangle.
  bool fan_pairs(const uint8_t* touched) {
    for (uint32_t v = 0; v < m.nv; ++v) {
      // The fan: triangles holding v, each with its two far vertices in its
      // cyclic order after v.
      uint32_t fan[8], far[8][2];
      int k = 0;
      bool any = !touched;
      for (int i = 0; i < 4; ++i) {
        const uint32_t f = m.vfaces[4 * size_t(v) + i];
        if (f == kNone) continue;
        const uint32_t t0 = m.first_triangle(f);
        const int c = m.faces[4 * size_t(f) + 3] == kNone ? 1 : 2;
        for (int j = 0; j < c; ++j) {
          const uint32_t* q = s.tris + 3 * size_t(t0 + j);
          const int r = q[0] == v ? 0 : q[1] == v ? 1 : q[2] == v ? 2 : -1;
          if (r < 0) continue;
          fan[k] = t0 + j;
          far[k][0] = q[(r + 1) % 3];
          far[k][1] = q[(r + 2) % 3];
          any = any || touched[t0 + j];
          ++k;
        }
      }
      if (k < 2 || !any) continue;
      // One rounding bound for the whole fan: D spans the boxes of all its
      // triangles, so every four of their points (same_side_certain()'s
      // condition).
      double lo[3] = {s.lo[3 * size_t(fan[0])], s.lo[3 * size_t(fan[0]) + 1], s.lo[3 * size_t(fan[0]) + 2]};
      double hi[3] = {s.hi[3 * size_t(fan[0])], s.hi[3 * size_t(fan[0]) + 1], s.hi[3 * size_t(fan[0]) + 2]};
      for (int i = 1; i < k; ++i)
        for (int a = 0; a < 3; ++a) {
          const double l = s.lo[3 * size_t(fan[i]) + a], h = s.hi[3 * size_t(fan[i]) + a];
          lo[a] = l < lo[a] ? l : lo[a];
          hi[a] = h > hi[a] ? h : hi[a];
        }
      double D = 0;
      for (int a = 0; a < 3; ++a) D = hi[a] - lo[a] > D ? hi[a] - lo[a] : D;
      const bool filter = D > 1e-80 && D < 1e100;
      const double tol = filter ? fan_tol(D) : 0.0;
      for (int i = 0; i < k; ++i)
        for (int j = i + 1; j < k; ++j) {
          // Sharing only v: no far vertex in common (else an edge).
          if (far[i][0] == far[j][0] || far[i][0] == far[j][1] || far[i][1] == far[j][0] || far[i][1] == far[j][1])
            continue;
          const int ti = fan[i] < fan[j] ? i : j, ui = fan[i] < fan[j] ? j : i;
          const uint32_t t = fan[ti], u = fan[ui];
          if (touched && !touched[t] && !touched[u]) continue;
          if (filter && planes_apart(t, u, far[ti], far[ui], tol)) continue;
          if (!spheres_meet(t, u) || !triangles_cross(x, s, t, u)) continue;
          if (hit(t, u)) return true;
        }
    }
    return false;
  }
  // The rounding bound of same_side_certain() for points within a box of
  // largest extent D (finite, not tiny).
  static double fan_tol(double D) { return 1e-13 * D * D * D; }
  // Triangles t and u sharing one vertex, far_t / far_u their two other
  // vertices: whether the far vertices of one lie beyond doubt on one side of
  // the other's plane (then triangles_cross() says no).
  bool planes_apart(uint32_t t, uint32_t u, const uint32_t* far_t, const uint32_t* far_u, double tol) const {
    auto P = [&](uint32_t w) { return x + 3 * size_t(w); };
    return same_side_certain(s.normal + 3 * size_t(t), P(s.tris[3 * size_t(t)]), P(far_u[0]), P(far_u[1]), tol) ||
           same_side_certain(s.normal + 3 * size_t(u), P(s.tris[3 * size_t(u)]), P(far_t[0]), P(far_t[1]), tol);
  }
  // fan_pairs()' filter for one pair sharing exactly one vertex, with D
  // spanning the two boxes (so every four of their points).
  bool fan_pair_apart(uint32_t t, uint32_t u) const {
    const uint32_t* a = s.tris + 3 * size_t(t);
    const uint32_t* b = s.tris + 3 * size_t(u);
    int sa = -1, sb = -1;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (a[i] == b[j]) {
          sa = i;
          sb = j;
        }
    if (sa < 0) return false;
    const double *lt = s.lo + 3 * size_t(t), *ht = s.hi + 3 * size_t(t);
    const double *lu = s.lo + 3 * size_t(u), *hu = s.hi + 3 * size_t(u);
    double D = 0;
    for (int k = 0; k < 3; ++k) {
      const double l = lt[k] < lu[k] ? lt[k] : lu[k], h = ht[k] > hu[k] ? ht[k] : hu[k];
      D = h - l > D ? h - l : D;
    }
    if (!(D > 1e-80 && D < 1e100)) return false;
    const uint32_t far_t[2] = {a[(sa + 1) % 3], a[(sa + 2) % 3]}, far_u[2] = {b[(sb + 1) % 3], b[(sb + 2) % 3]};
    return planes_apart(t, u, far_t, far_u, fan_tol(D));
  }
  bool ordered(uint32_t t, uint32_t u) { return t < u ? consider(t, u) : consider(u, t); }
  int shared_vertices(uint32_t t, uint32_t u) const {
    const uint32_t* a = s.tris + 3 * size_t(t);
    const uint32_t* b = s.tris + 3 * size_t(u);
    int shared = 0;
    for (int i = 0; i < 3; ++i) shared += (a[i] == b[0]) + (a[i] == b[1]) + (a[i] == b[2]);
    return shared;
  }

  // Every pair of a big box t with a grid box u where skip(u) is false, through
  // the cells t overlaps, or through all boxes when that would visit more cells
  // than there are triangles.
  template <class Skip>
  bool big_vs_grid(uint32_t t, Skip&& skip) {
    const uint32_t nt = m.triangle_count();
    const double* lt = s.lo + 3 * size_t(t);
    const double* ht = s.hi + 3 * size_t(t);
    bool stop = false;
    if (s.grid.cells(lt, ht) <= double(nt)) {
      s.grid.for_each_entry(lt, ht, [&](uint32_t u, const int64_t* c) {
        if (!stop && !skip(u) && overlap(t, u) && owns(t, u, c)) stop = ordered(t, u);
      });
    } else {
      for (uint32_t u = 0; u < nt && !stop; ++u)
        if (!(s.is_big[u] & kOutside) && !skip(u) && overlap(t, u)) stop = ordered(t, u);
    }
    return stop;
  }
  // Every pair of grid boxes, by cells; stops at the first crossing pair
  // without mark.
  bool grid_pairs() {
    return s.grid.for_each_overlapping_cell_pair(s.lo, s.hi, s.tris,
                                                 [&](uint32_t t, uint32_t u) { return consider(t, u); });
  }
  // The same over the pairs with keep(t, u) only.
  template <class Keep>
  bool grid_pairs_with(Keep&& keep) {
    return s.grid.for_each_overlapping_cell_pair(s.lo, s.hi, s.tris,
                                                 [&](uint32_t t, uint32_t u) { return keep(t, u) && consider(t, u); });
  }
  // Every pair of a grid box t with a grid box u where skip(u) is false.
  template <class Skip>
  bool grid_vs_grid(uint32_t t, Skip&& skip) {
    const double* lt = s.lo + 3 * size_t(t);
    const double* ht = s.hi + 3 * size_t(t);
    bool stop = false;
    s.grid.for_each_owned_entry(lt, ht, [&](uint32_t u) {
      if (!stop && u != t && !skip(u) && overlap(t, u)) stop = ordered(t, u);
    });
    return stop;
  }
};

// BoxGrid::fits at the cell size 1 / inv_h.
bool fits_at(double inv_h, const double* lo, const double* hi) {
  for (int a = 0; a < 3; ++a)
    if (!(floor_i64(hi[a] * inv_h) - floor_i64(lo[a] * inv_h) <= 1)) return false;
  return true;
}

// The grid at cell size h or the smallest doubling of it that leaves at
// most big_cap boxes outside; the big list. With only (not nullptr) and h
// the grid's cell size, only the boxes with only[t] != 0 changed since.
// With known, the kOutside bits are already those of cell size h.
void layout_enum(const CubeSphere& m, TriangleScratch& s, double h, const uint8_t* only = nullptr,
                 bool known = false) {
  const uint32_t nt = m.triangle_count();
  for (;;) {
    s.grid.set_cell_size(h);
    s.nbig = 0;
    for (uint32_t t = 0; t < nt; ++t) {
      if (!known && (!only || only[t])) {
        const bool out = !s.grid.fits(s.lo + 3 * size_t(t), s.hi + 3 * size_t(t));
        s.is_big[t] = uint8_t((s.is_big[t] & ~kOutside) | (out ? kOutside : 0));
      }
      s.nbig += s.is_big[t] & kOutside;
    }
    if (s.nbig <= s.big_cap) break;
    h *= 2;
    only = nullptr;
    known = false;
  }
  uint32_t k = 0;
  for (uint32_t t = 0; t < nt; ++t)
    if (s.is_big[t] & kOutside) s.big[k++] = t;
  s.grid.build(s.lo, s.hi, nt, [&](uint32_t t) { return !(s.is_big[t] & kOutside); });
}

// The reference cell size for the prepared triangles (doubled until at most
// ref_cap boxes outgrow it) and their kWide bits; then the grid.
void layout_grid(const CubeSphere& m, TriangleScratch& s, double emean, double rmax) {
  const uint32_t nt = m.triangle_count();
  const double h0 = 2 * emean + 1e-9 * rmax;
  double h = h0;
  for (;;) {
    const double inv_h = 1.0 / h;
    uint32_t wide = 0;
    // At h0 the test is the grid's own (BoxGrid::fits at 1 / h0): both bits.
    const bool first = h == h0;
    for (uint32_t t = 0; t < nt; ++t) {
      const bool w = !fits_at(inv_h, s.lo + 3 * size_t(t), s.hi + 3 * size_t(t));
      s.is_big[t] = first ? (w ? kWide | kOutside : 0) : uint8_t((s.is_big[t] & kOutside) | (w ? kWide : 0));
      wide += w;
    }
    if (wide <= s.ref_cap) {
      s.ref_inv_h = inv_h;
      break;
    }
    h *= 2;
  }
  layout_enum(m, s, h0, nullptr, true);
}

// Whether any pair crosses, from the patch certificate: the windows that
// pass need no test, the clusters of the failed ones are tested against
// their whole window, and far cluster pairs with overlapping boxes pair by
// pair; each pair by the same decision as the grid path (the same boxes and
// bounding spheres, then triangles_cross). Returns 0 or 1, or -1 when the
// certificate cannot decide (too many windows fail): then the grid path.
// With mark, every pair the certificate leaves open is decided, since the
// ones it proves apart hold no crossing: the crossing pairs are the grid
// path's, counted, marked and recorded (as P.hit does), and the count is
// returned (-1 as before, nothing marked).
int certified_check(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark = nullptr) {
  PatchCertificate& c = s.cert;
  if (!c.built) c.build(m);
  const uint32_t max_failed = c.ncl / c.fail_share;
  if (!c.certify(x, s.normal, s.lo, s.hi, max_failed)) return -1;
  Pairs P{m, x, s, mark, mark != nullptr};
  auto decide = [&](uint32_t t, uint32_t u) {
    if (t == u) return false;
    if (t > u) std::swap(t, u);
    // The boxes overlap: against() passes only those, by the same six
    // comparisons of the same bounds.
    const int shared = P.shared_vertices(t, u);
    if (shared >= 2) return false;
    // Sharing one vertex (most pairs of a failed window): fan_pairs()' plane
    // filter first, which answers no only where triangles_cross() would.
    if (shared == 1 && P.fan_pair_apart(t, u)) return false;
    // hit() stops the walk only without marks.
    return P.spheres_meet(t, u) && (shared ? triangles_cross(x, s, t, u) : disjoint_cross(x, s, t, u)) &&
           P.hit(t, u);
  };
  auto cluster_tris = [&](uint32_t cl, auto&& f) {
    for (uint32_t k = c.tri_ptr[cl]; k < c.tri_ptr[cl + 1]; ++k)
      if (f(c.cl_tris[k])) return true;
    return false;
  };
  // Triangle t against the triangles of cluster d, when t's box meets d's:
  // first the box test against every triangle of d, without branches, on
  // the certificate's packed boxes (the same bounds as s.lo / s.hi), then
  // decide() on the ones that meet t's box.
  const size_t nt = c.ntri;
  const double *plx = c.pbox, *ply = plx + nt, *plz = ply + nt, *phx = plz + nt, *phy = phx + nt, *phz = phy + nt;
  // above: with a triangle id, only the triangles after it in d's list
  // (kNone: all of them).
  auto against = [&](uint32_t t, uint32_t d, uint32_t above) {
    const double *lt = s.lo + 3 * size_t(t), *ht = s.hi + 3 * size_t(t), *bd = c.box + 6 * size_t(d);
    if (bd[0] > ht[0] || lt[0] > bd[3] || bd[1] > ht[1] || lt[1] > bd[4] || bd[2] > ht[2] || lt[2] > bd[5])
      return false;
    const double l0 = lt[0], l1 = lt[1], l2 = lt[2], h0 = ht[0], h1 = ht[1], h2 = ht[2];
    constexpr int kChunk = 64;
    uint32_t cand[kChunk];
    uint32_t first = c.tri_ptr[d];
    if (above != kNone)
      while (first < c.tri_ptr[d + 1] && c.cl_tris[first++] != above) {
      }
    // The bounds in locals and the six tests joined by | rather than ||:
    // else the compiler branches on each test (about half of them
    // mispredicted) and reloads the bounds' pointers after every store to
    // cand, which might alias them.
    const double *bx0 = plx, *by0 = ply, *bz0 = plz, *bx1 = phx, *by1 = phy, *bz1 = phz;
    for (uint32_t k0 = first, end = c.tri_ptr[d + 1]; k0 < end; k0 += kChunk) {
      const uint32_t k1 = end - k0 < uint32_t(kChunk) ? end : k0 + kChunk;
      int nc = 0;
      for (uint32_t k = k0; k < k1; ++k) {
        const bool apart = (bx0[k] > h0) | (l0 > bx1[k]) | (by0[k] > h1) | (l1 > by1[k]) | (bz0[k] > h2) |
                           (l2 > bz1[k]);
        cand[nc] = k;
        nc += !apart;
      }
      for (int i = 0; i < nc; ++i)
        if (decide(t, c.cl_tris[cand[i]])) return true;
    }
    return false;
  };
  // A passing window proves every pair of its triangles, so the pairs of
  // clusters a and b need no test when some passing window holds both: a's
  // or b's own, or that of a cluster of a's window (b asked first: a is in
  // the window of nearly every cluster of its own, by symmetry).
  auto covered = [&](uint32_t a, uint32_t b) {
    if (!c.is_failed[a] && c.neighbours(a, b)) return true;
    if (!c.is_failed[b] && c.neighbours(b, a)) return true;
    const uint32_t* w = c.nb + size_t(PatchCertificate::kMaxNeighbours) * a;
    for (uint32_t k = 0; k < c.nb_cnt[a]; ++k) {
      const uint32_t e = w[k];
      if (!c.is_failed[e] && c.neighbours(e, b) && c.neighbours(e, a)) return true;
    }
    return false;
  };
  // Each remaining pair once: a failed neighbour D < C whose window holds C
  // (always, unless D's list overflowed) tests (or covers) its triangles
  // against C's, and within C a triangle meets only the ones after it.
  uint32_t todo[PatchCertificate::kMaxNeighbours];
  for (uint32_t i = 0; i < c.nfailed; ++i) {
    const uint32_t cl = c.failed[i];
    const uint32_t* w = c.nb + size_t(PatchCertificate::kMaxNeighbours) * cl;
    uint32_t nd = 0;
    for (uint32_t k = 0; k < c.nb_cnt[cl]; ++k) {
      const uint32_t d = w[k];
      if (d != cl && c.is_failed[d] && d < cl && c.neighbours(d, cl)) continue;
      if (covered(cl, d)) continue;
      todo[nd++] = d;
    }
    if (nd == 0) continue;
    const bool hit = cluster_tris(cl, [&](uint32_t t) {
      for (uint32_t k = 0; k < nd; ++k)
        if (against(t, todo[k], todo[k] == cl ? t : kNone)) return true;
      return false;
    });
    if (hit) return 1;
  }
  const bool far_hit = c.for_each_far_pair(
      [&](uint32_t a, uint32_t b) { return cluster_tris(a, [&](uint32_t t) { return against(t, b, kNone); }); });
  return mark ? int(P.count) : far_hit ? 1 : 0;
}

// The whole check from scratch; with record, also keeps the crossing pairs
// (mark must then be set).
uint32_t full_check(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark, bool record,
                    const uint8_t* alt) {
  const uint32_t nt = m.triangle_count();
  s.tracked = false;
  s.layout_pending = false;
  if (alt) {
    uint32_t t = 0;
    for (uint32_t f = 0; f < m.nfaces; ++f) t += uint32_t(face_split(m, f, alt[f] != 0, s.tris + 3 * size_t(t)));
  } else {
    triangulate(m, x, s.tris);
  }
  double rmax = 0, emean = 0;
  for (uint32_t t = 0; t < nt; ++t) {
    prepare(x, s, t, 0.0);
    const double* lo = s.lo + 3 * size_t(t);
    const double* hi = s.hi + 3 * size_t(t);
    emean += (hi[0] - lo[0]) + (hi[1] - lo[1]) + (hi[2] - lo[2]);
    rmax = fmax_inline(rmax, s.radius[t]);
  }
  if (!(rmax > 0) || !std::isfinite(rmax)) return 0;
  emean /= 3.0 * nt;
  // Candidates: pairs whose bounding boxes overlap (a crossing point lies in
  // both), each box widened by a hair against rounding.
  s.eps = 1e-9 * (emean + rmax);
  for (uint32_t q = 0; q < 3 * nt; ++q) {
    s.lo[q] -= s.eps;
    s.hi[q] += s.eps;
  }
  // The certificate answers the yes/no query, and finds the pairs of a
  // recorded check (the guard's first intersection test of a call, or a
  // tracked check starting afresh) at a fraction of the grid path's cost.
  // The tracked calls that follow a recorded check need its grid all the
  // same: laid out by the first of them (without the grid's pair search).
  if ((!mark || record) && s.certificate_enabled()) {
    s.npairs = 0;
    s.tracked = record;
    const int r = certified_check(m, x, s, mark);
    if (r >= 0) {
      s.count_certified();
      s.layout_pending = record;
      s.layout_emean = emean;
      s.layout_rmax = rmax;
      return uint32_t(r);
    }
    s.tracked = false;
  }
  layout_grid(m, s, emean, rmax);
  s.npairs = 0;
  s.tracked = record;
  Pairs P{m, x, s, mark, record};
  if (P.fan_pairs(nullptr)) return P.count;
  auto none = [](uint32_t) { return false; };
  for (uint32_t i = 0; i < s.nbig; ++i) {
    const uint32_t t = s.big[i];
    if (P.big_vs_grid(t, none)) return P.count;
    for (uint32_t j = i + 1; j < s.nbig; ++j)
      if (P.overlap(t, s.big[j]) && P.ordered(t, s.big[j])) return P.count;
  }
  // Grid boxes among themselves: every two entries of one cell, the pair
  // counted in the cell holding the low corner of the boxes' intersection
  // (the same pairs as each box querying the grid, without the lookups). A
  // box's entries have distinct keys and ids ascend within a bucket, so
  // t < u and the pair is met in that cell only.
  P.grid_pairs();
  return P.count;
}

}  // namespace

uint32_t mark_intersections(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark,
                            const uint8_t* alt) {
  return full_check(m, x, s, mark, false, alt);
}

uint32_t mark_intersections_tracked(const CubeSphere& m, const double* x, TriangleScratch& s, uint8_t* mark,
                                    const uint8_t* moved, const uint8_t* alt) {
  if (!moved || !s.tracked) return full_check(m, x, s, mark, true, alt);
  const uint32_t nt = m.triangle_count();
  // A check from scratch, decided by the patch certificate, costs about a
  // tenth of the tracked pair search per triangle (the guard's rounds on the
  // nine abdominal organs at n = 22: 0.13 against 1 us): past an eighth of
  // the triangles touched, it is the cheaper way to the same pairs.
  uint32_t ntouched = 0;
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    const uint32_t* q = m.faces + 4 * size_t(f);
    const int k = q[3] == kNone ? 3 : 4;
    bool any = false;
    for (int i = 0; i < k && !any; ++i) any = moved[q[i]] != 0;
    ntouched += any ? uint32_t(k - 2) : 0u;
  }
  if (8 * size_t(ntouched) > nt) return full_check(m, x, s, mark, true, alt);
  // The boxes are still the recorded check's.
  if (s.layout_pending) {
    layout_grid(m, s, s.layout_emean, s.layout_rmax);
    s.layout_pending = false;
  }
  // Re-split and re-measure the faces around moved vertices.
  for (uint32_t t = 0; t < nt; ++t) s.touched[t] = 0;
  ntouched = 0;
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    const uint32_t* q = m.faces + 4 * size_t(f);
    const int k = q[3] == kNone ? 3 : 4;
    bool any = false;
    for (int i = 0; i < k && !any; ++i) any = moved[q[i]] != 0;
    if (!any) continue;
    const uint32_t t0 = m.first_triangle(f);
    const int c = alt ? face_split(m, f, alt[f] != 0, s.tris + 3 * size_t(t0))
                      : face_triangles(m, f, s.tris + 3 * size_t(t0), x);
    for (int i = 0; i < c; ++i) {
      s.touched[t0 + i] = 1;
      prepare(x, s, t0 + i, s.eps);
      ++ntouched;
    }
  }
  double rmax = 0;
  for (uint32_t t = 0; t < nt; ++t) rmax = fmax_inline(rmax, s.radius[t]);
  if (!(rmax > 0) || !std::isfinite(rmax)) {
    s.tracked = false;
    return 0;
  }
  // The reference cell size stays; more boxes outgrowing it than its cap:
  // start afresh. The grid keeps its cell size (doubled when too many boxes
  // outgrew it); boxes outside it join the big ones.
  if (ntouched) {
    uint32_t wide = 0;
    for (uint32_t t = 0; t < nt; ++t) {
      if (s.touched[t]) {
        const bool w = !fits_at(s.ref_inv_h, s.lo + 3 * size_t(t), s.hi + 3 * size_t(t));
        s.is_big[t] = uint8_t((s.is_big[t] & ~kWide) | (w ? kWide : 0));
      }
      wide += (s.is_big[t] & kWide) != 0;
    }
    if (wide > s.ref_cap) return full_check(m, x, s, mark, true, alt);
    layout_enum(m, s, s.grid.cell_size(), s.touched);
  }
  // Pairs between untouched triangles stand; the others are found afresh.
  Pairs P{m, x, s, mark, true};
  uint32_t kept = 0;
  for (uint32_t i = 0; i < s.npairs; ++i) {
    const uint32_t t = s.pairs[2 * size_t(i)], u = s.pairs[2 * size_t(i) + 1];
    if (s.touched[t] || s.touched[u]) continue;
    s.pairs[2 * size_t(kept)] = t;
    s.pairs[2 * size_t(kept) + 1] = u;
    ++kept;
    const uint32_t* a = s.tris + 3 * size_t(t);
    const uint32_t* b = s.tris + 3 * size_t(u);
    for (int k = 0; k < 3; ++k) mark[a[k]] = mark[b[k]] = 1;
  }
  s.npairs = kept;
  P.count = kept;
  // Each new pair once: touched grid boxes against the grid (two touched:
  // from the lower index) and against every big box; touched big boxes
  // against untouched grid boxes and against the big boxes (two touched:
  // from the lower index). With most boxes touched (small meshes, wide
  // tapers), the grid pairs come from one walk over the cells instead, the
  // same pairs: those with a touched box.
  P.fan_pairs(s.touched);
  const bool walk = 2 * size_t(ntouched) > nt;
  if (walk) P.grid_pairs_with([&](uint32_t t, uint32_t u) { return (s.touched[t] | s.touched[u]) != 0; });
  for (uint32_t t = 0; t < nt; ++t) {
    if (!s.touched[t]) continue;
    if (!(s.is_big[t] & kOutside)) {
      if (!walk) P.grid_vs_grid(t, [&](uint32_t u) { return s.touched[u] && u < t; });
      for (uint32_t j = 0; j < s.nbig; ++j)
        if (P.overlap(t, s.big[j])) P.ordered(t, s.big[j]);
    } else {
      P.big_vs_grid(t, [&](uint32_t u) { return s.touched[u] != 0; });
      for (uint32_t j = 0; j < s.nbig; ++j) {
        const uint32_t u = s.big[j];
        if (u == t || (s.touched[u] && u < t)) continue;
        if (P.overlap(t, u)) P.ordered(t, u);
      }
    }
  }
  return P.count;
}

}  // namespace ffseg
