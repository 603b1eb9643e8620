#include "step_guard.h"

#include <cstring>
#include <utility>

#include "triangulation.h"

namespace ffseg {

namespace {

constexpr int kMaxHalvings = 6;
constexpr int kGlobalHalvings = 2;
constexpr int kLocalRounds = 8;
constexpr int kFreezeRounds = 24;
constexpr double kMinShare = 1.0 / 64;
constexpr double kTaper = 0.125;
// Adjacent triangles whose normals meet at more than 120 degrees form a fold;
// the guard refuses a little before it (cos -0.499), because a step it scales
// back can come to rest exactly on its limit, and the mesh the caller extracts
// is in floats: the Colin27 brain mask at n = 49 kept an edge at cos -0.5 in
// doubles that read -0.500003 in floats, a fold by the promise's measure.
constexpr double kFoldCos = -0.499;

void tri_normal(const double* a, const double* b, const double* c, double n[3]) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  const double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  n[0] = u[1] * w[2] - u[2] * w[1];
  n[1] = u[2] * w[0] - u[0] * w[2];
  n[2] = u[0] * w[1] - u[1] * w[0];
}

// Normal of the triangle of face f (split for positions x) holding the directed
// edge a -> b.
// tri: the face's nt triangles as face_triangles() splits it for x.
void split_edge_normal(const uint32_t* tri, int nt, uint32_t a, uint32_t b, const double* x, double n[3]) {
  for (int t = 0; t < nt; ++t) {
    const uint32_t* id = tri + 3 * t;
    for (int k = 0; k < 3; ++k)
      if (id[k] == a && id[(k + 1) % 3] == b) {
        tri_normal(x + 3 * size_t(id[0]), x + 3 * size_t(id[1]), x + 3 * size_t(id[2]), n);
        return;
      }
  }
  n[0] = n[1] = n[2] = 0;
}

void edge_triangle_normal(const CubeSphere& m, uint32_t f, uint32_t a, uint32_t b, const double* x, double n[3]) {
  uint32_t tri[6];
  split_edge_normal(tri, face_triangles(m, f, tri, x), a, b, x, n);
}

// Whether the angle between normals a and b folds: cos < kFoldCos.
// The cosine dot / sqrt(|a|^2 |b|^2), -1 for a zero normal; with
// sign_only, 1 where the dot product is not negative (no square root or
// division: the cosine is then >= 0, no fold).
double fold_cos(const double a[3], const double b[3], bool sign_only = false) {
  const double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const double l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) * (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
  if (sign_only && dot >= 0 && l > 0) return 1.0;
  return l > 0 ? dot / __builtin_sqrt(l) : -1.0;
}

bool folded(const double a[3], const double b[3]) { return fold_cos(a, b, true) < kFoldCos; }

// A triangle thinning into a needle: its altitude below kNeedle times its
// longest edge at the tested positions, and its area shrinking. Such a
// triangle is on its way through zero area, a flip, and before that its
// normal is no longer defined by the floats the caller extracts (a tube's
// wall kept needles 4e-5 mm high on 1.6 mm edges, read as a fold of 120.1
// degrees where the guard's doubles saw 119.9). It counts as the turn of that
// triangle.
constexpr double kNeedle = 0.01;

bool needle_in_making(const double n0[3], const double n1[3], const double* xs, const uint32_t* id) {
  const double l1 = n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2];
  if (!(l1 < n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2])) return false;
  double e = 0;
  for (int k = 0; k < 3; ++k) {
    const double* a = xs + 3 * size_t(id[k]);
    const double* b = xs + 3 * size_t(id[(k + 1) % 3]);
    const double d2 = (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
    e = d2 > e ? d2 : e;
  }
  // |n1| = altitude x longest edge: altitude < kNeedle e  <=>  l1 < kNeedle^2 e^2.
  return l1 < kNeedle * kNeedle * e * e;
}

// A fold at the tested positions (new normals a, b) is an offence unless the
// same edge was folded at the old positions (c, d) already and does not fold
// further: a fold that was already there may stay (the guard cannot undo it),
// but an edge held inside the margin between kFoldCos and the promise's -0.5
// must not creep past it step after step (a tube's sliver went from -0.4995
// to -0.5012 that way).
bool new_fold(const double a[3], const double b[3], const double c[3], const double d[3]) {
  if (!folded(a, b)) return false;
  return !folded(c, d) || fold_cos(a, b) < fold_cos(c, d);
}

}  // namespace

