// Flip detection (thesis 4.2.3, eq. 4.2.1) and flip avoidance (4.2.4) on
// hand-made loops of a bare cube-sphere (src/deform/flips.h).
#include <doctest/doctest.h>

#include <vector>

#include "flips.h"
#include "support/sphere_box.h"

using ffseg_test::SphereBox;

namespace {

// avoid_flips on loop 0 only: every vertex of loop 0 has a target, no other
// vertex has one, and the vertices at the given loop positions are flagged as
// flipping. Returns has[] after avoidance.
std::vector<uint8_t> avoid_on_loop0(const SphereBox& b, const std::vector<uint32_t>& flagged,
                                    const std::vector<uint32_t>& solitary, uint32_t* removed) {
  const uint32_t nv = b.m.nv;
  std::vector<uint8_t> has(nv, 0), flipping(nv, 0);
  std::vector<uint32_t> scratch(b.m.loop_len);
  for (uint32_t p = 0; p < b.m.loop_len; ++p) has[b.at(0, p)] = 1;
  for (uint32_t p : solitary) has[b.at(0, p)] = 0;
  for (uint32_t p : flagged) flipping[b.at(0, p)] = 1;
  *removed = ffseg::avoid_flips(b.m, flipping.data(), has.data(), scratch.data());
  return has;
}

}  // namespace

TEST_CASE("flip avoidance: a run of three flipping vertices keeps its middle one") {
  SphereBox b(6);
  const uint32_t L = b.m.loop_len;
  uint32_t removed = 0;
  const std::vector<uint8_t> has = avoid_on_loop0(b, {5, 6, 7}, {}, &removed);
  CHECK(removed == 2);
  CHECK(has[b.at(0, 5)] == 0);
  CHECK(has[b.at(0, 6)] == 1);
  CHECK(has[b.at(0, 7)] == 0);
  for (uint32_t p = 0; p < L; ++p)
    if (p < 5 || p > 7) CHECK(has[b.at(0, p)] == 1);
}

TEST_CASE("flip avoidance: runs of one, two, four and five; solitary vertices do not break a run") {
  SphereBox b(6);
  uint32_t removed = 0;
  {  // a single flipper keeps its target
    const std::vector<uint8_t> has = avoid_on_loop0(b, {9}, {}, &removed);
    CHECK(removed == 0);
    CHECK(has[b.at(0, 9)] == 1);
  }
  {  // two: the second in loop order stays; four: the third; five: the third
    const std::vector<uint8_t> has = avoid_on_loop0(b, {2, 3, 8, 9, 10, 11, 15, 16, 17, 18, 19}, {}, &removed);
    CHECK(removed == 1 + 3 + 4);
    CHECK(has[b.at(0, 2)] == 0);
    CHECK(has[b.at(0, 3)] == 1);
    CHECK(has[b.at(0, 8)] == 0);
    CHECK(has[b.at(0, 9)] == 0);
    CHECK(has[b.at(0, 10)] == 1);
    CHECK(has[b.at(0, 11)] == 0);
    for (uint32_t p = 15; p <= 19; ++p) CHECK(has[b.at(0, p)] == (p == 17 ? 1 : 0));
  }
  {  // 4, 5, (6 solitary), 7: one run of three in the loop's non-solitary order, 5 keeps
    const std::vector<uint8_t> has = avoid_on_loop0(b, {4, 5, 7}, {6}, &removed);
    CHECK(removed == 2);
    CHECK(has[b.at(0, 4)] == 0);
    CHECK(has[b.at(0, 5)] == 1);
    CHECK(has[b.at(0, 6)] == 0);
    CHECK(has[b.at(0, 7)] == 0);
  }
}

TEST_CASE("flip avoidance: a run across the loop's wrap-around is one run") {
  SphereBox b(6);
  const uint32_t L = b.m.loop_len;
  uint32_t removed = 0;
  {  // positions L-1, 0, 1: the middle is position 0
    const std::vector<uint8_t> has = avoid_on_loop0(b, {L - 1, 0, 1}, {}, &removed);
    CHECK(removed == 2);
    CHECK(has[b.at(0, L - 1)] == 0);
    CHECK(has[b.at(0, 0)] == 1);
    CHECK(has[b.at(0, 1)] == 0);
  }
  {  // L-3 .. 1 (five): the middle is L-1
    const std::vector<uint8_t> has = avoid_on_loop0(b, {L - 3, L - 2, L - 1, 0, 1}, {}, &removed);
    CHECK(removed == 4);
    for (uint32_t p : {L - 3, L - 2, 0u, 1u}) CHECK(has[b.at(0, p)] == 0);
    CHECK(has[b.at(0, L - 1)] == 1);
  }
  {  // the whole loop flips: one vertex of it keeps its target
    std::vector<uint32_t> all;
    for (uint32_t p = 0; p < L; ++p) all.push_back(p);
    const std::vector<uint8_t> has = avoid_on_loop0(b, all, {}, &removed);
    CHECK(removed == L - 1);
    uint32_t kept = 0;
    for (uint32_t p = 0; p < L; ++p) kept += has[b.at(0, p)];
    CHECK(kept == 1);
  }
}

