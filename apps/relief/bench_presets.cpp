// Presets: every built-in preset through relief::generate into memory, at each preset size.
#include "bench_common.hpp"
#include "relief/generate.hpp"
#include "relief/output.hpp"

namespace relief::cli {

void bench_presets(const BenchSettings& s, json& entries) {
  for (int size : s.preset_sizes) {
    for (auto& p : list_presets()) {
      if (p.origin != "built-in") continue;
      Recipe r = parse_recipe(preset_doc(p.name, size));
      for (int threads : s.threads) {
        RunOptions o;
        o.threads = threads;
        // Whole pipeline: stages, then every default writer except the OBJ above 1025²
        // (gigabytes of text), encoded in memory, the writers running concurrently as in
        // `relief generate` (one task each, into an output of its own).
        // relief::generate, as `relief generate` runs it, into memory.
        GenerateSettings gs;
        gs.recipe = r;
        gs.formats = size > 1025 ? "default,-obj" : "default";  // no OBJ above 1025² (gigabytes of text)
        gs.threads = threads;
        Sample t = time_runs(s.runs, [&] {
          MemoryOutput mem;
          generate(gs, mem);
        });
        json e = timing_entry("preset " + p.name + (size > 1025 ? " (no obj)" : ""), size, size, threads, t);
        e["peak_memory_bytes"] = peak_rss_bytes();
        print_row(e);
        entries.push_back(e);
      }
    }
  }
}

}  // namespace relief::cli