namespace {

// Offence bits of face f (the tests the face owns): kTurn << t for its
// triangle t (split at x_old) turned by 90 degrees or more; kQuadFold for a
// new fold between its two triangles; kEdgeFold << e for a new fold across
// edge e towards a face of higher index.
constexpr uint8_t kTurn = 1, kQuadFold = 4, kEdgeFold = 8;
constexpr uint8_t kDirty = 0x80;  // guard bookkeeping, never an offence

uint8_t face_offences(const CubeSphere& m, uint32_t f, const double* x_old, const double* xs) {
  uint8_t bits = 0;
  uint32_t tri[6] = {0, 0, 0, 0, 0, 0};
  const int nt = face_triangles(m, f, tri, x_old);
  for (int t = 0; t < nt; ++t) {
    const uint32_t* id = tri + 3 * t;
    double n0[3], n1[3];
    tri_normal(x_old + 3 * size_t(id[0]), x_old + 3 * size_t(id[1]), x_old + 3 * size_t(id[2]), n0);
    tri_normal(xs + 3 * size_t(id[0]), xs + 3 * size_t(id[1]), xs + 3 * size_t(id[2]), n1);
    if (!(n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] > 0) || needle_in_making(n0, n1, xs, id))
      bits |= uint8_t(kTurn << t);
  }
  const uint32_t* q = m.faces + 4 * size_t(f);
  const int k = q[3] == kNone ? 3 : 4;
  // Folds: inside the quad (between its two triangles) and across each edge.
  uint32_t tn[6] = {0, 0, 0, 0, 0, 0};
  const int ntn = face_triangles(m, f, tn, xs);
  if (nt == 2) {
    double a[3], b[3];
    tri_normal(xs + 3 * size_t(tn[0]), xs + 3 * size_t(tn[1]), xs + 3 * size_t(tn[2]), a);
    tri_normal(xs + 3 * size_t(tn[3]), xs + 3 * size_t(tn[4]), xs + 3 * size_t(tn[5]), b);
    if (folded(a, b)) {
      double c[3], d[3];
      tri_normal(x_old + 3 * size_t(tri[0]), x_old + 3 * size_t(tri[1]), x_old + 3 * size_t(tri[2]), c);
      tri_normal(x_old + 3 * size_t(tri[3]), x_old + 3 * size_t(tri[4]), x_old + 3 * size_t(tri[5]), d);
      if (new_fold(a, b, c, d)) bits |= kQuadFold;
    }
  }
  for (int e = 0; e < k; ++e) {
    const uint32_t g = m.fadj[4 * size_t(f) + e];
    if (g == kNone || g < f) continue;  // each shared edge once
    const uint32_t a = q[e], b = q[(e + 1) % k];
    double nf[3], ng[3];
    split_edge_normal(tn, ntn, a, b, xs, nf);
    edge_triangle_normal(m, g, b, a, xs, ng);
    if (!folded(nf, ng)) continue;
    double of[3], og[3];
    edge_triangle_normal(m, f, a, b, x_old, of);
    edge_triangle_normal(m, g, b, a, x_old, og);
    if (new_fold(nf, ng, of, og)) bits |= uint8_t(kEdgeFold << e);
  }
  return bits;
}

// Marks the vertices of face f's offences bits (mark may be nullptr); returns
// their count (a fold across an edge counts for both faces), or with first,
// the count up to and including the first offence.
uint32_t mark_offences(const CubeSphere& m, uint32_t f, uint8_t bits, const double* x_old, uint8_t* mark,
                       bool first) {
  uint32_t count = 0;
  const uint32_t* q = m.faces + 4 * size_t(f);
  const int k = q[3] == kNone ? 3 : 4;
  auto hit = [&](const uint32_t* ids, int c) {
    ++count;
    if (mark)
      for (int i = 0; i < c; ++i) mark[ids[i]] = 1;
  };
  if (bits & (kTurn | kTurn << 1)) {
    uint32_t tri[6] = {0, 0, 0, 0, 0, 0};
    face_triangles(m, f, tri, x_old);
    for (int t = 0; t < 2; ++t)
      if (bits & (kTurn << t)) {
        hit(tri + 3 * t, 3);
        if (first) return count;
      }
  }
  if (bits & kQuadFold) {
    hit(q, 4);
    if (first) return count;
  }
  for (int e = 0; e < k; ++e)
    if (bits & (kEdgeFold << e)) {
      const uint32_t g = m.fadj[4 * size_t(f) + e];
      hit(q, k);
      hit(m.faces + 4 * size_t(g), m.faces[4 * size_t(g) + 3] == kNone ? 3 : 4);
      if (first) return count;
    }
  return count;
}

}  // namespace

