// Islands: the volcanic-island preset with every default writer, with per-stage medians.
#include "bench_common.hpp"
#include "relief/output.hpp"

namespace relief::cli {

void bench_islands(const BenchSettings& s, json& entries) {
  // The island systems: volcanic-island at 1025² (whole pipeline and every writer that applies,
  // OBJ included), with the median time of each stage.
  const Recipe r = parse_recipe(preset_doc("volcanic-island", 1025));
  for (int threads : s.threads) {
    RunOptions o;
    o.threads = threads;
    std::vector<std::vector<double>> stage_ms(r.stages.size());
    Sample t = time_runs(s.runs, [&] {
      RunResult res = run(r, o);
      for (std::size_t k = 0; k < res.timings.size(); ++k) stage_ms[k].push_back(res.timings[k].ms);
      MemoryOutput mem;
      WriteContext wc;
      wc.seed = res.seed;
      tbb::task_arena arena(threads);
      arena.execute([&] {
        for (auto& w : writer_registry())
          if (w.in_default_set && (!w.applies || w.applies(res.terrain))) w.write(res.terrain, wc, mem);
      });
    });
    json e = timing_entry("islands volcanic-island", 1025, 1025, threads, t);
    json stages = json::array();
    std::string line;
    for (std::size_t k = 0; k < stage_ms.size(); ++k) {
      const double med = stage_ms[k].empty() ? 0.0 : median_of(stage_ms[k]);
      stages.push_back({{"stage", r.stages[k].def->name}, {"median_ms", med}});
      char buf[64];
      std::snprintf(buf, sizeof buf, "%s%s %.0f", line.empty() ? "" : ", ", r.stages[k].def->name.c_str(), med);
      line += buf;
    }
    e["stages"] = stages;
    e["peak_memory_bytes"] = peak_rss_bytes();
    print_row(e);
    std::printf("    stages (median ms, generation only): %s\n", line.c_str());
    entries.push_back(e);
  }
}

}  // namespace relief::cli
