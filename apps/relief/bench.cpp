// `relief bench`: timings as medians of several runs, with libnoise (the peer) measured in the
// same run so that a ratio, not an absolute time, carries the claim. Machines are shared and
// noisy: never a pass/fail threshold here or in the tests.
#include "bench.hpp"

#include <sys/resource.h>
#include <time.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <ctime>
#include <utility>
#include <functional>
#include <libnoise/noise.h>

#include "../../src/erosion.hpp"
#include "../../src/hydrology.hpp"
#include "../../src/noise_simd.hpp"
#include "../../src/parallel.hpp"
#include "relief/export.hpp"
#include "relief/generate.hpp"
#include "relief/noise.hpp"
#include "relief/random.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "relief/tilemap.hpp"

namespace relief::cli {
namespace {

struct Sample {
  double median = 0, min = 0, max = 0;
  // Median process CPU time per run (all threads; with more than one thread it includes oneTBB's
  // workers spinning briefly after the work). On a shared, loaded machine the 1-thread CPU time
  // shows the work itself while wall time also holds the waits for a core.
  double cpu_median = 0;
};

double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// The fields every JSON entry has: name, grid size, threads, the median, min and max wall time,
// the median CPU time and the throughput (million grid cells per second).
json timing_entry(const std::string& name, int nx, int nz, int threads, const Sample& t) {
  json e;
  e["name"] = name;
  e["size"] = json::array({nx, nz});
  e["threads"] = threads;
  e["median_ms"] = t.median;
  e["min_ms"] = t.min;
  e["max_ms"] = t.max;
  e["cpu_median_ms"] = t.cpu_median;
  e["msamples_per_s"] = double(nx) * nz / (t.median * 1e3);
  return e;
}

// Runs setup() then f() once to warm up (page faults, caches, lazy init), then `runs` timed f()
// calls, each after an untimed setup().
template <class F, class S>
Sample time_runs(int runs, F&& f, S&& setup) {
  std::vector<double> ms, cpu;
  setup();
  f();
  for (int r = 0; r < runs; ++r) {
    setup();
    const double c0 = cpu_ms();
    auto t0 = std::chrono::steady_clock::now();
    f();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    cpu.push_back(cpu_ms() - c0);
  }
  Sample s;
  s.min = *std::min_element(ms.begin(), ms.end());
  s.max = *std::max_element(ms.begin(), ms.end());
  s.median = median_of(ms);
  s.cpu_median = median_of(cpu);
  return s;
}
template <class F>
Sample time_runs(int runs, F&& f) {
  return time_runs(runs, std::forward<F>(f), [] {});
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
  CellularReturn cellular = CellularReturn::F1;
};

// Issue 17's targets, as the ratio of a noise case's time to the `gradient` case with the same
// fractal measured in the same run (cellular: to single-octave gradient). 0: no target.
double noise_target(const NoiseCase& c) {
  switch (c.basis) {
    case NoiseBasis::Simplex: return 1.3;
    case NoiseBasis::Value: return c.fractal == Fractal::Ridged ? 0.0 : 1.0;
    case NoiseBasis::Cellular: return 3.0;
    case NoiseBasis::Perlin: return 2.5;
    case NoiseBasis::Gradient: return 0.0;
  }
  return 0.0;
}

// Prints, for each noise case of one thread count, its wall and CPU time as a ratio to the gradient
// case with the same fractal (cellular: 1 octave) in the same run, its target and whether the
// target is missed, and records them in the cases' JSON entries ("gradient_ratio",
// "gradient_cpu_ratio", "gradient_target", "target_met").
// entries[first + i] is cases[i]'s entry.
void print_noise_ratios(const std::vector<NoiseCase>& cases, json& all, std::size_t first) {
  auto entry = [&](std::size_t i) -> json& { return all[first + i]; };
  auto find_gradient = [&](Fractal f) -> const json* {
    for (std::size_t i = 0; i < cases.size(); ++i)
      if (cases[i].basis == NoiseBasis::Gradient && cases[i].fractal == f) return &entry(i);
    return nullptr;
  };
  std::printf("noise ratios to gradient with the same fractal (same run, %d thread(s)):\n",
              entry(0)["threads"].get<int>());
  std::printf("  %-22s %8s %8s %8s\n", "case", "wall", "cpu", "target");
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const NoiseCase& c = cases[i];
    if (c.basis == NoiseBasis::Gradient) continue;
    const json* g = find_gradient(c.basis == NoiseBasis::Cellular ? Fractal::None : c.fractal);
    if (!g) continue;
    json& e = entry(i);
    const double r = e["median_ms"].get<double>() / (*g)["median_ms"].get<double>();
    const double rc = e["cpu_median_ms"].get<double>() / (*g)["cpu_median_ms"].get<double>();
    const double target = noise_target(c);
    e["gradient_ratio"] = r;
    e["gradient_cpu_ratio"] = rc;
    std::printf("  %-22s %7.2fx %7.2fx", c.name.c_str(), r, rc);
    if (target > 0) {
      e["gradient_target"] = target;
      e["target_met"] = r <= target;
      std::printf(" %7.2fx%s", target, r <= target ? "" : "  MISSED");
    }
    std::printf("\n");
  }
  std::fflush(stdout);
}

}  // namespace