uint32_t mark_violations(const CubeSphere& m, const double* x_old, const double* xs, uint8_t* mark) {
  uint32_t count = 0;
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    const uint8_t bits = face_offences(m, f, x_old, xs);
    if (!bits) continue;
    count += mark_offences(m, f, bits, x_old, mark, mark == nullptr);
    if (!mark) return count;
  }
  return count;
}

namespace {

// The guard's fold test on cached splits and normals (ts.face_*): the same
// tri_normal() of the same vertices in the same order as face_offences(), so
// the same bits. cache_face: face f split at x and its triangles' normals.
void cache_face(const CubeSphere& m, uint32_t f, const double* x, double* n, uint8_t* alt) {
  const uint32_t* q = m.faces + 4 * size_t(f);
  double* nf = n + 6 * size_t(f);
  const double *p0 = x + 3 * size_t(q[0]), *p1 = x + 3 * size_t(q[1]), *p2 = x + 3 * size_t(q[2]);
  if (q[3] == kNone) {
    alt[f] = 0;
    tri_normal(p0, p1, p2, nf);
    return;
  }
  // face_triangles()' split decision, whose two candidate splits' normals
  // are the triangles' tri_normal()s (same vertices, same order).
  const double* p3 = x + 3 * size_t(q[3]);
  double a0[3], a1[3], b0[3], b1[3];
  double c02, c13;
  detail::split_cos_both(p0, p1, p2, p3, &c02, &c13, a0, a1, b0, b1);
  const bool al = detail::split_alt(c02, c13);
  alt[f] = al;
  for (int k = 0; k < 3; ++k) {
    nf[k] = al ? b0[k] : a0[k];
    nf[3 + k] = al ? b1[k] : a1[k];
  }
}

// split_edge_normal() from the cache: of the cached normals n of face f
// (split alt), the one of the triangle holding the face's edge i (from
// corner i to the next). A quad's split keeps its orientation, and each of
// its edges lies in one triangle: edges 0 and 1 in the first of the 0-2
// split, 1 and 2 in the first of the 1-3 split (face_split()), so the
// edge's place in the face decides.
inline const double* cached_edge_normal(int k, bool alt, int i, const double* n) {
  return n + (k == 3 ? 0 : alt ? (i == 1 || i == 2 ? 0 : 3) : (i < 2 ? 0 : 3));
}

// The place in face g of its directed edge a -> b, or -1.
inline int edge_place(const CubeSphere& m, uint32_t g, uint32_t a, uint32_t b, int* k) {
  const uint32_t* q = m.faces + 4 * size_t(g);
  *k = q[3] == kNone ? 3 : 4;
  for (int i = 0; i < *k; ++i)
    if (q[i] == a && q[i + 1 < *k ? i + 1 : 0] == b) return i;
  return -1;
}

uint8_t face_offences_cached(const CubeSphere& m, uint32_t f, const double* xs, const TriangleScratch& ts) {
  uint8_t bits = 0;
  const bool alt_old = ts.face_alt_old[f], alt_new = ts.face_alt_new[f];
  const double* no = ts.face_n_old + 6 * size_t(f);
  const double* nn = ts.face_n_new + 6 * size_t(f);
  uint32_t tri[6] = {0, 0, 0, 0, 0, 0};
  const int nt = face_split(m, f, alt_old, tri);
  for (int t = 0; t < nt; ++t) {
    const uint32_t* id = tri + 3 * t;
    const double* n0 = no + 3 * t;
    double n1s[3];
    const double* n1 = nn + 3 * t;
    if (alt_old != alt_new) {
      tri_normal(xs + 3 * size_t(id[0]), xs + 3 * size_t(id[1]), xs + 3 * size_t(id[2]), n1s);
      n1 = n1s;
    }
    if (!(n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2] > 0) || needle_in_making(n0, n1, xs, id))
      bits |= uint8_t(kTurn << t);
  }
  const uint32_t* q = m.faces + 4 * size_t(f);
  const int k = q[3] == kNone ? 3 : 4;
  if (nt == 2) {
    if (new_fold(nn, nn + 3, no, no + 3)) bits |= kQuadFold;
  }
  for (int e = 0; e < k; ++e) {
    const uint32_t g = m.fadj[4 * size_t(f) + e];
    if (g == kNone || g < f) continue;  // each shared edge once
    // The shared edge runs a -> b in f (its edge e) and b -> a in g.
    int kg = 0;
    const int j = edge_place(m, g, q[(e + 1) % k], q[e], &kg);
    static const double kZero[3] = {0, 0, 0};
    const double* nf = cached_edge_normal(k, alt_new, e, nn);
    const double* ng = j < 0 ? kZero : cached_edge_normal(kg, ts.face_alt_new[g], j, ts.face_n_new + 6 * size_t(g));
    if (!folded(nf, ng)) continue;
    const double* of = cached_edge_normal(k, alt_old, e, no);
    const double* og = j < 0 ? kZero : cached_edge_normal(kg, ts.face_alt_old[g], j, ts.face_n_old + 6 * size_t(g));
    if (new_fold(nf, ng, of, og)) bits |= uint8_t(kEdgeFold << e);
  }
  return bits;
}

