// A hashed uniform grid over points, held in workspace memory: counting sort
// of point ids by cell hash, rebuilt in O(points). Queries visit the cells
// overlapping a box (or a ball's bounding box) and report each point once:
// every point keeps its packed cell coordinates, so a bucket shared by two
// cells of one query (a hash collision) is not read twice.
#pragma once
#include <algorithm>
#include <cstdint>

#include "arena.h"

namespace ffseg {

// floor(v) as an integer, inline (no libm call). Beyond +-2^60 (a box of a
// mesh gone far off, a sphere of 1e300 mm) it saturates there, and NaN reads
// 0: converting such a double would be undefined, and the saturated cells
// still tell a grid that the box does not fit (differences stay in range).
inline int64_t floor_i64(double v) {
  constexpr double kLimit = 1152921504606846976.0;  // 2^60
  if (!(v > -kLimit && v < kLimit)) return v > 0 ? int64_t(1) << 60 : (v < 0 ? -(int64_t(1) << 60) : 0);
  const int64_t i = int64_t(v);
  return i - (v < double(i));
}

// What both grids share: a power-of-two table of buckets over hashed integer
// cells of size 1 / inv_h_, and a counting sort of entries into it (count
// per bucket, prefix sums, scatter with start_ as a cursor, shift back).
class CellTable {
 public:
  int64_t cell(double v) const { return floor_i64(v * inv_h_); }
  // The cells a box overlaps, a[k]..b[k] per axis: a query that first asks
  // how many (count()) and then visits them computes them once.
  struct Range {
    int64_t a[3], b[3];
  };
  Range range_of(const double* lo, const double* hi) const {
    Range r;
    for (int k = 0; k < 3; ++k) {
      r.a[k] = cell(lo[k]);
      r.b[k] = cell(hi[k]);
    }
    return r;
  }
  // Number of cells (as a double: may be huge).
  static double count(const Range& r) {
    double c = 1;
    for (int k = 0; k < 3; ++k) c *= double(r.b[k] - r.a[k] + 1);
    return c;
  }
  // Buckets for the next build: at least 2 * cells (as carved for the most),
  // fewer when a build enters far fewer than the most (the grid of the
  // obstacles a step meets): every build pass and lookup then walks a table
  // that fits the entries instead of the capacity. Which entries a query
  // meets, and in which order, does not depend on it.
  void size_table(uint32_t cells) {
    table_ = 1;
    while (table_ < 2 * cells && table_ < table_cap_) table_ <<= 1;
    mask_ = table_ - 1;
  }

 protected:
  // At least 2 * cells buckets; room for `entries` ids.
  void carve_table(Arena& a, uint32_t cells, uint32_t entries) {
    table_ = 1;
    while (table_ < 2 * cells) table_ <<= 1;
    mask_ = table_ - 1;
    table_cap_ = table_;
    start_ = a.alloc<uint32_t>(size_t(table_) + 1);
    ids_ = a.alloc<uint32_t>(entries);
  }
  uint32_t hash(int64_t x, int64_t y, int64_t z) const {
    const uint64_t h = uint64_t(x) * 73856093u ^ uint64_t(y) * 19349663u ^ uint64_t(z) * 83492791u;
    return uint32_t(h & mask_);
  }
  // Whether pred(x, y, z) holds for some cell of the range; stops at the
  // first.
  template <class P>
  bool any_cell_of(const Range& r, P&& pred) const {
    for (int64_t z = r.a[2]; z <= r.b[2]; ++z)
      for (int64_t y = r.a[1]; y <= r.b[1]; ++y)
        for (int64_t x = r.a[0]; x <= r.b[0]; ++x)
          if (pred(x, y, z)) return true;
    return false;
  }
  // Calls f(x, y, z) for every cell the box [lo, hi] overlaps.
  template <class F>
  void for_each_cell_of(const Range& r, F&& f) const {
    any_cell_of(r, [&](int64_t x, int64_t y, int64_t z) {
      f(x, y, z);
      return false;
    });
  }
  template <class F>
  void for_each_cell_of(const double* lo, const double* hi, F&& f) const {
    for_each_cell_of(range_of(lo, hi), f);
  }
  // Counting sort: clear, ++start_[bucket + 1] per entry, then starts(),
  // then ids_[start_[bucket]++] = id per entry, then restore().
  void clear_counts() {
    for (uint32_t b = 0; b <= table_; ++b) start_[b] = 0;
  }
  void starts() {
    for (uint32_t b = 0; b < table_; ++b) start_[b + 1] += start_[b];
  }
  void restore() {
    for (uint32_t b = table_; b > 0; --b) start_[b] = start_[b - 1];
    start_[0] = 0;
  }

