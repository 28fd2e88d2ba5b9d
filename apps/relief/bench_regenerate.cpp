// Regenerate: the studio's slider move, run() in memory with and without recycling and fusion.
#include "bench_common.hpp"

namespace relief::cli {

void bench_regenerate(const BenchSettings& s, json& entries) {
  // What the studio does on a slider move: run() the island preset at 513², in memory, no
  // writers, handing the previous result back for its buffers (RunOptions::recycle). Target
  // ≤ 15 ms. Also without recycling (fresh allocations) and without fusion, for comparison. The
  // per-stage medians show where the time goes (a fused chain's time sits on its first stage).
  const Recipe r = parse_recipe(preset_doc("island", 513));
  struct Variant {
    const char* name;
    bool recycle, fuse;
  };
  for (int threads : s.threads) {
    for (const Variant& v : {Variant{"island regenerate 513² in memory", true, true},
                             Variant{"  same, fresh allocations", false, true},
                             Variant{"  same, unfused", true, false}}) {
      RunOptions o;
      o.threads = threads;
      o.fuse = v.fuse;
      Terrain previous;
      std::vector<std::vector<double>> stage_ms(r.stages.size());
      Sample t = time_runs(s.runs, [&] {
        if (v.recycle) o.recycle = &previous;
        RunResult res = run(r, o);
        for (std::size_t k = 0; k < res.timings.size() && k < stage_ms.size(); ++k) stage_ms[k].push_back(res.timings[k].ms);
        if (v.recycle) previous = std::move(res.terrain);
      });
      json e = timing_entry(v.name, 513, 513, threads, t);
      json per = json::array();
      std::string line = "    stages (median ms):";
      for (std::size_t k = 0; k < stage_ms.size(); ++k) {
        const double med = stage_ms[k].empty() ? 0.0 : median_of(stage_ms[k]);
        per.push_back({{"stage", r.stages[k].def->name}, {"median_ms", med}});
        char buf[64];
        std::snprintf(buf, sizeof buf, " %s %.2f", r.stages[k].def->name.c_str(), med);
        line += buf;
      }
      e["stages"] = per;
      print_row(e);
      std::printf("%s; cpu %.2f ms per run\n", line.c_str(), t.cpu_median);
      entries.push_back(e);
    }
  }
}

}  // namespace relief::cli