// Face f's cache at xs and that of its higher edge neighbours (what its
// test reads), each once (done: the faces refreshed so far).
inline void cache_for_test(const CubeSphere& m, uint32_t f, const double* xs, TriangleScratch& ts, uint8_t* done) {
  if (!done[f]) cache_face(m, f, xs, ts.face_n_new, ts.face_alt_new);
  done[f] = 1;
  const int k = m.faces[4 * size_t(f) + 3] == kNone ? 3 : 4;
  for (int e = 0; e < k; ++e) {
    const uint32_t g = m.fadj[4 * size_t(f) + e];
    if (g == kNone || g < f || done[g]) continue;
    cache_face(m, g, xs, ts.face_n_new, ts.face_alt_new);
    done[g] = 1;
  }
}

// Whether any face offends at xs. The cache at xs is refreshed face by face
// as the test reaches it (a face's test reads its own and its higher
// neighbours' entries), so a test that finds an offence early skips the
// splits of the faces after it: most line-search tests fail (two in three
// in the nine abdominal organs), and nothing reads the cache of a failed
// test (the next test refreshes it; ts.face_new_partial tells guard_step()
// not to keep it). ts.face_flags marks the faces done: its per-face
// offences are written from scratch by the next round's mark_offending().
// *first (kNone: none): a face asked before the others (LastOffence; the
// walk up to it would redo every face before it), then the offending face
// found. A face's test reads only its own cache entries and its higher
// neighbours', each a function of xs alone, so the face asked first gives
// the walk's answer for it, and whether any face offends does not hang on
// the order they are asked in.
bool any_violation(const CubeSphere& m, const double* xs, TriangleScratch& ts, uint32_t* first) {
  uint8_t* done = ts.face_flags;
  for (uint32_t f = 0; f < m.nfaces; ++f) done[f] = 0;
  if (*first != kNone) {
    cache_for_test(m, *first, xs, ts, done);
    if (face_offences_cached(m, *first, xs, ts)) {
      ts.face_new_partial = true;
      return true;
    }
  }
  for (uint32_t f = 0; f < m.nfaces; ++f) {
    cache_for_test(m, f, xs, ts, done);
    if (face_offences_cached(m, f, xs, ts)) {
      ts.face_new_partial = true;
      *first = f;
      return true;
    }
  }
  ts.face_new_partial = false;
  return false;
}

// What the last failed test of one update found: the line search tries the
// update at shrinking scales, and what offended at one scale mostly offends
// at the next (the nine abdominal organs: the same first face in four tests
// in five; where the contacts failed, they failed at every scale in 63 of 67
// guard calls).
struct LastOffence {
  uint32_t face = kNone;  // any_violation()'s first offending face
  bool contact = false;   // the fold test passed and the contacts failed
};