namespace {
const std::vector<std::string> kGroups = {"noise", "stages", "regenerate", "presets", "tilemap", "erosion", "islands", "export"};
}

bool is_bench_group(const std::string& name) {
  return std::find(kGroups.begin(), kGroups.end(), name) != kGroups.end();
}

std::string bench_group_list() {
  std::string out;
  for (auto& g : kGroups) out += (out.empty() ? "" : ", ") + g;
  return out;
}

// The processor's name as the kernel reports it ("model name" in /proc/cpuinfo), or "unknown":
// figures differ several-fold between machines (SIMD width, how wide the vector units really
// are), so every table and JSON file says where it was measured.
std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos && colon + 2 <= line.size()) return line.substr(colon + 2);
    }
  return "unknown";
}

int run_bench(const BenchSettings& s) {
  json entries = json::array();
  const std::string cpu = cpu_model(), simd = detail::noise_simd_current_target();
  std::printf("machine: %s, %u hardware threads, SIMD target %s\n", cpu.c_str(), std::thread::hardware_concurrency(),
              simd.c_str());
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
        {"value fbm 6", NoiseBasis::Value, Fractal::Fbm, 6, nullptr},
        {"cellular f2", NoiseBasis::Cellular, Fractal::None, 1, nullptr, CellularReturn::F2},
        {"cellular f2-f1", NoiseBasis::Cellular, Fractal::None, 1, nullptr, CellularReturn::F2MinusF1},
    };
    const int n = s.noise_size;
    std::vector<float> buf(std::size_t(n) * n);
    const int pn = std::min(n, s.peer_size);
    std::vector<double> pbuf(std::size_t(pn) * pn);
    for (int threads : s.threads) {
      tbb::task_arena arena(threads);
      const std::size_t first = entries.size();
      for (auto& c : cases) {
        NoiseSettings ns;
        ns.basis = c.basis;
        ns.cellular = c.cellular;
        ns.fractal = c.fractal;
        ns.octaves = c.octaves;
        ns.frequency = 1.0 / 64.0;  // 64 samples per first-octave cycle
        ns.seed = 1;
        Noise noise(ns);
        Sample t = time_runs(s.runs, [&] {
          arena.execute([&] {
            // Blocks of 16 rows: Noise::rows computes the x-only terms once per block and strip.
            detail::parallel_rows((n + 15) / 16, [&](int b) {
              const int j0 = b * 16, m = std::min(16, n - j0);
              double z[16];
              for (int r = 0; r < m; ++r) z[r] = double(j0 + r);
              noise.rows(z, m, 0, 1.0, n, buf.data() + std::size_t(j0) * n, n);
            }, 1);
          });
        });
        json e = timing_entry(c.name, n, n, threads, t);
        e["simd_target"] = detail::noise_simd_current_target();
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
      print_noise_ratios(cases, entries, first);
    }
  }

  if (want("stages")) {
    // Pointwise stages on a size² layer against a plain copy of that layer (the floor: one read
    // and one write). The target is ≤ 2× the copy. The colour stage writes a 3-channel layer and
    // is compared with a copy of a 3-channel layer of the same size. Hillshade reads the height and
    // the 3-channel albedo and writes the 1-channel 'shade' and the 3-channel colour, so its floor
    // copies the same bytes: height → shade and albedo → colour, row by row.
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
    // hillshade reads an albedo: the colour stage's output on this height field.
    Terrain coloured = base;
    {
      auto st = find_stage("color")->parse(json{{"stage", "color"}}, "color");
      Context c;
      c.seed = 1;
      st->apply(coloured, c);
    }
    const std::vector<float> original3(std::size_t(3) * n * n, 0.5f);
    std::vector<float> copy_dst(original.size()), copy_dst3(original3.size());
    for (int threads : s.threads) {
      tbb::task_arena arena(threads);
      // The copies are split into the same row blocks the stages use.
      auto time_copy = [&](const std::vector<float>& src, std::vector<float>& dst, int channels, const char* name) {
        const std::size_t w = std::size_t(n) * channels;
        Sample copy = time_runs(s.runs, [&] {
          arena.execute([&] {
            detail::parallel_rows(n, [&](int j) { std::copy_n(src.data() + j * w, w, dst.data() + j * w); });
          });
        });
        const json ce = timing_entry(name, n, n, threads, copy);
        std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   cpu %.2f ms\n", name, (std::to_string(n) + "²").c_str(), threads,
                    copy.median, copy.min, copy.max, ce["msamples_per_s"].get<double>(), copy.cpu_median);
        std::fflush(stdout);
        entries.push_back(ce);
        return copy;
      };
      const Sample copy1 = time_copy(original, copy_dst, 1, "copy (floor)");
      const Sample copy3 = time_copy(original3, copy_dst3, 3, "copy 3 channels (floor)");
      // Hillshade's floor: 1 + 3 channels in, 1 + 3 out (the copy above moves 3 + 3).
      const Sample copy4 = [&] {
        const std::size_t w = std::size_t(n);
        Sample c = time_runs(s.runs, [&] {
          arena.execute([&] {
            detail::parallel_rows(n, [&](int j) {
              std::copy_n(original.data() + j * w, w, copy_dst.data() + j * w);
              std::copy_n(original3.data() + 3 * j * w, 3 * w, copy_dst3.data() + 3 * j * w);
            });
          });
        });
        const json ce = timing_entry("copy 1+3 channels (floor)", n, n, threads, c);
        std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   cpu %.2f ms\n", "copy 1+3 channels (floor)",
                    (std::to_string(n) + "²").c_str(), threads, c.median, c.min, c.max, ce["msamples_per_s"].get<double>(),
                    c.cpu_median);
        std::fflush(stdout);
        entries.push_back(ce);
        return c;
      }();
      const std::vector<json> cases = {
          {{"stage", "redistribute"}, {"exponent", 1.4}},
          {{"stage", "redistribute"}, {"exponent", 1.4}, {"land_only", true}},
          {{"stage", "redistribute"}, {"exponent", 2.2}, {"modifier", 1.1}},
          {{"stage", "terrace"}, {"levels", 8}},
          {{"stage", "terrace"}, {"mode", "smooth"}, {"levels", 8}},
          {{"stage", "island"}, {"distance", "square_bump"}},
          {{"stage", "island"}, {"distance", "euclidean2"}},
          {{"stage", "island"}, {"distance", "hyperboloid"}},
          {{"stage", "island"}, {"distance", "trig_product"}},
          {{"stage", "island"}, {"distance", "squircle"}},
          {{"stage", "island"}, {"distance", "circular"}, {"shaping", "subtract"}},
          {{"stage", "curve"}, {"points", json::array({json::array({0, 0}), json::array({0.4, 0.2}), json::array({0.7, 0.8}), json::array({1, 1})})}},
          {{"stage", "curve"},
           {"points", json::array({json::array({0, 0}), json::array({0.1, 0.3}), json::array({0.3, 0.35}), json::array({0.5, 0.7}),
                                   json::array({0.6, 0.6}), json::array({0.75, 0.9}), json::array({1, 1})})}},
          {{"stage", "color"}, {"mode", "bands"}},
          {{"stage", "color"}, {"mode", "gradient"}},
          {{"stage", "hillshade"}},
      };
      for (const json& c : cases) {
        const std::string stage = c["stage"].get<std::string>();
        const bool colour = stage == "color", shade = stage == "hillshade";
        const Sample& fl = shade ? copy4 : colour ? copy3 : copy1;
        auto st = find_stage(stage)->parse(c, "bench");
        Terrain t = stage == "hillshade" ? coloured : base;
        Context ctx;
        ctx.seed = 1;
        Sample ts = time_runs(
            s.runs, [&] { arena.execute([&] { st->apply(t, ctx); }); },
            [&] { std::copy(original.begin(), original.end(), t.get("height").data.begin()); });
        std::string name = stage;
        for (auto it = c.begin(); it != c.end(); ++it)
          if (it.key() == "points") name.append(" ").append(std::to_string(it.value().size())).append(" points");
          else if (it.key() != "stage") name += " " + (it.value().is_string() ? it.value().get<std::string>() : it.key());
        const double floor = fl.median;
        json e = timing_entry(name, n, n, threads, ts);
        e["vs_copy"] = ts.median / floor;
        e["vs_copy_min"] = ts.min / fl.min;
        e["copy_channels"] = shade ? json("1+3") : json(colour ? 3 : 1);
        e["vs_copy_cpu"] = ts.cpu_median / fl.cpu_median;
        std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f   %.2fx copy (min %.2fx), cpu %.2f ms = %.2fx copy%s\n",
                    name.c_str(), (std::to_string(n) + "²").c_str(), threads, ts.median, ts.min, ts.max,
                    e["msamples_per_s"].get<double>(), e["vs_copy"].get<double>(), e["vs_copy_min"].get<double>(), ts.cpu_median,
                    e["vs_copy_cpu"].get<double>(), shade ? " (1+3 channels)" : colour ? " (3 channels)" : "");
        std::fflush(stdout);
        entries.push_back(e);
      }
    }
  }

  if (want("regenerate")) {
    // What the studio does on a slider move: run() the island preset at 513², in memory, no
    // writers, handing the previous result back for its buffers (RunOptions::recycle). Target
    // ≤ 15 ms. Also without recycling (fresh allocations) and without fusion, for comparison. The
    // per-stage medians show where the time goes (a fused chain's time sits on its first stage).
    json doc = load_preset("island");
    doc["world"]["size"] = 513;
    doc["seed"] = 1;
    const Recipe r = parse_recipe(doc);
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
        json e = timing_entry(name, 256, 256, threads, t);  // msamples_per_s: tiles per µs
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

  if (want("erosion")) {
    // Terrains: the island preset's fBm relief at the sizes, with the sea lowered so that
    // almost every droplet starts on land.
    auto terrain = [](int size) {
      json doc = load_preset("island");
      doc["world"]["size"] = size;
      doc["world"]["sea_level"] = 0.05;
      doc["seed"] = 1;
      doc["stages"] = json::array({doc["stages"][0], doc["stages"][1]});
      RunOptions o;
      return run(parse_recipe(doc), o).terrain;
    };
    auto record = [&](const std::string& name, int size, int threads, const Sample& t, json extra) {
      json e = timing_entry(name, size, size, threads, t);
      for (auto it = extra.begin(); it != extra.end(); ++it) e[it.key()] = it.value();
      e["peak_memory_bytes"] = peak_rss();
      print_row(e);
      entries.push_back(e);
    };
    const int n = s.erosion_size;
    const Terrain base = terrain(n);
    const Frame& f = base.frame;
    const std::vector<float>& h0 = base.get("height").data;
    std::vector<float> h(h0.size()), next(h0.size());
    for (int threads : s.threads) {
      tbb::task_arena arena(threads);
      // 1M droplets, brush radius 3 samples, lifetime 30 steps of one sample.
      erosion::HydraulicSettings hs;
      hs.brush_radius_m = 3 * f.cell_m();
      hs.step_m = f.cell_m();
      hs.lifetime = 30;
      const double area_km2 = double(n - 1) * double(n - 1) * f.cell_m() * f.cell_m() * 1e-6;
      std::size_t land = 0;
      for (float v : h0) land += v >= f.sea_level;
      hs.droplets_per_km2 = 1e6 / area_km2 * double(h0.size()) / double(std::max<std::size_t>(land, 1));
      erosion::HydraulicStats hst;
      Sample t = time_runs(s.runs, [&] {
        h = h0;
        arena.execute([&] { hst = erosion::hydraulic_erosion(h.data(), f, hs, 1); });
      });
      record("hydraulic 1M droplets r3 l30", n, threads, t, {{"droplets", hst.droplets}});
      // Thermal: 20 iterations per run, reported per iteration.
      constexpr int kIter = 20;
      t = time_runs(s.runs, [&] {
        h = h0;
        arena.execute([&] {
          for (int it = 0; it < kIter; ++it) {
            erosion::thermal_iteration(h.data(), next.data(), f, 30.0, 0.5);
            h.swap(next);
          }
        });
      });
      t.median /= kIter, t.min /= kIter, t.max /= kIter, t.cpu_median /= kIter;
      record("thermal, per iteration", n, threads, t, json::object());
      // Stream power, 100 steps.
      erosion::StreamPowerSettings sp;
      sp.steps = 100;
      sp.duration_years = 1e6;
      sp.k = 1e-5;
      sp.uplift_mm_per_year = 2.0;
      t = time_runs(std::max(3, s.runs / 2 + 1), [&] {
        h = h0;
        arena.execute([&] { erosion::stream_power(h.data(), f, sp); });
      });
      record("stream power 100 steps", n, threads, t, json::object());
    }
    // Priority-Flood+ε, D8 and accumulation at the flood size.
    const int m = s.flood_size;
    const Terrain big = terrain(m);
    const std::vector<float>& b0 = big.get("height").data;
    std::vector<float> b(b0.size());
    std::vector<std::uint32_t> rec(b0.size()), order, count(b0.size());
    for (int threads : s.threads) {
      tbb::task_arena arena(threads);
      const float sea = float(big.frame.sea_level);
      // Each part's time too (medians over the same runs): where the time goes.
      std::vector<double> part_ms[3];
      Sample t = time_runs(std::max(3, s.runs / 2 + 1), [&] {
        b = b0;
        arena.execute([&] {
          auto t0 = std::chrono::steady_clock::now();
          auto lap = [&](int k) {
            const auto t1 = std::chrono::steady_clock::now();
            part_ms[k].push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
            t0 = t1;
          };
          hydro::fill_depressions<float>(b.data(), m, m, sea, 0.0f);
          lap(0);
          hydro::d8_receivers<float>(b.data(), m, m, sea, rec.data());
          lap(1);
          hydro::flow_order(rec.data(), b.size(), order, count.data());
          lap(2);
        });
      });
      double part[3];
      for (int k = 0; k < 3; ++k)  // time_runs' first call is its untimed warm-up
        part[k] = median_of(std::vector<double>(part_ms[k].begin() + 1, part_ms[k].end()));
      record("fill + d8 + accumulation", m, threads, t,
             {{"fill_median_ms", part[0]}, {"d8_median_ms", part[1]}, {"accumulation_median_ms", part[2]}});
      std::printf("    parts (median ms): fill %.1f, d8 %.1f, accumulation %.1f\n", part[0], part[1], part[2]);
    }
  }
  if (want("islands")) {
    // The island systems: volcanic-island at 1025² (whole pipeline and every writer that applies,
    // OBJ included), with the median time of each stage.
    json doc = load_preset("volcanic-island");
    doc["world"]["size"] = 1025;
    doc["seed"] = 1;
    const Recipe r = parse_recipe(doc);
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
        auto v = stage_ms[k];
        std::sort(v.begin(), v.end());
        const double med = v.empty() ? 0.0 : v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
        stages.push_back({{"stage", r.stages[k].def->name}, {"median_ms", med}});
        char buf[64];
        std::snprintf(buf, sizeof buf, "%s%s %.0f", line.empty() ? "" : ", ", r.stages[k].def->name.c_str(), med);
        line += buf;
      }
      e["stages"] = stages;
      e["peak_memory_bytes"] = peak_rss();
      print_row(e);
      std::printf("    stages (median ms, generation only): %s\n", line.c_str());
      entries.push_back(e);
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
          {"glb lowpoly 2 m", "glb", [](ExportOptions& e) { e.simplify_error_m = 2.0, e.style = MeshStyle::Lowpoly; }},
          {"glb gpu instancing", "glb", [](ExportOptions& e) { e.instancing = Instancing::Gpu; }},
          {"fbx", "fbx", nullptr},
          {"stl", "stl", nullptr},
          {"obj", "obj", nullptr},
          {"albedo png", "albedo", nullptr},
          {"heightmap", "heightmap", nullptr},
          {"normalmap 8-bit", "normalmap", nullptr},
          {"normalmap 16-bit", "normalmap", [](ExportOptions& e) { e.normal_bits = 16; }},
          {"splat", "splat", nullptr},
          {"hillshade", "hillshade", nullptr},
          {"engine unity raw", "engine", [](ExportOptions& e) { e.engine = Engine::Unity; }},
          {"engine godot exr", "engine", [](ExportOptions& e) { e.engine = Engine::Godot; }},
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
        json e = timing_entry("export " + c.name, size, size, threads, tm);
        e["bytes"] = bytes;
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
    doc["cpu"] = cpu;
    doc["simd_target"] = simd;
    doc["entries"] = entries;
    doc["peak_memory_bytes"] = peak_rss();
    write_file_atomic(s.json_path, doc.dump(2) + "\n");
    std::printf("wrote %s\n", s.json_path.c_str());
  }
  return 0;
}

}  // namespace relief::cli
