#pragma once
// Internal to `relief bench` (bench.cpp and the bench_*.cpp case groups): timing runs, the JSON
// entry every case writes, and the row it prints. Only public headers of the library.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "bench.hpp"
#include "relief/generate.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"

namespace relief::cli {

struct Sample {
  double median = 0, min = 0, max = 0;
  // Median process CPU time per run (all threads; with more than one thread it includes oneTBB's
  // workers spinning briefly after the work). On a shared, loaded machine the 1-thread CPU time
  // shows the work itself while wall time also holds the waits for a core.
  double cpu_median = 0;
};

inline double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

inline double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// The fields every JSON entry has: name, grid size, threads, the median, min and max wall time,
// the median CPU time and the throughput (million grid cells per second).
inline json timing_entry(const std::string& name, int nx, int nz, int threads, const Sample& t) {
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

// Calls fn(j) for every row j in [0, rows) on the current task arena, in blocks of `grain` rows
// (the library's own row loops split the same way).
template <class F>
void parallel_rows(int rows, F&& fn, int grain = 4) {
  tbb::parallel_for(tbb::blocked_range<int>(0, rows, grain), [&](const tbb::blocked_range<int>& r) {
    for (int j = r.begin(); j < r.end(); ++j) fn(j);
  });
}

// The named preset at size² samples, seed 1: the document every case group starts from.
inline json preset_doc(const std::string& name, int size) {
  json doc = load_preset(name);
  doc["world"]["size"] = size;
  doc["seed"] = 1;
  return doc;
}

// Prints one entry as a row of the table (bench.cpp).
void print_row(const json& e);

// The case groups, one file each (bench_GROUP.cpp): each appends its entries to `entries` and
// prints its rows as it goes.
void bench_noise(const BenchSettings& s, json& entries);
void bench_stages(const BenchSettings& s, json& entries);
void bench_regenerate(const BenchSettings& s, json& entries);
void bench_presets(const BenchSettings& s, json& entries);
void bench_tilemap(const BenchSettings& s, json& entries);
void bench_erosion(const BenchSettings& s, json& entries);
void bench_islands(const BenchSettings& s, json& entries);
void bench_export(const BenchSettings& s, json& entries);
void bench_dem(const BenchSettings& s, json& entries);  // slope and hillshade against GDAL

}  // namespace relief::cli
