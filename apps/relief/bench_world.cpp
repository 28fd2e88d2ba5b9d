// World builds (relief/world.hpp, issue 18), each against one whole-map run of the same recipe at
// the same size in the same run, so that the tiled overhead is a ratio:
//   * the island preset (pointwise and neighbourhood stages): the stages on the tiles' grown
//     windows alone, and the whole build into a tile store (zlib tiles, fsync, overview);
//   * a river world of the river-island kind without its bounded erosion stages (noise, island,
//     redistribute, fill, flow, color, hillshade): the whole build, and per stage class (pointwise,
//     neighbourhood, exact global) the samples per second per core, whole map against tiled;
//   * the same river world built by `mpirun -n 1` and `-n 2` (`relief world` as a subprocess, one
//     thread per rank), when mpirun is on the PATH: wall times and their ratio; and so a 2113²
//     world of river-island up to its stream power (the refinement's blocks spread over the ranks).
// Opt-in large case: RELIEF_BENCH_WORLD_SIZE=N (e.g. 32769) runs only a river world of N² samples
// (noise, island, redistribute, fill, flow; tiles of RELIEF_BENCH_WORLD_TILE, default 1025) into a
// folder under RELIEF_BENCH_WORLD_DIR (default: the temp folder), printing the build's own disk
// estimate first, then wall time, per-stage times, samples per second per core per stage class,
// peak memory and store bytes; the folder is deleted after.
// Registered by bench.cpp as the "world" group (void bench_world(const BenchSettings&, json&)).
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <thread>

#include "bench_common.hpp"
#include "relief/error.hpp"
#include "relief/world.hpp"

