// `ffseg segment --seed-check` (seed_check.h).
#include "seed_check.h"

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <exception>
#include <mutex>
#include <thread>

#include "cli.h"

namespace ffseg_cli {

const SeedVariant kSeedVariant[kSeedVariants] = {
    {"radius x0.6", 0.6, {0, 0, 0}},
    {"radius x1.5", 1.5, {0, 0, 0}},
    {"centre +1 mm x", 1, {1, 0, 0}},
    {"centre +1 mm y", 1, {0, 1, 0}},
    {"centre +1 mm z", 1, {0, 0, 1}},
};

SegmentRequest perturbed_request(const SegmentRequest& rq, const std::vector<std::array<double, 3>>& centres_mm,
                                 const SeedVariant& v) {
  SegmentRequest q = rq;
  q.quiet = true;
  for (uint32_t k = 0; k < q.objects(); ++k) {
    SphereArg& s = q.spheres[k];
    for (int a = 0; a < 3; ++a) s.c[a] = centres_mm[k][a] + v.shift_mm[a];
    s.c[3] *= v.radius_scale;
    s.voxel = false;
    char text[160];
    std::snprintf(text, sizeof text, "--sphere %g,%g,%g,%g, the %s", s.c[0], s.c[1], s.c[2], s.c[3], v.name);
    s.text = text;
  }
  return q;
}

double mask_dice(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  const size_t n = std::min(a.size(), b.size());
  size_t both = 0, na = 0, nb = 0;
  for (size_t i = 0; i < n; ++i) {
    both += a[i] && b[i];
    na += a[i] != 0;
    nb += b[i] != 0;
  }
  return na + nb == 0 ? 1.0 : 2.0 * double(both) / double(na + nb);
}

double SeedCheck::lowest(uint32_t k) const {
  double m = 1;
  for (double d : dice[k])
    if (d >= 0) m = std::min(m, d);
  return m;
}

SeedCheck check_seeds(const SegmentRequest& rq, const std::vector<std::array<double, 3>>& centres_mm,
                      const std::vector<std::vector<uint8_t>>& result,
                      const std::function<std::vector<std::vector<uint8_t>>(const SegmentRequest&)>& segment,
                      std::vector<std::vector<uint8_t>>* votes, uint32_t jobs) {
  SeedCheck sc;
  sc.dice.assign(rq.objects(), {});
  sc.runs = 1;
  if (votes) *votes = result;  // the result's own vote
  std::mutex mu;                // guards sc, *votes and stop
  std::exception_ptr stop;      // an interrupt (or anything else unexpected): rethrown once all have ended
  std::atomic<uint32_t> next{0};
  auto work = [&] {
    for (uint32_t v; (v = next++) < kSeedVariants;) {
      std::vector<std::vector<uint8_t>> masks;
      std::string failed;
      try {
        {
          std::lock_guard<std::mutex> lock(mu);
          if (stop) return;
        }
        masks = segment(perturbed_request(rq, centres_mm, kSeedVariant[v]));
      } catch (const CliError& e) {
        if (e.code == kExitInterrupted) {
          std::lock_guard<std::mutex> lock(mu);
          if (!stop) stop = std::current_exception();
          return;
        }
        failed = e.message.empty() ? "failed" : e.message;
      } catch (...) {
        std::lock_guard<std::mutex> lock(mu);
        if (!stop) stop = std::current_exception();
        return;
      }
      std::vector<double> d(rq.objects(), -1.0);
      for (uint32_t k = 0; k < rq.objects(); ++k)
        if (failed.empty() && k < masks.size()) d[k] = mask_dice(masks[k], result[k]);
      std::lock_guard<std::mutex> lock(mu);
      sc.failed[v] = failed;
      for (uint32_t k = 0; k < rq.objects(); ++k) sc.dice[k][v] = d[k];
      if (!failed.empty()) continue;
      ++sc.runs;
      if (votes)
        for (uint32_t k = 0; k < rq.objects() && k < masks.size(); ++k) {
          std::vector<uint8_t>& to = (*votes)[k];
          for (size_t i = 0; i < to.size() && i < masks[k].size(); ++i) to[i] = uint8_t(to[i] + (masks[k][i] != 0));
        }
    }
  };
  std::vector<std::thread> pool;
  for (uint32_t t = 1; t < std::min(std::max(jobs, 1u), kSeedVariants); ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (stop) std::rethrow_exception(stop);
  return sc;
}

std::vector<std::vector<uint8_t>> consensus_masks(const std::vector<std::vector<uint8_t>>& votes, uint32_t runs) {
  // The least whole number of votes that is at least the share of the runs.
  uint32_t need = 1;
  while (double(need) < kConsensusShare * double(runs) - 1e-9) ++need;
  std::vector<std::vector<uint8_t>> out(votes.size());
  for (size_t k = 0; k < votes.size(); ++k) {
    out[k].assign(votes[k].size(), 0);
    for (size_t i = 0; i < votes[k].size(); ++i) {
      if (votes[k][i] < need) continue;
      bool earlier = false;
      for (size_t e = 0; e < k && !earlier; ++e) earlier = i < out[e].size() && out[e][i];
      out[k][i] = !earlier;
    }
  }
  return out;
}

ffseg_tools::Json seed_check_json(const SeedCheck& sc, const std::vector<std::string>& names) {
  using ffseg_tools::Json;
  Json j = Json::object();
  Json variants = Json::array();
  for (uint32_t v = 0; v < kSeedVariants; ++v) {
    Json o = Json::object();
    o.set("name", kSeedVariant[v].name);
    o.set("radius_scale", kSeedVariant[v].radius_scale);
    o.set("shift_mm", Json::array_of(kSeedVariant[v].shift_mm, 3));
    if (!sc.failed[v].empty()) o.set("failed", sc.failed[v]);
    variants.push(std::move(o));
  }
  j.set("variants", std::move(variants));
  j.set("floor", kSeedCheckFloor);
  Json objects = Json::array();
  for (uint32_t k = 0; k < sc.dice.size(); ++k) {
    Json o = Json::object();
    o.set("name", names[k]);
    Json d = Json::array();
    for (double x : sc.dice[k]) d.push(x >= 0 ? Json(x) : Json());
    o.set("dice", std::move(d));
    o.set("lowest_dice", sc.lowest(k));
    o.set("below_floor", sc.lowest(k) < kSeedCheckFloor);
    objects.push(std::move(o));
  }
  j.set("objects", std::move(objects));
  return j;
}

}  // namespace ffseg_cli
