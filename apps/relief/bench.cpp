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
#include <functional>
#include <libnoise/noise.h>

#include "../../src/parallel.hpp"
#include "relief/export.hpp"
#include "relief/noise.hpp"
#include "relief/random.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

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
  if (want("export")) {
    // Every export writer on the island preset with 2000 props, at each preset size, with the
    // largest thread count given: median encode time and the bytes written. The OBJ is skipped
    // above 1025² (gigabytes of text), as in the preset cases.
    const int threads = s.threads.back();
    tbb::task_arena arena(threads);
    std::printf("\n%-28s %6s %3s %10s %10s %10s %12s\n", "export case", "size", "thr", "median ms", "min ms", "max ms", "bytes");
    for (int size : s.preset_sizes) {
      json doc = load_preset("island");
      doc["world"]["size"] = size;
      doc["seed"] = 1;
      RunOptions o;
      o.threads = threads;
      RunResult res = run(parse_recipe(doc), o);
      Terrain& t = res.terrain;
      const Layer& h = t.get("height");
      for (int k = 0; k < 2000; ++k) {
        const auto i = int(hash64(7, std::uint64_t(k)) % std::uint64_t(t.frame.nx));
        const auto j = int(hash64(8, std::uint64_t(k)) % std::uint64_t(t.frame.nz));
        Point p;
        p.kind = "prop";
        p.type = prop_types()[std::size_t(k) % prop_types().size()];
        p.x_m = t.frame.x_m(i);
        p.z_m = t.frame.z_m(j);
        p.y_m = t.frame.y_m(h.data[std::size_t(j) * std::size_t(t.frame.nx) + std::size_t(i)]);
        p.rotation_deg = double(k * 37 % 360);
        t.points.push_back(p);
      }
      struct Case {
        std::string name, writer;
        std::function<void(ExportOptions&)> set;
      };
      const int legal_unity = (size - 1) % 4096 == 0 || (size >= 33 && size <= 4097 && ((size - 1) & (size - 2)) == 0);
      std::vector<Case> cases = {
          {"glb", "glb", nullptr},
          {"glb lod 3 + msft_lod", "glb", [](ExportOptions& e) { e.lod_levels = 3, e.lod_msft = true; }},
          {"glb simplify 1 m", "glb", [](ExportOptions& e) { e.simplify_error_m = 1.0; }},
          {"glb lowpoly 2 m", "glb", [](ExportOptions& e) { e.simplify_error_m = 2.0, e.style = "lowpoly"; }},
          {"glb gpu instancing", "glb", [](ExportOptions& e) { e.instancing = "gpu"; }},
          {"fbx", "fbx", nullptr},
          {"stl", "stl", nullptr},
          {"obj", "obj", nullptr},
          {"albedo png", "albedo", nullptr},
          {"heightmap", "heightmap", nullptr},
          {"normalmap 8-bit", "normalmap", nullptr},
          {"normalmap 16-bit", "normalmap", [](ExportOptions& e) { e.normal_bits = 16; }},
          {"splat", "splat", nullptr},
          {"hillshade", "hillshade", nullptr},
          {"engine unity raw", "engine", [](ExportOptions& e) { e.engine = "unity"; }},
          {"engine godot exr", "engine", [](ExportOptions& e) { e.engine = "godot"; }},
      };
      for (auto& c : cases) {
        if (c.writer == "obj" && size > 1025) continue;
        if (c.writer == "engine" && !legal_unity) continue;
        WriteContext wc;
        wc.seed = res.seed;
        if (c.set) c.set(wc.options);
        std::uint64_t bytes = 0;
        Sample tm = time_runs(s.runs, [&] {
          MemoryOutput mem;
          arena.execute([&] { find_writer(c.writer)->write(t, wc, mem); });
          bytes = 0;
          for (auto& [n, b] : mem.files) bytes += b.size();
        });
        json e;
        e["name"] = "export " + c.name;
        e["size"] = json::array({size, size});
        e["threads"] = threads;
        e["median_ms"] = tm.median;
        e["min_ms"] = tm.min;
        e["max_ms"] = tm.max;
        e["bytes"] = bytes;
        e["msamples_per_s"] = double(size) * size / (tm.median * 1e3);
        e["peak_memory_bytes"] = peak_rss();
        std::printf("%-28s %6s %3d %10.1f %10.1f %10.1f %12llu\n", c.name.c_str(), (std::to_string(size) + "²").c_str(), threads,
                    tm.median, tm.min, tm.max, (unsigned long long)bytes);
        std::fflush(stdout);
        entries.push_back(e);
      }
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