  uint32_t table_ = 0, mask_ = 0, table_cap_ = 0;
  uint32_t* start_ = nullptr;  // table_ + 1
  uint32_t* ids_ = nullptr;    // entries, sorted by bucket
  double inv_h_ = 1;
};

class SpatialGrid : public CellTable {
 public:
  void carve(Arena& a, uint32_t max_points);
  // pts: 3 * count coordinates; h: cell size (> 0).
  void build(const double* pts, uint32_t count, double h) {
    build_if(pts, count, h, [](uint32_t) { return true; });
  }
  // The same over the points i < count with keep(i) only.
  template <class Keep>
  void build_if(const double* pts, uint32_t count, double h, Keep&& keep);

  // Calls f(id) once for every point within r of c (ids are indices into pts).
  template <class F>
  void for_each_in_ball(const double c[3], double r, F&& f) const {
    for_each_in_ball_unless(c, r, [](uint32_t) { return false; }, f);
  }
  // The same, passing over the buckets for which skip(first) holds, first
  // being the bucket's first slot in bucket order (see for_each_bucket): a
  // caller that knows from a bucket's summary that none of its points
  // matters spares their distance tests.
  template <class Skip, class F>
  void for_each_in_ball_unless(const double c[3], double r, Skip&& skip, F&& f) const {
    const double r2 = r * r;
    const double lo[3] = {c[0] - r, c[1] - r, c[2] - r}, hi[3] = {c[0] + r, c[1] + r, c[2] + r};
    // A cell's points are tested in a row, from their copies in bucket
    // order and without a branch (inside or not is a coin toss: a third of
    // the candidates of a ball lie in it), and the ones inside are listed
    // for f, in the same order.
    constexpr uint32_t kChunk = 64;
    uint32_t in[kChunk];
    for_each_cell_of(lo, hi, [&](int64_t x, int64_t y, int64_t z) {
      const uint32_t h = hash(x, y, z);
      const uint64_t pc = pack(x, y, z);
      const uint32_t first = start_[h], end = start_[h + 1];
      if (first == end || skip(first)) return;
      for (uint32_t k0 = first; k0 < end; k0 += kChunk) {
        const uint32_t k1 = end - k0 < kChunk ? end : k0 + kChunk;
        const uint32_t n = in_ball(k0, k1, pc, c, r2, in);
        for (uint32_t i = 0; i < n; ++i) f(in[i]);
      }
    });
  }
  // The ids of slots k0 <= k < k1 in cell pc within sqrt(r2) of c, in slot
  // order, into in; returns how many. Not inlined: inside the callers'
  // loops (the fold prevention's conflict test around it) the compiler ran
  // out of registers and kept this loop's pointers and key on the stack.
  __attribute__((noinline)) uint32_t in_ball(uint32_t k0, uint32_t k1, uint64_t pc, const double c[3], double r2,
                                             uint32_t* in) const {
    const double cx = c[0], cy = c[1], cz = c[2];
    const double* sorted = sorted_;
    const uint64_t* key = cellkey_;
    const uint32_t* ids = ids_;
    uint32_t n = 0;
    for (uint32_t k = k0; k < k1; ++k) {
      const double* p = sorted + 3 * size_t(k);
      const double dx = p[0] - cx, dy = p[1] - cy, dz = p[2] - cz;
      in[n] = ids[k];
      n += uint32_t((key[k] == pc) & (dx * dx + dy * dy + dz * dz <= r2));
    }
    return n;
  }

  // Calls f(first, end) for every bucket holding points: its slots in
  // bucket order are first <= k < end (id_at(k) the point of slot k). A
  // caller may keep one summary per bucket at its first slot (distinct
  // buckets have distinct first slots; room for as many slots as points).
  template <class F>
  void for_each_bucket(F&& f) const {
    for (uint32_t b = 0; b < table_; ++b)
      if (start_[b] < start_[b + 1]) f(start_[b], start_[b + 1]);
  }
  uint32_t id_at(uint32_t k) const { return ids_[k]; }

