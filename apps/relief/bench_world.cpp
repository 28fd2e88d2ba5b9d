// World builds (relief/world.hpp, issue 18): the island preset (pointwise and neighbourhood stages)
// as one whole-map run against the same world built as tiles — the stages on the tiles' grown
// windows alone, and the whole build into a tile store (zlib tiles, fsync, overview) — so that
// the tiled overhead is a ratio measured in the same run. Registered by bench.cpp as the "world"
// group (void bench_world(const BenchSettings&, json&)).
#include <filesystem>
#include <unistd.h>

#include "bench_common.hpp"
#include "relief/world.hpp"

namespace relief::cli {

void bench_world(const BenchSettings& s, json& entries) {
  const int n = s.preset_sizes.empty() ? 4097 : std::max(257, s.preset_sizes.back());
  const json doc = preset_doc("island", n);
  const Recipe r = parse_recipe(doc);
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("relief-bench-world-" + std::to_string(::getpid()));
  for (int threads : s.threads) {
    RunOptions whole_opt;
    whole_opt.threads = threads;
    const Sample whole = time_runs(s.runs, [&] { run(r, whole_opt); });
    json base = timing_entry("world island whole map (stages)", n, n, threads, whole);
    base["peak_memory_bytes"] = peak_rss_bytes();
    print_row(base);
    entries.push_back(base);
    for (int tile : {257, 1025}) {
      if (tile > n) continue;
      const WorldGrid g = world_grid(n, n, tile);
      // The stages alone on every tile's window (grown by the halo and cropped by run()).
      const Sample stages = time_runs(s.runs, [&] {
        RunOptions o;
        o.threads = threads;
        for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
          for (std::int64_t X = 0; X < g.tiles_x; ++X) {
            const WorldGrid::Window w = g.window(X, Z);
            o.window = r.world.frame().window(w.ix0, w.iz0, w.nx, w.nz);
            run(r, o);
          }
      });
      json e = timing_entry("world island tiles " + std::to_string(tile) + " (stages)", n, n, threads, stages);
      e["ratio_to_whole_map"] = stages.median / whole.median;
      print_row(e);
      entries.push_back(e);
      // The whole build: stages, tile files (shuffle + zlib + CRC + fsync), overview, manifest.
      const Sample build = time_runs(
          s.runs,
          [&] {
            WorldSettings ws;
            ws.recipe = r;
            ws.tile = tile;
            ws.out_dir = dir.string();
            ws.threads = threads;
            build_world(ws);
          },
          [&] { std::filesystem::remove_all(dir); });
      json b = timing_entry("world island build " + std::to_string(tile), n, n, threads, build);
      b["ratio_to_whole_map"] = build.median / whole.median;
      std::uint64_t bytes = 0;
      for (const auto& f : std::filesystem::directory_iterator(dir / "tiles")) bytes += f.file_size();
      b["store_bytes"] = bytes;
      b["peak_memory_bytes"] = peak_rss_bytes();
      print_row(b);
      entries.push_back(b);
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace relief::cli