namespace relief::cli {
namespace {

// The river-island preset without its bounded stages (stream_power, hydraulic, thermal), with a
// fill before the flow: every stage is exact in a world build.
// Without colour and hillshade when `colour` is false (the large case: what the benchmark of issue
// 18 names, noise, shaping, fill, flow and rivers).
json river_world_doc(int n, bool colour = true) {
  json doc = preset_doc("river-island", n);
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    const std::string name = st.value("stage", "");
    if (name == "stream_power" || name == "hydraulic" || name == "thermal") continue;
    if (!colour && (name == "color" || name == "hillshade")) continue;
    if (name == "flow") stages.push_back({{"stage", "fill"}, {"epsilon_m", st.value("epsilon_m", 0.0)}});
    stages.push_back(st);
  }
  doc["stages"] = stages;
  doc["name"] = "river-world";
  return doc;
}

// river-island up to its stream power stage (noise, island, redistribute, stream_power): at more than
// 2049 samples a side stream power's world algorithm refines its coarse solve on world blocks
// (relief/world_bounded.hpp), whose solves are farm tasks spread over the ranks.
json stream_power_world_doc(int n) {
  json doc = preset_doc("river-island", n);
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    stages.push_back(st);
    if (st.value("stage", "") == "stream_power") break;
  }
  doc["stages"] = stages;
  doc["name"] = "stream-power-world";
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

// `mpirun -n 1` against `-n 2` (one thread per rank) on a world (`what`: "rivers", the river world;
// "stream power", stream_power_world_doc): `relief world` as a subprocess (this executable), wall
// time per build, tiles each rank built, the farm's tasks per rank, and the ratio.
void bench_world_mpi(const BenchSettings& s, json& entries, int n, const std::filesystem::path& dir, const std::string& what = "rivers") {
  namespace fs = std::filesystem;
  if (std::system("command -v mpirun >/dev/null 2>&1") != 0) {
    std::printf("world mpi: skipped (mpirun is not on the PATH)\n");
    return;
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (ec) {
    std::printf("world mpi: skipped (cannot find this executable: %s)\n", ec.message().c_str());
    return;
  }
  fs::create_directories(dir, ec);
  const bool sp = what == "stream power";
  const fs::path recipe = dir / (sp ? "stream-power-world.json" : "river-world.json");
  std::ofstream(recipe) << (sp ? stream_power_world_doc(n) : river_world_doc(n)).dump(2);
  const int tile = n >= 2049 ? 257 : 129;
  double ms[2] = {0, 0};
  for (int ranks : {1, 2}) {
    const fs::path out = dir / ("mpi-" + std::to_string(ranks));
    const std::string cmd = "mpirun --oversubscribe --allow-run-as-root -n " + std::to_string(ranks) + " '" + exe.string() +
                            "' world '" + recipe.string() + "' --size " + std::to_string(n) + " --tile " + std::to_string(tile) +
                            " -j 1 -q -o '" + out.string() + "' >'" + (dir / "mpi.log").string() + "' 2>&1";
    bool failed = false;
    const Sample t = time_runs(
        s.runs,
        [&] {
          const int rc = std::system(cmd.c_str());
          failed = failed || rc != 0;
        },
        [&] { fs::remove_all(out, ec); });
    if (failed) {
      std::ifstream log(dir / "mpi.log");
      const std::string text((std::istreambuf_iterator<char>(log)), std::istreambuf_iterator<char>());
      std::printf("world mpi: `mpirun -n %d relief world` failed; skipped. Its output:\n%s\n", ranks,
                  text.substr(text.size() > 2000 ? text.size() - 2000 : 0).c_str());
      return;
    }
    ms[ranks - 1] = t.median;
    json e = timing_entry("world " + what + " mpi -n " + std::to_string(ranks), n, n, 1, t);
    e["ranks"] = ranks;
    e["tile"] = tile;
    std::ifstream rf(out / "report.json");
    const json report = json::parse(rf, nullptr, false);
    if (report.is_object() && report.contains("tiles")) {
      e["built_by_rank"] = report["tiles"].value("built_by_rank", json::array());
      e["global_solves_by_rank"] = report["tiles"].value("global_solves_by_rank", json::array());
    }
    if (ranks == 2) e["ratio_to_1_rank"] = ms[1] / ms[0];
    print_row(e);
    if (ranks == 2)
      std::printf("  2 ranks take %.2fx the time of 1 (local phases and the %s spread over the ranks); global solves by rank %s\n",
                  ms[1] / ms[0], sp ? "refinement's blocks of stream power" : "tile solves of fill and flow",
                  e.value("global_solves_by_rank", json::array()).dump().c_str());
    entries.push_back(e);
  }
}

// The opt-in large case (RELIEF_BENCH_WORLD_SIZE): one build, reported once.
void bench_world_large(const BenchSettings& s, json& entries, int n) {
  namespace fs = std::filesystem;
  const char* tile_env = std::getenv("RELIEF_BENCH_WORLD_TILE");
  const int tile = tile_env ? std::atoi(tile_env) : 1025;
  const char* dir_env = std::getenv("RELIEF_BENCH_WORLD_DIR");
  const fs::path dir = fs::path(dir_env ? dir_env : fs::temp_directory_path().string()) / ("relief-bench-world-large-" + std::to_string(::getpid()));
  const int threads = s.threads.empty() ? 0 : s.threads.back();
  // The recipe at a size one map may have; the world's size is the build's (it may be larger).
  const Recipe r = parse_recipe(river_world_doc(std::min(n, 1025), false));
  WorldSettings ws;
  ws.recipe = r;
  ws.nx = ws.nz = n;
  ws.tile = tile;
  ws.out_dir = dir.string();
  ws.threads = threads;
  // The disk estimate first: the build's own checks, as `relief world --dry-run` makes them.
  std::error_code ec;
  const fs::space_info sp = fs::space(fs::path(dir_env ? dir_env : fs::temp_directory_path().string()), ec);
  {
    WorldSettings probe = ws;
    probe.dry_run = true;
    try {
      const WorldReport est = build_world(probe);
      std::printf("world large %d² (tiles of %d): the disk check estimates %s on disk in all (%s for the final store), "
                  "%s of memory for the tiles built at once; free here: %s\n",
                  n, tile, human_bytes(est.estimated_bytes).c_str(), human_bytes(est.estimated_store_bytes).c_str(),
                  human_bytes(est.tile_memory_bytes).c_str(), ec ? "?" : human_bytes(sp.available).c_str());
    } catch (const Error& e) {
      std::printf("world large %d² (tiles of %d): the checks refuse it: %s\n", n, tile, e.message().c_str());
    }
  }
  std::fflush(stdout);
  int last_pct = -1;
  ws.progress = [&](const WorldProgress& p) {
    const int pct = int(p.fraction * 20) * 5;
    if (pct == last_pct) return;
    last_pct = pct;
    std::fprintf(stderr, "  %3d%% (%lld of %lld tiles)\n", pct, (long long)p.tiles_done, (long long)p.tiles_total);
  };
  WorldReport rep;
  try {
    rep = build_world(ws);
  } catch (...) {
    fs::remove_all(dir, ec);
    throw;
  }
  fs::remove_all(dir, ec);
  const int used = rep.tiles_at_once > 1 ? rep.tiles_at_once : (threads > 0 ? threads : int(std::thread::hardware_concurrency()));
  Sample t;
  t.median = t.min = t.max = rep.total_ms;
  json e = timing_entry("world rivers large " + std::to_string(tile), n, n, used, t);
  e["peak_memory_bytes"] = rep.peak_memory_bytes;
  e["store_bytes"] = rep.store_bytes;
  e["estimated_store_bytes"] = rep.estimated_store_bytes;  // the final store's part, comparable with store_bytes
  e["estimated_bytes"] = rep.estimated_bytes;              // the disk check's whole need
  e["tiles"] = rep.grid.count();
  print_row(e);
  const double samples = double(n) * double(n);
  std::printf("  wall %.1f s, peak memory %s, store %s (estimate %s; whole need %s), %lld tiles of %d, %d threads\n",
              rep.total_ms / 1e3, human_bytes(rep.peak_memory_bytes).c_str(), human_bytes(rep.store_bytes).c_str(),
              human_bytes(rep.estimated_store_bytes).c_str(), human_bytes(rep.estimated_bytes).c_str(),
              (long long)rep.grid.count(), tile, used);
  // Local stages' times are summed over the tiles (each tile on one thread when tiles are built
  // concurrently): per core already. Global stages' times are wall times on `used` threads.
  std::map<std::string, double> cls;  // class → core-seconds
  json per_stage = json::array();
  for (std::size_t i = 0; i < rep.timings.size(); ++i) {
    const StageTiming& st = rep.timings[i];
    const char* c = stage_class(*r.stages[i].def);
    const bool global = r.stages[i].def->locality == Locality::Global;
    const double core_s = st.ms / 1e3 * (global || rep.tiles_at_once == 1 ? used : 1);
    cls[c] += core_s;
    const double per_core = core_s > 0 ? samples / core_s : 0;
    std::printf("  %-14s %-13s %9.1f s  %8.2f Msamples/s/core\n", (st.label.empty() ? st.name : st.label).c_str(), c, st.ms / 1e3,
                per_core / 1e6);
    per_stage.push_back({{"stage", st.name}, {"class", c}, {"ms", st.ms}, {"msamples_per_core_s", per_core / 1e6}});
  }
  json classes = json::object();
  for (const auto& [c, core_s] : cls) {
    classes[c] = {{"core_s", core_s}, {"msamples_per_core_s", core_s > 0 ? samples / core_s / 1e6 : 0.0}};
    std::printf("  class %-13s %8.2f Msamples/s/core\n", c.c_str(), core_s > 0 ? samples / core_s / 1e6 : 0.0);
  }
  e["per_stage"] = per_stage;
  e["classes"] = classes;
  entries.push_back(e);
}

}  // namespace

void bench_world(const BenchSettings& s, json& entries) {
  if (const char* large = std::getenv("RELIEF_BENCH_WORLD_SIZE")) {
    std::printf("RELIEF_BENCH_WORLD_SIZE=%s: only the large world case\n", large);
    bench_world_large(s, entries, std::atoi(large));
    return;
  }
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
  bench_world_mpi(s, entries, std::min(n, 2049), dir);
  // Stream power's refinement at 2113² (coarse 1057², 3 × 3 blocks of 1024 grown by 192, 6 sweeps).
  bench_world_mpi(s, entries, 2113, dir, "stream power");
  std::filesystem::remove_all(dir);
}

}  // namespace relief::cli