  // Calls f(id) once for every point whose cell overlaps the box [lo, hi]
  // (a superset of the points inside it; the caller filters).
  template <class F>
  void for_each_in_cells(const double lo[3], const double hi[3], F&& f) const {
    for_each_cell_of(lo, hi, [&](int64_t x, int64_t y, int64_t z) {
      const uint32_t h = hash(x, y, z);
      const uint64_t pc = pack(x, y, z);
      for (uint32_t k = start_[h]; k < start_[h + 1]; ++k)
        if (cellkey_[k] == pc) f(ids_[k]);
    });
  }

 private:
  // 21 bits per axis: two cells of one query never differ by 2^21 on an axis.
  static uint64_t pack(int64_t x, int64_t y, int64_t z) {
    return (uint64_t(x) & 0x1FFFFF) | (uint64_t(y) & 0x1FFFFF) << 21 | (uint64_t(z) & 0x1FFFFF) << 42;
  }

  uint64_t* cellkey_ = nullptr;  // max points: packed cell of ids_[k]
  uint32_t* key_ = nullptr;      // max points: bucket of point i (build only)
  double* sorted_ = nullptr;     // 3 per max point: the coordinates of ids_[k]
  const double* pts_ = nullptr;
};

template <class Keep>
void SpatialGrid::build_if(const double* pts, uint32_t count, double h, Keep&& keep) {
  pts_ = pts;
  inv_h_ = 1.0 / h;
  clear_counts();
  for (uint32_t i = 0; i < count; ++i) {
    if (!keep(i)) {
      key_[i] = table_;  // not inserted
      continue;
    }
    const double* p = pts + 3 * size_t(i);
    key_[i] = hash(cell(p[0]), cell(p[1]), cell(p[2]));
    ++start_[key_[i] + 1];
  }
  starts();
  for (uint32_t i = 0; i < count; ++i) {
    if (key_[i] == table_) continue;
    const double* p = pts + 3 * size_t(i);
    const uint32_t k = start_[key_[i]]++;
    ids_[k] = i;
    cellkey_[k] = pack(cell(p[0]), cell(p[1]), cell(p[2]));
    for (int a = 0; a < 3; ++a) sorted_[3 * size_t(k) + a] = p[a];
  }
  restore();
}

// A hashed uniform grid over boxes, held in workspace memory: every box that
// spans at most two cells per axis ("fits") is entered in each cell it
// overlaps (at most 8 entries), a counting sort by cell hash. A query visits
// the cells a box overlaps; an entry is reported with the cell it was met in,
// so a caller can count a pair once (in the cell holding the low corner of
// the two boxes' intersection).
class BoxGrid : public CellTable {
 public:
  static constexpr uint32_t kMaxEntries = 8;  // per box
  void carve(Arena& a, uint32_t max_boxes);
  // Sets the cell size h (> 0) for fits(), cells() and the next build().
  void set_cell_size(double h) {
    h_ = h;
    inv_h_ = 1.0 / h;
  }
  // lo, hi: 3 per box. Enters the boxes i < count with keep(i) && fits(i), at
  // the cell size set.
  template <class Keep>
  void build(const double* lo, const double* hi, uint32_t count, Keep&& keep);
  // The same for the boxes ids[0..count) (ascending), entered when they fit:
  // build() over the ids that keep() passes, without asking about the others.
  void build_from(const double* lo, const double* hi, const uint32_t* ids, uint32_t count) {
    build_each(lo, hi, [&](auto&& enter) {
      for (uint32_t j = 0; j < count; ++j) enter(ids[j]);
    });
  }

  double cell_size() const { return h_; }
  bool fits(const double* lo, const double* hi) const {
    for (int a = 0; a < 3; ++a)
      if (!(cell(hi[a]) - cell(lo[a]) <= 1)) return false;
    return true;
  }
  // Number of cells the box [lo, hi] overlaps (as a double: may be huge).
  double cells(const double* lo, const double* hi) const { return count(range_of(lo, hi)); }

