// `relief bench`: timings as medians of several runs, with libnoise (the peer) measured in the
// same run so that a ratio, not an absolute time, carries the claim. Machines are shared and
// noisy: never a pass/fail threshold here or in the tests.
#include "bench.hpp"

#include <sys/resource.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <libnoise/noise.h>

#include "../../src/parallel.hpp"
#include "relief/noise.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "relief/tilemap.hpp"

namespace relief::cli {
namespace {

struct Sample {
  double median = 0, min = 0, max = 0;
};

template <class F>
Sample time_runs(int runs, F&& f) {
  std::vector<double> ms;
  f();  // warm-up: page faults, caches, lazy init
  for (int r = 0; r < runs; ++r) {
    auto t0 = std::chrono::steady_clock::now();
    f();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  Sample s;
  s.min = ms.front();
  s.max = ms.back();
  s.median = ms.size() % 2 ? ms[ms.size() / 2] : 0.5 * (ms[ms.size() / 2 - 1] + ms[ms.size() / 2]);
  return s;
}

std::uint64_t peak_rss() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return std::uint64_t(u.ru_maxrss) * 1024;
}

struct NoiseCase {
  std::string name;
  NoiseBasis basis;
  Fractal fractal;
  int octaves;
  const char* peer;  // libnoise module or nullptr
};

}  // namespace

namespace {
const std::vector<std::string> kGroups = {"noise", "stages", "presets", "tilemap"};
}

bool is_bench_group(const std::string& name) {
  return std::find(kGroups.begin(), kGroups.end(), name) != kGroups.end();
}

std::string bench_group_list() {
  std::string out;
  for (auto& g : kGroups) out += (out.empty() ? "" : ", ") + g;
  return out;
}

int run_bench(const BenchSettings& s) {
  json entries = json::array();
  auto print_row = [](const json& e) {
    std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f", e["name"].get<std::string>().c_str(),
                (std::to_string(e["size"][0].get<int>()) + "²").c_str(), e["threads"].get<int>(), e["median_ms"].get<double>(),
                e["min_ms"].get<double>(), e["max_ms"].get<double>(), e["msamples_per_s"].get<double>());
    if (e.contains("peer")) {
      std::printf("   %-22s %9.1f  %7.1fx", e["peer"]["name"].get<std::string>().c_str(),
                  e["peer"]["msamples_per_s"].get<double>(), e["ratio"].get<double>());
    }
    std::printf("\n");
    std::fflush(stdout);
  };
  std::printf("%-28s %6s %3s %10s %10s %10s %9s   %-22s %9s  %8s\n", "case", "size", "thr", "median ms", "min ms",
              "max ms", "Msamp/s", "peer (libnoise)", "Msamp/s", "ratio");

  auto want = [&](const std::string& group) {
    return s.cases.empty() || std::find(s.cases.begin(), s.cases.end(), group) != s.cases.end();
  };

