#include "rcm.h"

namespace ffseg {
namespace {

inline uint32_t degree(const CsrGraph& g, uint32_t v) { return g.row_ptr[v + 1] - g.row_ptr[v]; }

// Breadth-first level structure rooted at root, restricted to nodes whose mark
// differs from stamp (they get marked). Nodes land in queue[0..count) level by
// level. Returns the number of nodes reached; *depth = number of levels,
// *last_begin = index in queue where the last level starts.
uint32_t level_structure(const CsrGraph& g, uint32_t root, uint32_t* mark, uint32_t stamp,
                         uint32_t* queue, uint32_t* depth, uint32_t* last_begin) {
  uint32_t head = 0, tail = 0;
  queue[tail++] = root;
  mark[root] = stamp;
  uint32_t levels = 0, begin = 0;
  while (head < tail) {
    const uint32_t level_end = tail;
    begin = head;
    ++levels;
    while (head < level_end) {
      const uint32_t v = queue[head++];
      for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e) {
        const uint32_t w = g.cols[e];
        if (mark[w] != stamp) {
          mark[w] = stamp;
          queue[tail++] = w;
        }
      }
    }
  }
  *depth = levels;
  *last_begin = begin;
  return tail;
}

// Orders a[0..count) by (degree, index), insertion sort: the runs are the
// unnumbered neighbours of one node, short for mesh graphs.
void sort_by_degree(const CsrGraph& g, uint32_t* a, uint32_t count) {
  for (uint32_t i = 1; i < count; ++i) {
    const uint32_t v = a[i];
    const uint32_t dv = degree(g, v);
    uint32_t j = i;
    while (j > 0) {
      const uint32_t u = a[j - 1];
      const uint32_t du = degree(g, u);
      if (du < dv || (du == dv && u < v)) break;
      a[j] = u;
      --j;
    }
    a[j] = v;
  }
}

}  // namespace

std::size_t rcm_scratch_words(uint32_t n) { return 2 * std::size_t(n); }

bool rcm_order(const CsrGraph& g, uint32_t* perm, uint32_t* scratch) {
  const uint32_t n = g.n;
  if (n == 0) return true;
  if (g.row_ptr == nullptr || perm == nullptr || scratch == nullptr) return false;
  if (g.row_ptr[n] > 0 && g.cols == nullptr) return false;
  for (uint32_t v = 0; v < n; ++v) {
    if (g.row_ptr[v + 1] < g.row_ptr[v]) return false;
    for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e)
      if (g.cols[e] >= n) return false;
  }

  // mark[v]: 0 = unnumbered; stamps >= 2 label level-structure passes; 1 =
  // numbered (placed in perm). Stamps only grow, so nothing is cleared.
  uint32_t* mark = scratch;
  uint32_t* queue = scratch + n;
  for (uint32_t v = 0; v < n; ++v) mark[v] = 0;
  const uint32_t kNumbered = 1;
  uint32_t stamp = 1;

  uint32_t placed = 0;
  uint32_t next_seed = 0;
  while (placed < n) {
    while (mark[next_seed] == kNumbered) ++next_seed;
    // Pseudo-peripheral node of the component of next_seed (George-Liu).
    uint32_t root = next_seed;
    uint32_t depth = 0, last = 0;
    if (++stamp == 0) return false;  // > 4e9 passes: impossible for valid n
    uint32_t count = level_structure(g, root, mark, stamp, queue, &depth, &last);
    for (;;) {
      // Minimum-degree node of the last level, smallest index on ties.
      uint32_t best = queue[last];
      for (uint32_t q = last + 1; q < count; ++q) {
        const uint32_t v = queue[q];
        const uint32_t dv = degree(g, v), db = degree(g, best);
        if (dv < db || (dv == db && v < best)) best = v;
      }
      if (++stamp == 0) return false;
      uint32_t d2 = 0, last2 = 0;
      const uint32_t count2 = level_structure(g, best, mark, stamp, queue, &d2, &last2);
      (void)count2;
      if (d2 > depth) {
        root = best;
        depth = d2;
        last = last2;
        count = count2;
      } else {
        break;
      }
    }
    // The last pass may have been rooted at a node that was not accepted; the
    // marks then belong to that pass, which is fine: Cuthill-McKee below only
    // looks at the kNumbered mark.
    // Cuthill-McKee: breadth-first from root, children by increasing degree.
    const uint32_t comp_begin = placed;
    perm[placed++] = root;
    mark[root] = kNumbered;
    for (uint32_t head = comp_begin; head < placed; ++head) {
      const uint32_t v = perm[head];
      const uint32_t first_child = placed;
      for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e) {
        const uint32_t w = g.cols[e];
        if (mark[w] != kNumbered) {
          mark[w] = kNumbered;
          perm[placed++] = w;
        }
      }
      sort_by_degree(g, perm + first_child, placed - first_child);
    }
  }
  // Reverse the whole order: components stay contiguous, in reverse order.
  for (uint32_t i = 0, j = n - 1; i < j; ++i, --j) {
    const uint32_t t = perm[i];
    perm[i] = perm[j];
    perm[j] = t;
  }
  return true;
}

uint32_t graph_bandwidth(const CsrGraph& g, const uint32_t* iperm) {
  uint32_t bw = 0;
  for (uint32_t v = 0; v < g.n; ++v) {
    const uint32_t pv = iperm ? iperm[v] : v;
    for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e) {
      const uint32_t w = g.cols[e];
      const uint32_t pw = iperm ? iperm[w] : w;
      const uint32_t d = pv > pw ? pv - pw : pw - pv;
      if (d > bw) bw = d;
    }
  }
  return bw;
}

uint64_t graph_envelope(const CsrGraph& g, const uint32_t* iperm) {
  uint64_t env = 0;
  for (uint32_t v = 0; v < g.n; ++v) {
    const uint32_t pv = iperm ? iperm[v] : v;
    uint32_t first = pv;
    for (uint32_t e = g.row_ptr[v]; e < g.row_ptr[v + 1]; ++e) {
      const uint32_t w = g.cols[e];
      const uint32_t pw = iperm ? iperm[w] : w;
      if (pw < first) first = pw;
    }
    env += pv - first;
  }
  return env;
}

}  // namespace ffseg