  // Calls f(id, cell) for every entry of the cells the box [lo, hi] overlaps
  // (cell: int64_t[3]); an entry of a box is met once per cell it shares.
  template <class F>
  void for_each_entry(const double* lo, const double* hi, F&& f) const {
    for_each_cell_of(lo, hi, [&](int64_t x, int64_t y, int64_t z) {
      const int64_t c[3] = {x, y, z};
      const uint32_t hb = hash(x, y, z);
      const uint32_t pc = pack(x, y, z);
      for (uint32_t k = start_[hb]; k < start_[hb + 1]; ++k)
        if (key_[k] == pc) f(ids_[k] & kIdMask, c);
    });
  }
  // Whether pred(id) holds for some entry of the range's cells (range_of()
  // the box); stops at the first.
  template <class P>
  bool any_entry(const Range& r, P&& pred) const {
    return any_cell_of(r, [&](int64_t x, int64_t y, int64_t z) {
      const uint32_t hb = hash(x, y, z);
      const uint32_t pc = pack(x, y, z);
      for (uint32_t k = start_[hb]; k < start_[hb + 1]; ++k)
        if (key_[k] == pc && pred(ids_[k] & kIdMask)) return true;
      return false;
    });
  }
  // For a box [lo, hi] over fewer than 1024 cells per axis (any box that
  // fits): calls f(id) for the entries met in the cell holding the low
  // corner of the intersection of the two boxes, the one cell where the pair
  // counts; that cell is, per axis, the low cell of one of the two boxes (the
  // larger; a cell both boxes reach is at or past each), so an entry's
  // low-cell bits and the query's decide without arithmetic. (An entry of an
  // aliased cell may be reported; its box does not overlap the query's,
  // which the caller tests.)
  template <class F>
  void for_each_owned_entry(const double* lo, const double* hi, F&& f) const {
    for_each_owned_entry(range_of(lo, hi), f);
  }
  // A bucket's entries are listed first, without branches (a cell's key and
  // its low-cell bits are a coin toss each), then handed to f in bucket
  // order: the walk's loads stay in registers instead of being read again
  // after every call of f, which may write anywhere but to the grid.
  template <class F>
  void for_each_owned_entry(const Range& r, F&& f) const {
    const int64_t c0 = r.a[0], c1 = r.a[1], c2 = r.a[2];
    constexpr uint32_t kChunk = 64;
    uint32_t got[kChunk];
    for_each_cell_of(r, [&](int64_t x, int64_t y, int64_t z) {
      const uint32_t low = uint32_t(x == c0) | uint32_t(y == c1) << 1 | uint32_t(z == c2) << 2;
      const uint32_t hb = hash(x, y, z);
      const uint32_t pc = pack(x, y, z);
      const uint32_t first = start_[hb], end = start_[hb + 1];
      for (uint32_t k0 = first; k0 < end; k0 += kChunk) {
        const uint32_t k1 = end - k0 < kChunk ? end : k0 + kChunk;
        const uint32_t n = owned_in(k0, k1, pc, low, got);
        for (uint32_t i = 0; i < n; ++i) f(got[i]);
      }
    });
  }
  // The ids of slots k0 <= k < k1 in cell pc whose low-cell bits with low
  // make the cell their pair's owner, into got, in slot order; how many.
  uint32_t owned_in(uint32_t k0, uint32_t k1, uint32_t pc, uint32_t low, uint32_t* got) const {
    const uint32_t* key = key_;
    const uint32_t* ids = ids_;
    uint32_t n = 0;
    for (uint32_t k = k0; k < k1; ++k) {
      const uint32_t id = ids[k];
      got[n] = id & kIdMask;
      n += uint32_t(key[k] == pc) & uint32_t(((id >> kLowShift) | low) == 7);
    }
    return n;
  }