  if (want("noise")) {
    const std::vector<NoiseCase> cases = {
        {"perlin", NoiseBasis::Perlin, Fractal::None, 1, "Perlin"},
        {"simplex", NoiseBasis::Simplex, Fractal::None, 1, nullptr},
        {"value", NoiseBasis::Value, Fractal::None, 1, nullptr},
        {"cellular", NoiseBasis::Cellular, Fractal::None, 1, "Voronoi"},
        {"perlin fbm 6", NoiseBasis::Perlin, Fractal::Fbm, 6, "Perlin"},
        {"perlin ridged 6", NoiseBasis::Perlin, Fractal::Ridged, 6, "RidgedMulti"},
        {"simplex fbm 6", NoiseBasis::Simplex, Fractal::Fbm, 6, "Perlin"},
        {"simplex ridged 6", NoiseBasis::Simplex, Fractal::Ridged, 6, "RidgedMulti"},
    };
    const int n = s.noise_size;
    std::vector<float> buf(std::size_t(n) * n);
    const int pn = std::min(n, s.peer_size);
    std::vector<double> pbuf(std::size_t(pn) * pn);
    for (int threads : s.threads) {
      tbb::task_arena arena(threads);
      for (auto& c : cases) {
        NoiseSettings ns;
        ns.basis = c.basis;
        ns.fractal = c.fractal;
        ns.octaves = c.octaves;
        ns.frequency = 1.0 / 64.0;  // 64 samples per first-octave cycle
        ns.seed = 1;
        Noise noise(ns);
        Sample t = time_runs(s.runs, [&] {
          arena.execute([&] {
            detail::parallel_rows(n, [&](int j) { noise.row(double(j), 0, 1.0, n, buf.data() + std::size_t(j) * n); }, 16);
          });
        });
        json e;
        e["name"] = c.name;
        e["size"] = json::array({n, n});
        e["threads"] = threads;
        e["median_ms"] = t.median;
        e["min_ms"] = t.min;
        e["max_ms"] = t.max;
        e["msamples_per_s"] = double(n) * n / (t.median * 1e3);
        if (c.peer) {
          std::unique_ptr<noise::module::Module> m;
          std::string peer = c.peer;
          if (peer == "Perlin") {
            auto p = std::make_unique<noise::module::Perlin>();
            p->SetOctaveCount(c.octaves);
            p->SetFrequency(1.0 / 64.0);
            p->SetNoiseQuality(noise::QUALITY_BEST);  // quintic fade, as ours
            m = std::move(p);
          } else if (peer == "RidgedMulti") {
            auto p = std::make_unique<noise::module::RidgedMulti>();
            p->SetOctaveCount(c.octaves);
            p->SetFrequency(1.0 / 64.0);
            p->SetNoiseQuality(noise::QUALITY_BEST);
            m = std::move(p);
          } else {
            auto p = std::make_unique<noise::module::Voronoi>();
            p->SetFrequency(1.0 / 64.0);
            p->EnableDistance(true);
            m = std::move(p);
          }
          Sample pt = time_runs(std::max(3, s.runs / 2 + 1), [&] {
            arena.execute([&] {
              detail::parallel_rows(pn, [&](int j) {
                for (int i = 0; i < pn; ++i) pbuf[std::size_t(j) * pn + i] = m->GetValue(double(i), double(j), 0.0);
              }, 16);
            });
          });
          const double pms = double(pn) * pn / (pt.median * 1e3);
          e["peer"] = {{"name", "libnoise " + peer + " " + std::to_string(c.octaves) + " oct"},
                       {"size", json::array({pn, pn})},
                       {"median_ms", pt.median},
                       {"min_ms", pt.min},
                       {"max_ms", pt.max},
                       {"msamples_per_s", pms}};
          e["ratio"] = e["msamples_per_s"].get<double>() / pms;
        }
        e["peak_memory_bytes"] = peak_rss();
        print_row(e);
        entries.push_back(e);
      }
    }
  }