TEST_CASE("flip detection: a uniform expansion has no flip; two swapped targets flip their edge only") {
  SphereBox b(6);
  const uint32_t nv = b.m.nv;
  const std::vector<double> x = b.sphere(10);
  std::vector<double> t = b.sphere(12);
  std::vector<uint8_t> has(nv, 1), flipping(nv, 7);
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), 0.0, flipping.data()) == 0);
  for (uint32_t v = 0; v < nv; ++v) CHECK(flipping[v] == 0);  // cleared, not left as it was
  // Swap the targets of two neighbours along loop 4 (interior of a face).
  const uint32_t i = b.at(4, 10), j = b.at(4, 11);
  for (int a = 0; a < 3; ++a) std::swap(t[3 * i + a], t[3 * j + a]);
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), 0.0, flipping.data()) == 2);
  CHECK(flipping[i] == 1);
  CHECK(flipping[j] == 1);
  // With i solitary the edge is gone; j's edge now runs to i's other neighbour
  // across the gap, whose target lies ahead of j's: no flip left.
  has[i] = 0;
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), 0.0, flipping.data()) == 0);
  // Avoidance after detection keeps one of the two.
  has[i] = 1;
  ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), 0.0, flipping.data());
  std::vector<uint32_t> scratch(b.m.loop_len);
  CHECK(ffseg::avoid_flips(b.m, flipping.data(), has.data(), scratch.data()) == 1);
  CHECK(has[i] + has[j] == 1);
}

TEST_CASE("flip detection: tau edge cases (cos exactly tau flips, collapsed edges flip at any tau)") {
  // Only two vertices have targets, neighbours on loop 0: one edge, seen from
  // both ends of the loop (and alone on their other loops).
  SphereBox b(6);
  const uint32_t nv = b.m.nv;
  const uint32_t i = b.at(0, 3), j = b.at(0, 4);
  std::vector<double> x = b.sphere(10), t = b.sphere(10);
  std::vector<uint8_t> has(nv, 0), flipping(nv);
  has[i] = has[j] = 1;
  // x_i - x_j = (1, 0, 0); t_i - t_j = (3, 4, 0): cos = 3/5 exactly.
  for (int a = 0; a < 3; ++a) x[3 * i + a] = x[3 * j + a] + (a == 0 ? 1.0 : 0.0);
  for (int a = 0; a < 3; ++a) t[3 * i + a] = t[3 * j + a] + (a == 0 ? 3.0 : a == 1 ? 4.0 : 0.0);
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), 0.6, flipping.data()) == 2);
  CHECK(flipping[i] == 1);
  CHECK(flipping[j] == 1);
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), 0.59, flipping.data()) == 0);
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), -1.0, flipping.data()) == 0);
  // Reversed (cos = -1): flips at tau = -1 and above.
  for (int a = 0; a < 3; ++a) t[3 * i + a] = t[3 * j + a] - (a == 0 ? 2.0 : 0.0);
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), -1.0, flipping.data()) == 2);
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), -1.5, flipping.data()) == 0);
  // Both targets on one point: a flip whatever tau.
  for (int a = 0; a < 3; ++a) t[3 * i + a] = t[3 * j + a];
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), -2.0, flipping.data()) == 2);
  // Both vertices on one point (targets apart): a flip too.
  for (int a = 0; a < 3; ++a) {
    t[3 * i + a] = t[3 * j + a] + 1.0;
    x[3 * i + a] = x[3 * j + a];
  }
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), -2.0, flipping.data()) == 2);
  // No vertex with a target: nothing flips, nothing is touched by avoidance.
  has[i] = has[j] = 0;
  CHECK(ffseg::detect_flips(b.m, x.data(), t.data(), has.data(), 1.0, flipping.data()) == 0);
}