  // Calls f(i, j) for every two entries i < j (box ids) of one bucket with
  // the same packed cell key that are met in the cell holding the low corner
  // of their boxes' intersection (the one cell where the pair counts): per
  // axis that cell is the low cell of one of the two boxes, read from the
  // entries' low-cell bits. Walks the table in order (no lookups). Cells
  // whose keys alias share a bucket and a key; their boxes do not overlap,
  // which the caller tests. Stops when f returns true; returns whether it did.
  template <class F>
  bool for_each_cell_pair(F&& f) const {
    for (uint32_t hb = 0; hb < table_; ++hb) {
      const uint32_t e = start_[hb + 1];
      for (uint32_t k = start_[hb]; k + 1 < e; ++k) {
        const uint32_t kk = key_[k], ik = ids_[k];
        if ((ik >> kLowShift) == 7) {
          for (uint32_t l = k + 1; l < e; ++l)
            if (key_[l] == kk && f(ik & kIdMask, ids_[l] & kIdMask)) return true;
        } else {
          for (uint32_t l = k + 1; l < e; ++l)
            if (key_[l] == kk && ((ids_[l] | ik) >> kLowShift) == 7 && f(ik & kIdMask, ids_[l] & kIdMask))
              return true;
        }
      }
    }
    return false;
  }
  // for_each_cell_pair restricted to the pairs whose boxes (lo, hi: 3 per
  // box id, as built) overlap, closed, and whose labels (tris: 3 per box id)
  // differ: the same pairs in the same order, each bucket's boxes and labels
  // read once.
  template <class F>
  bool for_each_overlapping_cell_pair(const double* lo, const double* hi, const uint32_t* tris, F&& f) const {
    constexpr uint32_t kLocal = 64, kSweep = 1024;
    struct Sweep {
      double x;
      uint32_t k;
    };
    double b[kLocal][6];
    uint32_t v[kLocal][3];
    auto disjoint = [](const uint32_t* p, const uint32_t* q) {
      return p[0] != q[0] && p[0] != q[1] && p[0] != q[2] && p[1] != q[0] && p[1] != q[1] && p[1] != q[2] &&
             p[2] != q[0] && p[2] != q[1] && p[2] != q[2];
    };
    // Entries k and l pair here: the same cell, this cell owns the pair, the
    // boxes overlap (closed) and the labels share no vertex.
    auto meets = [&](uint32_t k, uint32_t l) {
      if (key_[l] != key_[k] || ((ids_[l] | ids_[k]) >> kLowShift) != 7) return false;
      const uint32_t ik = ids_[k] & kIdMask, il = ids_[l] & kIdMask;
      const double *lk = lo + 3 * size_t(ik), *hk = hi + 3 * size_t(ik);
      const double *ll = lo + 3 * size_t(il), *hl = hi + 3 * size_t(il);
      if (ll[0] > hk[0] || lk[0] > hl[0] || ll[1] > hk[1] || lk[1] > hl[1] || ll[2] > hk[2] || lk[2] > hl[2])
        return false;
      return disjoint(tris + 3 * size_t(ik), tris + 3 * size_t(il));
    };
    for (uint32_t hb = 0; hb < table_; ++hb) {
      const uint32_t k0 = start_[hb], e = start_[hb + 1];
      if (e - k0 < 2) continue;
      if (e - k0 > kLocal && e - k0 <= kSweep) {
        // A crowded bucket (a crumpled region of small triangles): its
        // entries by the low x of their boxes, each paired only with those
        // starting before it ends (the same pairs, in another order; f gets
        // the lower id first).
        Sweep w[kSweep];
        const uint32_t c = e - k0;
        for (uint32_t k = 0; k < c; ++k) {
          const uint32_t id = ids_[k0 + k] & kIdMask;
          w[k] = Sweep{lo[3 * size_t(id)], k0 + k};
        }
        std::sort(w, w + c, [](const Sweep& p, const Sweep& q) { return p.x < q.x || (p.x == q.x && p.k < q.k); });
        for (uint32_t i = 0; i + 1 < c; ++i) {
          const uint32_t k = w[i].k, a = ids_[k] & kIdMask;
          const double hx = hi[3 * size_t(a)];
          for (uint32_t j = i + 1; j < c && !(w[j].x > hx); ++j) {
            const uint32_t l = w[j].k, il = ids_[l] & kIdMask;
            if (!meets(k, l)) continue;
            if (a < il ? f(a, il) : f(il, a)) return true;
          }
        }
        continue;
      }
      if (e - k0 > kLocal) {
        for (uint32_t k = k0; k + 1 < e; ++k)
          for (uint32_t l = k + 1; l < e; ++l)
            if (meets(k, l) && f(ids_[k] & kIdMask, ids_[l] & kIdMask)) return true;
        continue;
      }
      for (uint32_t k = k0; k < e; ++k) {
        const uint32_t id = ids_[k] & kIdMask;
        for (int a = 0; a < 3; ++a) {
          b[k - k0][a] = lo[3 * size_t(id) + a];
          b[k - k0][3 + a] = hi[3 * size_t(id) + a];
          v[k - k0][a] = tris[3 * size_t(id) + a];
        }
      }
      for (uint32_t k = k0; k + 1 < e; ++k) {
        const uint32_t kk = key_[k], ik = ids_[k];
        const double* bk = b[k - k0];
        for (uint32_t l = k + 1; l < e; ++l) {
          // All tests evaluated, one branch (they mostly fail).
          const double* bl = b[l - k0];
          const bool meet = (key_[l] == kk) & (((ids_[l] | ik) >> kLowShift) == 7) & !(bl[0] > bk[3]) &
                            !(bk[0] > bl[3]) & !(bl[1] > bk[4]) & !(bk[1] > bl[4]) & !(bl[2] > bk[5]) &
                            !(bk[2] > bl[5]);
          if (!meet || !disjoint(v[k - k0], v[l - k0])) continue;
          if (f(ik & kIdMask, ids_[l] & kIdMask)) return true;
        }
      }
    }
    return false;
  }
  // The packed key of the cell holding point p.
  uint32_t packed_cell(const double* p) const { return pack(cell(p[0]), cell(p[1]), cell(p[2])); }

