// Reverse Cuthill-McKee ordering of a symmetric graph (George & Liu, "Computer
// Solution of Large Sparse Positive Definite Systems", 1981, ch. 4). The start
// node of every connected component is a pseudo-peripheral node found with the
// George-Liu iteration. No allocation: the caller passes scratch memory.
#pragma once
#include <cstddef>
#include <cstdint>

namespace ffseg {

// Symmetric graph in CSR form: the neighbours of v are cols[row_ptr[v] ..
// row_ptr[v+1]), without v itself. Both directions of every edge are present.
struct CsrGraph {
  uint32_t n = 0;
  const uint32_t* row_ptr = nullptr;  // n + 1 entries
  const uint32_t* cols = nullptr;     // row_ptr[n] entries
};

// Number of uint32_t scratch words rcm_order() needs for a graph of n nodes.
std::size_t rcm_scratch_words(uint32_t n);

// Computes the reverse Cuthill-McKee permutation: perm[k] is the old index of
// the node that gets new index k (so perm is the "new -> old" map). Components
// are numbered one after the other, in the order of their smallest node.
// Ties are broken by node index, so the result is deterministic.
// scratch: rcm_scratch_words(g.n) words. Returns false when the graph is
// malformed (column out of range, decreasing row_ptr); perm is then undefined.
bool rcm_order(const CsrGraph& g, uint32_t* perm, uint32_t* scratch);

// Half-bandwidth max |iperm[u] - iperm[v]| over the edges (0 without edges),
// where iperm is "old -> new" (iperm[perm[k]] = k). With iperm == nullptr the
// identity order is measured.
uint32_t graph_bandwidth(const CsrGraph& g, const uint32_t* iperm);

// Envelope (profile) size: sum over rows i of (i - first column of row i),
// the strictly lower part, in the order given by iperm (nullptr = identity).
uint64_t graph_envelope(const CsrGraph& g, const uint32_t* iperm);

}  // namespace ffseg