// The fold test, then the contacts with the obstacles (when the mesh is far
// from them a bounding-box reject, cheaper than the self-intersection
// test), then the intersections. The answer is whether any of the three
// fails, so last only chooses what is asked first: after contacts that
// failed, they are asked before the fold test (their splits then decided
// from xs, as the fold test's cache would have had them: the same function
// of the same bits); a fold test skipped leaves its cache stale
// (face_new_partial).
bool violates(const CubeSphere& m, const double* xs, TriangleScratch& ts, ContactScratch* obstacles,
              LastOffence& last) {
  const bool asked = last.contact && obstacles;
  if (asked) {
    if (mark_contacts(m, xs, *obstacles, nullptr) > 0) {
      ts.face_new_partial = true;
      return true;
    }
    last.contact = false;  // asked, and free: not again
  }
  if (any_violation(m, xs, ts, &last.face)) return true;
  if (!asked && obstacles && mark_contacts(m, xs, *obstacles, nullptr, ts.face_alt_new) > 0) {
    last.contact = true;
    return true;
  }
  return mark_intersections(m, xs, ts, nullptr, ts.face_alt_new) > 0;
}

// share[v] held within kTaper of each neighbour's, the minimum kept in a
// register: a neighbour is never v itself, so the same values. A vertex
// relaxed since its neighbours' shares last fell is within kTaper of each
// (shares only fall during a guard call, and start equal), and relaxing it
// again changes nothing; unsettled[v] marks the others. So the sweeps relax
// those alone, in the same order, with the same values, and a share that
// falls unsettles its neighbours (and sets changed[v]).
inline __attribute__((always_inline)) void relax(const CubeSphere& m, double* share, uint8_t* unsettled,
                                                 uint8_t* changed, size_t v) {
  if (!unsettled[v]) return;
  unsettled[v] = 0;
  const uint32_t* nb = m.nbr + 4 * v;
  double sv = share[v];
  for (int k = 0; k < 4; ++k) {
    const double lim = share[nb[k]] + kTaper;
    sv = sv > lim ? lim : sv;
  }
  if (sv == share[v]) return;
  share[v] = sv;
  changed[v] = 1;
  for (int k = 0; k < 4; ++k) unsettled[nb[k]] = 1;
}

// Two forward and backward sweeps of relax() over the unsettled vertices.
void relax_sweeps(const CubeSphere& m, double* share, uint8_t* unsettled, uint8_t* changed) {
  const size_t nv = m.nv;
  for (int sweep = 0; sweep < 2; ++sweep) {
    for (size_t v = 0; v < nv; ++v) relax(m, share, unsettled, changed, v);
    for (size_t v = nv; v-- > 0;) relax(m, share, unsettled, changed, v);
  }
}

// A vertex's share fell (or may have): its neighbours are unsettled.
inline void unsettle_around(const CubeSphere& m, uint8_t* unsettled, size_t v) {
  const uint32_t* nb = m.nbr + 4 * v;
  for (int k = 0; k < 4; ++k) unsettled[nb[k]] = 1;
}

bool same_bits(double a, double b) {
  uint64_t x, y;
  std::memcpy(&x, &a, sizeof x);
  std::memcpy(&y, &b, sizeof y);
  return x == y;
}

// xs = x_old + g share (x_new - x_old) per vertex; moved (may be nullptr)
// receives which vertices' positions changed bit for bit.
inline __attribute__((always_inline)) bool blend_vertex(size_t nv, const double* x_old, const double* x_new,
                                                        double g, const double* share, double* xs, size_t v) {
  bool changed = false;
  for (int c = 0; c < 3; ++c) {
    const double o = x_old[3 * v + c];
    const double p = o + g * share[v] * (x_new[c * nv + v] - o);
    changed |= !same_bits(p, xs[3 * v + c]);
    xs[3 * v + c] = p;
  }
  return changed;
}

void blend(size_t nv, const double* x_old, const double* x_new, double g, const double* share, double* xs,
           uint8_t* moved) {
  for (size_t v = 0; v < nv; ++v) {
    const bool changed = blend_vertex(nv, x_old, x_new, g, share, xs, v);
    if (moved) moved[v] = changed;
  }
}

// The rounds' blend at g = 1 when xs holds the last one's and only the
// vertices with moved[v] set may have changed their share since: blend()
// of these alone (the others' positions are the same bits), moved[v] then
// telling whether they moved, as blend() does.
void blend_changed(size_t nv, const double* x_old, const double* x_new, const double* share, double* xs,
                   uint8_t* moved) {
  for (size_t v = 0; v < nv; ++v)
    if (moved[v]) moved[v] = blend_vertex(nv, x_old, x_new, 1.0, share, xs, v);
}

