// Cost of the contact test between objects (src/mesh/mesh_contact.h), the
// step guard's check against the other objects: build_obstacles() once per
// step and mark_contacts() per tested position set, for two spheres of
// radius 10 mm far apart, with overlapping bounding boxes but apart, just
// touching (a shallow overlap) and deep, at n = 12, 21 and 33. Prints the
// best of several runs in microseconds per call.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <vector>

#include "cubesphere.h"
#include "mesh_contact.h"
#include "mesh_intersection.h"
#include "../tests/test_util.h"

namespace {

template <class F>
double best_us(int reps, int inner, F&& f) {
  double best = 1e300;
  for (int r = 0; r < reps; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < inner; ++i) f();
    const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count() / inner;
    best = us < best ? us : best;
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  // argv[1] (optional): run only the cases whose name contains it.
  for (uint32_t n : {12u, 21u, 33u}) {
    ffseg::CubeSphere m;
    ffseg::ContactScratch cs;
    ffseg_test::ArenaBox box([&](ffseg::Arena& a) {
      m.carve(a, n);
      cs.carve(a, m, 1);
    });
    if (!box.ok()) return 1;
    m.build();
    for (uint32_t k : {1u, 7u}) {
      ffseg::Arena probe;
      ffseg::ContactScratch c;
      c.carve(probe, m, k);
      std::printf("n=%2u ContactScratch for %u obstacle(s): %zu bytes\n", n, k, probe.used());
    }
    auto sphere = [&](double r, double cx, double cy, double cz) {
      std::vector<double> x(size_t(3) * m.nv);
      const double c[3] = {cx, cy, cz};
      for (size_t q = 0; q < x.size(); ++q) x[q] = c[q % 3] + r * m.unit[q];
      return x;
    };
    const std::vector<double> A = sphere(10, 0, 0, 0);
    std::vector<uint8_t> mark(m.nv);
    {
      // For scale: the guard's own self-intersection test of A (marking, no
      // certificate: the local rounds' call).
      ffseg::TriangleScratch ts;
      ffseg_test::ArenaBox tb([&](ffseg::Arena& a) { ts.carve(a, m); });
      if (!tb.ok()) return 1;
      const double self = best_us(5, 10, [&] { ffseg::mark_intersections(m, A.data(), ts, mark.data()); });
      std::printf("n=%2u self-intersection test of one mesh (mark_intersections, marking) %7.1f us\n", n, self);
    }
    struct Case {
      const char* name;
      double c[3];
    } cases[] = {{"far apart", {40, 0, 0}},
                 {"boxes overlap, apart", {14.8, 14.8, 0.3}},
                 {"touching", {19.7, 0.37, -0.21}},
                 {"deep", {12, 0.37, -0.21}}};
    for (const Case& c : cases) {
      if (argc > 1 && !std::strstr(c.name, argv[1])) continue;
      const std::vector<double> B = sphere(10, c.c[0], c.c[1], c.c[2]);
      const double* obst[1] = {B.data()};
      // As the guard would: the region is the query mesh's box.
      double region[6];
      for (int a = 0; a < 3; ++a) {
        region[a] = -10;
        region[3 + a] = 10;
      }
      const double whole = best_us(5, 10, [&] { ffseg::build_obstacles(m, obst, 1, cs); });
      const double build = best_us(5, 20, [&] { ffseg::build_obstacles(m, obst, 1, cs, region); });
      uint32_t count = 0;
      const double yes_no = best_us(5, 50, [&] { count = ffseg::mark_contacts(m, A.data(), cs, nullptr); });
      const double marked = best_us(5, 50, [&] { count = ffseg::mark_contacts(m, A.data(), cs, mark.data()); });
      std::printf(
          "n=%2u %-21s offences %4u  build_obstacles %7.1f us (no region %7.1f us)  mark_contacts %7.1f us "
          "(yes/no %7.1f us)\n",
          n, c.name, count, build, whole, marked, yes_no);
    }
  }
  return 0;
}
