// World builds (relief/world.hpp, issue 18), each against one whole-map run of the same recipe at
// the same size in the same run, so that the tiled overhead is a ratio:
//   * the island preset (pointwise and neighbourhood stages): the stages on the tiles' grown
//     windows alone, and the whole build into a tile store (zlib tiles, fsync, overview);
//   * a river world of the river-island kind without its bounded erosion stages (noise, island,
//     redistribute, fill, flow, color, hillshade): the whole build, and per stage class (pointwise,
//     neighbourhood, exact global) the samples per second per core, whole map against tiled.
// Registered by bench.cpp as the "world" group (void bench_world(const BenchSettings&, json&)).
#include <filesystem>
#include <map>
#include <unistd.h>

#include "bench_common.hpp"
#include "relief/world.hpp"

namespace relief::cli {
namespace {

// The river-island preset without its bounded stages (stream_power, hydraulic, thermal), with a
// fill before the flow: every stage is exact in a world build.
json river_world_doc(int n) {
  json doc = preset_doc("river-island", n);
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    const std::string name = st.value("stage", "");
    if (name == "stream_power" || name == "hydraulic" || name == "thermal") continue;
    if (name == "flow") stages.push_back({{"stage", "fill"}, {"epsilon_m", st.value("epsilon_m", 0.0)}});
    stages.push_back(st);
  }
  doc["stages"] = stages;
  doc["name"] = "river-world";
  return doc;
}

const char* stage_class(const StageDef& d) {
  switch (d.locality) {
    case Locality::Pointwise: return "pointwise";
    case Locality::Neighbourhood: return "neighbourhood";
    case Locality::Global: break;
  }
  return "global";
}

void bench_world_rivers(const BenchSettings& s, json& entries, int n, const std::filesystem::path& dir) {
  const Recipe r = parse_recipe(river_world_doc(n));
  for (int threads : s.threads) {
    RunOptions whole_opt;
    whole_opt.threads = threads;
    // Per-stage times of the whole map, medians over the runs.
    std::map<std::string, std::vector<double>> whole_stage;
    const Sample whole = time_runs(s.runs, [&] {
      const RunResult res = run(r, whole_opt);
      for (const StageTiming& t : res.timings) whole_stage[t.label.empty() ? t.name : t.label].push_back(t.ms);
    });
    json base = timing_entry("world rivers whole map (stages)", n, n, threads, whole);
    base["stages"] = json::array();
    for (const auto& st : r.stages) base["stages"].push_back(st.def->name);
    print_row(base);
    entries.push_back(base);
    for (int tile : {257, 1025}) {
      if (tile > n) continue;
      std::map<std::string, std::vector<double>> tiled_stage;
      WorldReport last;
      const Sample build = time_runs(
          s.runs,
          [&] {
            WorldSettings ws;
            ws.recipe = r;
            ws.tile = tile;
            ws.out_dir = dir.string();
            ws.threads = threads;
            last = build_world(ws);
            for (const StageTiming& t : last.timings) tiled_stage[t.label.empty() ? t.name : t.label].push_back(t.ms);
          },
          [&] { std::filesystem::remove_all(dir); });
      json b = timing_entry("world rivers build " + std::to_string(tile), n, n, threads, build);
      b["ratio_to_whole_map"] = build.median / whole.median;
      b["store_bytes"] = last.store_bytes;
      b["peak_memory_bytes"] = peak_rss_bytes();
      // Per stage class: samples per second per core, whole map and tiled, and their ratio.
      std::map<std::string, std::pair<double, double>> cls;  // class → (whole ms, tiled ms)
      json per_stage = json::array();
      for (const auto& st : r.stages) {
        const std::string key = st.label.empty() ? st.def->name : st.label;
        const double w = whole_stage.count(key) ? median_of(whole_stage[key]) : 0, t = tiled_stage.count(key) ? median_of(tiled_stage[key]) : 0;
        const char* c = stage_class(*st.def);
        cls[c].first += w;
        cls[c].second += t;
        per_stage.push_back({{"stage", key}, {"class", c}, {"whole_ms", w}, {"tiled_ms", t}, {"ratio", w > 0 ? t / w : 0.0}});
      }
      b["per_stage"] = per_stage;
      json classes = json::object();
      const double samples = double(n) * double(n);
      for (const auto& [c, wt] : cls)
        classes[c] = {{"whole_msamples_per_core_s", wt.first > 0 ? samples / (wt.first * 1e3) / threads : 0.0},
                      {"tiled_msamples_per_core_s", wt.second > 0 ? samples / (wt.second * 1e3) / threads : 0.0},
                      {"tiled_over_whole", wt.first > 0 ? wt.second / wt.first : 0.0}};
      b["classes"] = classes;
      print_row(b);
      entries.push_back(b);
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace

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
  bench_world_rivers(s, entries, n, dir);
}

}  // namespace relief::cli