// Marks (ts.vertex_marks) and counts every offence (turn or fold) at xs.
// moved == nullptr: from scratch; otherwise xs differs from the previous
// call's positions only at the vertices with moved[v] != 0, and only the
// faces around them are tested again (ts.face_flags keeps each face's
// offences).
uint32_t mark_offending(const CubeSphere& m, const double* x_old, const double* xs, const uint8_t* moved,
                        TriangleScratch& ts) {
  uint8_t* flags = ts.face_flags;
  uint8_t* mark = ts.vertex_marks;
  for (size_t v = 0; v < m.nv; ++v) mark[v] = 0;
  uint32_t count = 0;
  if (!moved) {
    for (uint32_t f = 0; f < m.nfaces; ++f) cache_face(m, f, xs, ts.face_n_new, ts.face_alt_new);
    ts.face_new_partial = false;
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      flags[f] = face_offences_cached(m, f, xs, ts);
      if (flags[f]) count += mark_offences(m, f, flags[f], x_old, mark, false);
    }
  } else {
    // A face's tests read its own vertices and the cache of its higher edge
    // neighbours (the fold across an edge is tested by the lower face).
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      const uint32_t* q = m.faces + 4 * size_t(f);
      const int k = q[3] == kNone ? 3 : 4;
      for (int i = 0; i < k; ++i)
        if (moved[q[i]]) {
          flags[f] |= kDirty;
          cache_face(m, f, xs, ts.face_n_new, ts.face_alt_new);
          break;
        }
    }
    // Only lower faces read a face's dirty bit: the walk clears it as it
    // passes, and marks each face's offences there.
    for (uint32_t f = 0; f < m.nfaces; ++f) {
      const uint32_t* q = m.faces + 4 * size_t(f);
      const int k = q[3] == kNone ? 3 : 4;
      bool dirty = flags[f] & kDirty;
      for (int e = 0; e < k && !dirty; ++e) {
        const uint32_t g = m.fadj[4 * size_t(f) + e];
        dirty = g != kNone && g > f && (flags[g] & kDirty);
      }
      flags[f] = dirty ? face_offences_cached(m, f, xs, ts) : uint8_t(flags[f] & ~kDirty);
      if (flags[f]) count += mark_offences(m, f, flags[f], x_old, mark, false);
    }
  }
  return count;
}

// The guard's local rounds' test at xs (moved as for mark_offending): the
// offences, and only when there are none, the intersections too (marked in
// ts.vertex_marks as well). Folds first: while a round still folds, the
// next round halves around the folds anyway, and the intersection test
// (most of a round's cost) waits; ts.vertex_pending gathers the vertices
// moved since it last ran, so that it goes on from its tracked pairs. *tracked:
// whether it has run in this guard call (then incrementally).
// Contacts with the obstacles (when given) are marked with the offences, a
// round's cheap tests, and tracked from round to round as the intersections
// are (the splits mark_offending() leaves in ts.face_alt_new are theirs).
uint32_t mark_all(const CubeSphere& m, const double* x_old, const double* xs, const uint8_t* moved,
                  TriangleScratch& ts, bool* tracked, ContactScratch* obstacles) {
  uint32_t count = mark_offending(m, x_old, xs, moved, ts);
  if (obstacles) count += mark_contacts_tracked(m, xs, *obstacles, ts.vertex_marks, moved, ts.face_alt_new);
  uint8_t* pending = ts.vertex_pending;
  if (moved)
    for (size_t v = 0; v < m.nv; ++v) pending[v] |= moved[v];
  if (count > 0) return count;
  // The first test of a guard call is a recorded check from scratch: the
  // patch certificate decides it as cheaply as the yes/no query when the
  // round is clean (which usually ends the rounds), and finds the pairs of
  // a crossing without a second check.
  const uint32_t pairs =
      mark_intersections_tracked(m, xs, ts, ts.vertex_marks, *tracked ? pending : nullptr, ts.face_alt_new);
  *tracked = true;
  for (size_t v = 0; v < m.nv; ++v) pending[v] = 0;
  return pairs;
}

}  // namespace

void GuardCache::carve(Arena& a, const CubeSphere& m) {
  n = a.alloc<double>(size_t(6) * m.nfaces);
  alt = a.alloc<uint8_t>(m.nfaces);
  key = a.alloc<double>(size_t(3) * m.nv);
  valid = false;
}