  if (want("stages")) {
    // Pointwise stages on a size² layer against a plain copy of that layer (the floor: one read
    // and one write). The target is ≤ 2× the copy.
    const int n = s.noise_size;
    Terrain base;
    base.frame = World{n, n, 4000.0, 600.0, 0.4}.frame();
    {
      json noise_doc = {{"stage", "noise"}, {"octaves", 4}};
      auto st = find_stage("noise")->parse(noise_doc, "noise");
      Context c;
      c.seed = 1;
      st->apply(base, c);
    }
    const std::vector<float> original = base.get("height").data;
    std::vector<float> copy_dst(original.size());
    for (int threads : s.threads) {
      tbb::task_arena arena(threads);
      // The copy is split into the same row blocks the stages use.
      Sample copy = time_runs(s.runs, [&] {
        arena.execute([&] {
          detail::parallel_rows(n, [&](int j) {
            std::copy_n(original.data() + std::size_t(j) * n, n, copy_dst.data() + std::size_t(j) * n);
          }, 16);
        });
      });
      json ce;
      ce["name"] = "copy (floor)";
      ce["size"] = json::array({n, n});
      ce["threads"] = threads;
      ce["median_ms"] = copy.median;
      ce["min_ms"] = copy.min;
      ce["max_ms"] = copy.max;
      ce["msamples_per_s"] = double(n) * n / (copy.median * 1e3);
      print_row(ce);
      entries.push_back(ce);
      const std::vector<json> cases = {
          {{"stage", "redistribute"}, {"exponent", 1.4}},
          {{"stage", "redistribute"}, {"exponent", 1.4}, {"land_only", true}},
          {{"stage", "terrace"}, {"levels", 8}},
          {{"stage", "terrace"}, {"mode", "smooth"}, {"levels", 8}},
          {{"stage", "island"}, {"distance", "square_bump"}},
          {{"stage", "island"}, {"distance", "euclidean2"}},
          {{"stage", "island"}, {"distance", "hyperboloid"}},
          {{"stage", "island"}, {"distance", "trig_product"}},
          {{"stage", "island"}, {"distance", "squircle"}},
          {{"stage", "island"}, {"distance", "circular"}, {"shaping", "subtract"}},
          {{"stage", "curve"}, {"points", json::array({json::array({0, 0}), json::array({0.4, 0.2}), json::array({0.7, 0.8}), json::array({1, 1})})}},
      };
      for (const json& c : cases) {
        auto st = find_stage(c["stage"].get<std::string>())->parse(c, "bench");
        Terrain t = base;
        Context ctx;
        ctx.seed = 1;
        std::vector<double> ms;
        for (int r = 0; r <= s.runs; ++r) {
          std::copy(original.begin(), original.end(), t.get("height").data.begin());
          auto t0 = std::chrono::steady_clock::now();
          arena.execute([&] { st->apply(t, ctx); });
          if (r > 0) ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
        std::sort(ms.begin(), ms.end());
        std::string name = c["stage"].get<std::string>();
        for (auto it = c.begin(); it != c.end(); ++it)
          if (it.key() != "stage" && it.key() != "points") name += " " + (it.value().is_string() ? it.value().get<std::string>() : it.key());
        json e;
        e["name"] = name;
        e["size"] = json::array({n, n});
        e["threads"] = threads;
        e["median_ms"] = ms[ms.size() / 2];
        e["min_ms"] = ms.front();
        e["max_ms"] = ms.back();
        e["msamples_per_s"] = double(n) * n / (ms[ms.size() / 2] * 1e3);
        e["vs_copy"] = ms[ms.size() / 2] / copy.median;
        std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   %.2fx copy\n", name.c_str(), (std::to_string(n) + "²").c_str(),
                    threads, ms[ms.size() / 2], ms.front(), ms.back(), e["msamples_per_s"].get<double>(), e["vs_copy"].get<double>());
        std::fflush(stdout);
        entries.push_back(e);
      }
    }
  }