 private:
  // 10 bits per axis: the cells of one fitting box never alias; a wider
  // query may meet an aliased entry, which the caller's cell test rejects.
  static uint32_t pack(int64_t x, int64_t y, int64_t z) {
    return uint32_t((uint64_t(x) & 0x3FF) | (uint64_t(y) & 0x3FF) << 10 | (uint64_t(z) & 0x3FF) << 20);
  }

  uint32_t* key_ = nullptr;  // kMaxEntries per box: packed cell of ids_[k]
  double h_ = 1;
  // ids_[k]: the box id, and in the top bits, per axis, whether the entry's
  // cell is the box's low cell (ids stay below 2^29).
  static constexpr int kLowShift = 29;
  static constexpr uint32_t kIdMask = (1u << kLowShift) - 1;

  // The build over the boxes each(enter) names, enter(i) for each i in
  // ascending order (twice: the count and the scatter).
  template <class Each>
  void build_each(const double* lo, const double* hi, Each&& each);
};

template <class Keep>
void BoxGrid::build(const double* lo, const double* hi, uint32_t count, Keep&& keep) {
  build_each(lo, hi, [&](auto&& enter) {
    for (uint32_t i = 0; i < count; ++i)
      if (keep(i)) enter(i);
  });
}

template <class Each>
void BoxGrid::build_each(const double* lo, const double* hi, Each&& each) {
  clear_counts();
  // Per box: its cell range, whether it fits (at most two cells per axis).
  auto range = [&](uint32_t i, int64_t* a, int64_t* b) {
    for (int k = 0; k < 3; ++k) {
      a[k] = cell(lo[3 * size_t(i) + k]);
      b[k] = cell(hi[3 * size_t(i) + k]);
      if (!(b[k] - a[k] <= 1)) return false;
    }
    return true;
  };
  int64_t a[3], b[3];
  each([&](uint32_t i) {
    if (!range(i, a, b)) return;
    for (int64_t z = a[2]; z <= b[2]; ++z)
      for (int64_t y = a[1]; y <= b[1]; ++y)
        for (int64_t x = a[0]; x <= b[0]; ++x) ++start_[hash(x, y, z) + 1];
  });
  starts();
  each([&](uint32_t i) {
    if (!range(i, a, b)) return;
    for (int64_t z = a[2]; z <= b[2]; ++z)
      for (int64_t y = a[1]; y <= b[1]; ++y)
        for (int64_t x = a[0]; x <= b[0]; ++x) {
          const uint32_t k = start_[hash(x, y, z)]++;
          ids_[k] = i | (uint32_t(x == a[0]) | uint32_t(y == a[1]) << 1 | uint32_t(z == a[2]) << 2) << kLowShift;
          key_[k] = pack(x, y, z);
        }
  });
  restore();
}

}  // namespace ffseg