void guard_region(const CubeSphere& m, const double* x_old, const double* x_new, double region[6]) {
  // Every tested position is x_old + f (x_new - x_old) with 0 <= f <= 1 per
  // vertex: between the two per axis (build_obstacles() widens the box
  // against the rounding of the blend).
  const size_t nv = m.nv;
  for (int a = 0; a < 3; ++a) {
    double lo = x_old[a], hi = x_old[a];
    for (size_t v = 0; v < nv; ++v) {
      const double o = x_old[3 * v + a], p = x_new[a * nv + v];
      lo = o < lo ? o : lo;
      hi = o > hi ? o : hi;
      lo = p < lo ? p : lo;
      hi = p > hi ? p : hi;
    }
    region[a] = lo;
    region[3 + a] = hi;
  }
}

double guard_step(const CubeSphere& m, const double* x_old, double* x_new, double* xs, double* share,
                  uint8_t* mark, uint8_t* grow, TriangleScratch& ts, ContactScratch* obstacles, GuardCache* keep) {
  // First a line search along the whole solved update: the largest s in
  // {1, 1/2, 1/4} that turns no triangle by 90 degrees and folds no edge.
  // Scaling the whole update keeps it smooth.
  const size_t nv = m.nv;
  // Splits and normals at x_old, fixed for the whole step: the last step's
  // cache at its accepted positions when these are x_old bit for bit (the
  // same function of the same bits), else computed. An object's own cache
  // is copied, not swapped in: it lies outside the engine, whose layout
  // check allows its own buffers to trade places only among themselves.
  if (keep && keep->valid && std::memcmp(keep->key, x_old, 3 * nv * sizeof(double)) == 0) {
    std::memcpy(ts.face_n_old, keep->n, 6 * size_t(m.nfaces) * sizeof(double));
    std::memcpy(ts.face_alt_old, keep->alt, m.nfaces);
    ts.count_reused_cache();
  } else if (!keep && ts.new_key_valid && std::memcmp(ts.new_key, x_old, 3 * nv * sizeof(double)) == 0) {
    std::swap(ts.face_n_old, ts.face_n_new);
    std::swap(ts.face_alt_old, ts.face_alt_new);
    ts.count_reused_cache();
  } else {
    for (uint32_t f = 0; f < m.nfaces; ++f) cache_face(m, f, x_old, ts.face_n_old, ts.face_alt_old);
  }
  if (keep) keep->valid = false;
  ts.new_key_valid = false;
  // Every position set tested below lies between x_old and x_new.
  if (obstacles) sweep_obstacles(m, x_old, x_new, *obstacles);
  for (size_t v = 0; v < nv; ++v) share[v] = 1.0;
  double s = 1.0;
  blend(nv, x_old, x_new, s, share, xs, nullptr);
  int halvings = 0;
  // What failed the object's last line search is asked first here too: an
  // offence often outlasts a step (the nine abdominal organs' line-search
  // tests: 0.53 G -> 0.42 G instructions with it).
  LastOffence offender;
  if (keep && keep->offence_face < m.nfaces) offender.face = keep->offence_face;
  if (keep) offender.contact = keep->offence_contact;
  bool bad = violates(m, xs, ts, obstacles, offender);
  while (bad && halvings < kGlobalHalvings) {
    ++halvings;
    s *= 0.5;
    blend(nv, x_old, x_new, s, share, xs, nullptr);
    bad = violates(m, xs, ts, obstacles, offender);
  }
  if (keep) {
    keep->offence_face = offender.face;
    keep->offence_contact = offender.contact;
  }
  for (size_t v = 0; v < nv; ++v) share[v] = s;
  // Still offending: one region holds the step back. Every share starts again
  // from 1; the offenders' vertices (and their neighbours) halve theirs, shares
  // taper back over a few rings around them, so the rest of the mesh keeps
  // moving at full speed; after kLocalRounds the whole update is halved on top
  // (down to nothing).
  bool clean = !bad;
  if (!clean) {
    for (size_t v = 0; v < nv; ++v) share[v] = 1.0;
    blend(nv, x_old, x_new, 1.0, share, xs, nullptr);
  }
  // Each round's test of its new positions also gives the next round's marks
  // (ts.vertex_marks); the first round marks from scratch.
  uint8_t* moved = ts.vertex_flags;
  bool tracked = false;  // mark_all's first intersection test is from scratch
  // The rounds' marks are read where mark_all() leaves them (ts.vertex_marks);
  // mark holds the relax sweeps' unsettled vertices, none while the shares
  // are all equal.
  uint8_t* unsettled = mark;
  if (!clean)
    for (size_t v = 0; v < nv; ++v) unsettled[v] = 0;
  for (int round = 0; round < kLocalRounds && !clean; ++round) {
    if (round == 0) mark_all(m, x_old, xs, nullptr, ts, &tracked, obstacles);
    const uint8_t* marked = ts.vertex_marks;
    for (size_t v = 0; v < nv; ++v) {
      grow[v] = marked[v];
      if (!marked[v]) continue;
      const uint32_t* nb = m.nbr + 4 * v;
      for (int k = 0; k < 4; ++k) grow[nb[k]] = 1;
    }
    for (size_t v = 0; v < nv; ++v) {
      moved[v] = grow[v];
      if (!grow[v]) continue;
      share[v] = share[v] * 0.5 < kMinShare ? 0.0 : share[v] * 0.5;
      unsettle_around(m, unsettled, v);
    }
    relax_sweeps(m, share, unsettled, moved);
    blend_changed(nv, x_old, x_new, share, xs, moved);
    clean = mark_all(m, x_old, xs, moved, ts, &tracked, obstacles) == 0;
  }
  // Still offending after the halving rounds: the offenders' vertices and
  // their neighbours stop outright (share 0, x_old there is clean), a round
  // at a time, so that a jammed patch holds only itself back and the rest of
  // the mesh keeps its step (whole-update halving froze every vertex of a
  // fine mesh when one patch kept crossing: the liver at 1 mm, n = 49, stood
  // still at 15% of its volume). A round's test is the local rounds' one
  // (mark_all: the offences of the faces around the moved vertices, the
  // contacts and the intersections tracked from the pairs of its first check,
  // every one exact for the positions tested), so a clean round is accepted
  // as a clean local round is: a check from scratch after it cost the 1 mm
  // liver's jammed steps 17-19 ms each and never found anything.
  for (int round = 0; round < kFreezeRounds && !clean; ++round) {
    const uint8_t* marked = ts.vertex_marks;
    for (size_t v = 0; v < nv; ++v) moved[v] = 0;
    for (size_t v = 0; v < nv; ++v) {
      if (!marked[v]) continue;
      share[v] = 0;
      moved[v] = 1;
      unsettle_around(m, unsettled, v);
      const uint32_t* nb = m.nbr + 4 * v;
      for (int k = 0; k < 4; ++k) {
        share[nb[k]] = 0;
        moved[nb[k]] = 1;
        unsettle_around(m, unsettled, nb[k]);
      }
    }
    relax_sweeps(m, share, unsettled, moved);
    blend_changed(nv, x_old, x_new, share, xs, moved);
    clean = mark_all(m, x_old, xs, moved, ts, &tracked, obstacles) == 0;
  }
  double g = 1.0;
  for (int h = 0; !clean; ++h) {
    if (h >= kMaxHalvings) {
      g = 0;
      break;
    }
    g *= 0.5;
    blend(nv, x_old, x_new, g, share, xs, nullptr);
    clean = !violates(m, xs, ts, obstacles, offender);
  }
  double kept = 0;
  // Whether the accepted positions are the last tested ones (xs), whose
  // splits and normals the face_*_new cache holds: then they are its key.
  bool tested = true;
  for (size_t v = 0; v < nv; ++v) {
    const double f = g * share[v];
    share[v] = f;  // the caller reads each vertex's kept share
    kept += f;
    for (int c = 0; c < 3; ++c) {
      double& p = x_new[c * nv + v];
      const double o = x_old[3 * v + c];
      p = o + f * (p - o);
      tested = tested && same_bits(p, xs[3 * v + c]);
    }
  }
  if (tested && !ts.face_new_partial) {
    if (keep) {
      std::memcpy(keep->n, ts.face_n_new, 6 * size_t(m.nfaces) * sizeof(double));
      std::memcpy(keep->alt, ts.face_alt_new, m.nfaces);
      std::memcpy(keep->key, xs, 3 * nv * sizeof(double));
      keep->valid = true;
    } else {
      std::memcpy(ts.new_key, xs, 3 * nv * sizeof(double));
      ts.new_key_valid = true;
    }
  }
  return nv ? kept / double(nv) : 1.0;
}

}  // namespace ffseg