  if (want("presets")) {
    for (int size : s.preset_sizes) {
      for (auto& p : list_presets()) {
        if (p.origin != "built-in") continue;
        json doc = load_preset(p.name);
        doc["world"]["size"] = size;
        doc["seed"] = 1;
        Recipe r = parse_recipe(doc);
        for (int threads : s.threads) {
          RunOptions o;
          o.threads = threads;
          // Whole pipeline: stages, then every default writer except the OBJ above 1025²
          // (gigabytes of text), encoded in memory.
          Sample t = time_runs(s.runs, [&] {
            RunResult res = run(r, o);
            MemoryOutput mem;
            WriteContext wc;
            wc.seed = res.seed;
            tbb::task_arena arena(threads);
            arena.execute([&] {
              for (auto& w : writer_registry()) {
                if (!w.in_default_set || (w.name == "obj" && size > 1025)) continue;
                w.write(res.terrain, wc, mem);
              }
            });
          });
          json e;
          e["name"] = "preset " + p.name + (size > 1025 ? " (no obj)" : "");
          e["size"] = json::array({size, size});
          e["threads"] = threads;
          e["median_ms"] = t.median;
          e["min_ms"] = t.min;
          e["max_ms"] = t.max;
          e["msamples_per_s"] = double(size) * size / (t.median * 1e3);
          e["peak_memory_bytes"] = peak_rss();
          print_row(e);
          entries.push_back(e);
        }
      }
    }
  }
  if (want("tilemap")) {
    // A 256×256-tile map with k = 5 types and 32 px tiles over the island preset at 1025² (4
    // height samples per tile): the stage (corner classification + tile choice), the atlas, the
    // Tiled/CSV exports, the 8192² map render with its PNG, and all of it end to end.
    json doc = load_preset("island");
    doc["world"]["size"] = 1025;
    doc["seed"] = 1;
    doc["stages"].push_back({{"stage", "tilemap"},
                             {"tiles_x", 256},
                             {"tiles_z", 256},
                             {"tile_size", 32},
                             {"types", json::array({{{"at", 0.30}, {"color", "#1d4877"}, {"name", "deep water"}},
                                                    {{"at", 0.40}, {"color", "#3a7cb8"}, {"name", "water"}},
                                                    {{"at", 0.43}, {"color", "#d8c88e"}, {"name", "sand"}},
                                                    {{"at", 0.62}, {"color", "#6b9b45"}, {"name", "grass"}},
                                                    {{"at", 1.00}, {"color", "#3c6b32"}, {"name", "forest"}}})}});
    const Recipe r = parse_recipe(doc);
    const StageDef* def = find_stage("tilemap");
    const WriterDef* writer = find_writer("tilemap");
    for (int threads : s.threads) {
      RunOptions o;
      o.threads = threads;
      RunResult base = run(r, o);  // every stage, once, for the per-part timings below
      const TileMap& m = *base.terrain.tilemap;
      tbb::task_arena arena(threads);
      auto stage = def->parse(doc["stages"].back(), "stages[5]");
      auto row = [&](const std::string& name, const Sample& t) {
        json e;
        e["name"] = name;
        e["size"] = json::array({256, 256});
        e["threads"] = threads;
        e["median_ms"] = t.median;
        e["min_ms"] = t.min;
        e["max_ms"] = t.max;
        e["msamples_per_s"] = 256.0 * 256.0 / (t.median * 1e3);  // tiles per µs
        e["peak_memory_bytes"] = peak_rss();
        print_row(e);
        entries.push_back(e);
      };
      row("tilemap stage k5", time_runs(s.runs, [&] {
            arena.execute([&] {
              Context ctx;
              ctx.seed = 1;
              ctx.stage_index = 5;
              stage->apply(base.terrain, ctx);
            });
          }));
      RgbImage atlas;
      row("tilemap atlas k5 32px", time_runs(s.runs, [&] {
            arena.execute([&] {
              atlas = render_atlas(m.style);
              encode_png_rgb8(atlas.rgb.data(), atlas.width, atlas.height);
            });
          }));
      row("tilemap tsx+tmx+tmj+csv", time_runs(s.runs, [&] {
            encode_tsx(m.style);
            encode_tmx(m);
            encode_tmj(m);
            encode_tile_csv(m);
          }));
      row("tilemap render 8192² + png", time_runs(s.runs, [&] {
            arena.execute([&] {
              const RgbImage img = render_map(m, atlas);
              encode_png_rgb8(img.rgb.data(), img.width, img.height);
            });
          }));
      row("tilemap end to end", time_runs(s.runs, [&] {
            RunResult res = run(r, o);
            MemoryOutput mem;
            WriteContext wc;
            wc.seed = res.seed;
            arena.execute([&] { writer->write(res.terrain, wc, mem); });
          }));
    }
  }

  std::printf("peak memory %.1f MiB\n", double(peak_rss()) / (1 << 20));
  if (!s.json_path.empty()) {
    json doc;
    doc["runs"] = s.runs;
    doc["hardware_threads"] = int(std::thread::hardware_concurrency());
    doc["entries"] = entries;
    doc["peak_memory_bytes"] = peak_rss();
    write_file_atomic(s.json_path, doc.dump(2) + "\n");
    std::printf("wrote %s\n", s.json_path.c_str());
  }
  return 0;
}

}  // namespace relief::cli
