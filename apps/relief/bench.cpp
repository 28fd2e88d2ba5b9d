// `relief bench`: timings as medians of several runs, with libnoise (the peer) measured in the
// same run so that a ratio, not an absolute time, carries the claim. Machines are shared and
// noisy: never a pass/fail threshold here or in the tests.
#include "bench.hpp"

#include <sys/resource.h>
#include <time.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <libnoise/noise.h>

#include "../../src/noise_simd.hpp"
#include "../../src/parallel.hpp"
#include "relief/noise.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

namespace relief::cli {
namespace {

struct Sample {
  double median = 0, min = 0, max = 0;
  // Median CPU time of the process over the same runs (all threads). On a shared, overloaded
  // machine the wall time includes waiting for a core; CPU time shows the work itself.
  double cpu_median = 0;
};

double process_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

template <class F>
Sample time_runs(int runs, F&& f) {
  std::vector<double> ms, cpu;
  f();  // warm-up: page faults, caches, lazy init
  for (int r = 0; r < runs; ++r) {
    const double c0 = process_cpu_ms();
    auto t0 = std::chrono::steady_clock::now();
    f();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    cpu.push_back(process_cpu_ms() - c0);
  }
  Sample s;
  s.min = *std::min_element(ms.begin(), ms.end());
  s.max = *std::max_element(ms.begin(), ms.end());
  s.median = median_of(ms);
  s.cpu_median = median_of(cpu);
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
    if (e.contains("cpu_median_ms")) std::printf(" %8.2f", e["cpu_median_ms"].get<double>());
    else std::printf(" %8s", "");
    if (e.contains("peer")) {
      std::printf("   %-22s %9.1f  %7.1fx %7.1fx", e["peer"]["name"].get<std::string>().c_str(),
                  e["peer"]["msamples_per_s"].get<double>(), e["ratio"].get<double>(), e["cpu_ratio"].get<double>());
    }
    std::printf("\n");
    std::fflush(stdout);
  };
  std::printf("%-28s %6s %3s %10s %10s %10s %9s %8s   %-22s %9s  %8s %8s\n", "case", "size", "thr", "median ms", "min ms",
              "max ms", "Msamp/s", "cpu ms", "peer (libnoise)", "Msamp/s", "ratio", "cpu ratio");

  auto want = [&](const std::string& group) {
    return s.cases.empty() || std::find(s.cases.begin(), s.cases.end(), group) != s.cases.end();
  };

  if (want("noise")) {
    // Peers: libnoise's Perlin module (gradient noise; 1 octave for the single-octave gradient-like
    // bases), its value-noise function, Voronoi for cellular and RidgedMulti for ridged, each at
    // our octave count.
    const std::vector<NoiseCase> cases = {
        {"perlin", NoiseBasis::Perlin, Fractal::None, 1, "Perlin"},
        {"gradient", NoiseBasis::Gradient, Fractal::None, 1, "Perlin"},
        {"simplex", NoiseBasis::Simplex, Fractal::None, 1, "Perlin"},
        {"value", NoiseBasis::Value, Fractal::None, 1, "Value"},
        {"cellular", NoiseBasis::Cellular, Fractal::None, 1, "Voronoi"},
        {"perlin fbm 6", NoiseBasis::Perlin, Fractal::Fbm, 6, "Perlin"},
        {"perlin ridged 6", NoiseBasis::Perlin, Fractal::Ridged, 6, "RidgedMulti"},
        {"gradient fbm 6", NoiseBasis::Gradient, Fractal::Fbm, 6, "Perlin"},
        {"gradient ridged 6", NoiseBasis::Gradient, Fractal::Ridged, 6, "RidgedMulti"},
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
        e["simd_target"] = detail::noise_simd_current_target();
        e["median_ms"] = t.median;
        e["min_ms"] = t.min;
        e["max_ms"] = t.max;
        e["cpu_median_ms"] = t.cpu_median;
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
          } else if (peer == "Value") {
            m = nullptr;  // noise::ValueCoherentNoise3D below (libnoise has no value-noise module)
          } else {
            auto p = std::make_unique<noise::module::Voronoi>();
            p->SetFrequency(1.0 / 64.0);
            p->EnableDistance(true);
            m = std::move(p);
          }
          Sample pt = time_runs(std::max(3, s.runs / 2 + 1), [&] {
            arena.execute([&] {
              detail::parallel_rows(pn, [&](int j) {
                if (m) {
                  for (int i = 0; i < pn; ++i) pbuf[std::size_t(j) * pn + i] = m->GetValue(double(i), double(j), 0.0);
                } else {
                  for (int i = 0; i < pn; ++i)
                    pbuf[std::size_t(j) * pn + i] = noise::ValueCoherentNoise3D(
                        double(i) / 64.0, double(j) / 64.0, 0.0, 1, noise::QUALITY_BEST);
                }
              }, 16);
            });
          });
          const double pms = double(pn) * pn / (pt.median * 1e3);
          e["peer"] = {{"name", "libnoise " + peer + " " + std::to_string(c.octaves) + " oct"},
                       {"size", json::array({pn, pn})},
                       {"median_ms", pt.median},
                       {"cpu_median_ms", pt.cpu_median},
                       {"min_ms", pt.min},
                       {"max_ms", pt.max},
                       {"msamples_per_s", pms}};
          e["ratio"] = e["msamples_per_s"].get<double>() / pms;
          // The same ratio by CPU time per sample: robust when other processes share the cores.
          e["cpu_ratio"] = (pt.cpu_median / (double(pn) * pn)) / (t.cpu_median / (double(n) * n));
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
