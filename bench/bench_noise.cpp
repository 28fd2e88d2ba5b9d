// Micro-benchmarks of Noise::row (one 4096-sample row per iteration) and Noise::rows ("rows16": a
// block of 16 such rows per iteration), for every basis, single
// octave and 6-octave fBm / ridged, on every Highway target this CPU supports (forced one at a
// time) and on the scalar reference. Throughput is reported as samples per second.
//
//   relief_bench_micro --benchmark_filter='gradient' --benchmark_repetitions=5
//       --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "noise_simd.hpp"
#include "relief/noise.hpp"

namespace {

using relief::Fractal;
using relief::Noise;
using relief::NoiseBasis;
using relief::NoiseSettings;

constexpr int kRow = 4096;

struct Case {
  const char* name;
  NoiseBasis basis;
  Fractal fractal;
  int octaves;
  relief::CellularReturn cellular = relief::CellularReturn::F1;
};

const Case kCases[] = {
    {"gradient", NoiseBasis::Gradient, Fractal::None, 1},
    {"gradient fbm 6", NoiseBasis::Gradient, Fractal::Fbm, 6},
    {"gradient ridged 6", NoiseBasis::Gradient, Fractal::Ridged, 6},
    {"perlin", NoiseBasis::Perlin, Fractal::None, 1},
    {"perlin fbm 6", NoiseBasis::Perlin, Fractal::Fbm, 6},
    {"simplex", NoiseBasis::Simplex, Fractal::None, 1},
    {"value", NoiseBasis::Value, Fractal::None, 1},
    {"cellular", NoiseBasis::Cellular, Fractal::None, 1},
    {"cellular f2-f1", NoiseBasis::Cellular, Fractal::None, 1, relief::CellularReturn::F2MinusF1},
};

NoiseSettings settings_of(const Case& c) {
  NoiseSettings s;
  s.basis = c.basis;
  s.fractal = c.fractal;
  s.octaves = c.octaves;
  s.cellular = c.cellular;
  s.frequency = 1.0 / 64.0;
  s.seed = 1;
  return s;
}

// target 0: automatic dispatch; −1: the scalar reference; else a forced Highway target.
void run_row(benchmark::State& state, Case c, std::int64_t target) {
  const Noise noise(settings_of(c));
  std::vector<float> out(kRow);
  relief::detail::noise_simd_force_target(target > 0 ? target : 0);
  int j = 0;
  for (auto _ : state) {
    const double z = double(j++ & 1023);
    if (target < 0)
      noise.row_reference(z, 0, 1.0, kRow, out.data());
    else
      noise.row(z, 0, 1.0, kRow, out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  relief::detail::noise_simd_force_target(0);
  state.SetItemsProcessed(state.iterations() * kRow);
}

// The block API: 16 rows per iteration through Noise::rows (x-only terms reused across the block);
// items are samples, comparable with run_row's.
void run_rows(benchmark::State& state, Case c, std::int64_t target) {
  const Noise noise(settings_of(c));
  constexpr int kBlock = 16;
  std::vector<float> out(std::size_t(kRow) * kBlock);
  relief::detail::noise_simd_force_target(target > 0 ? target : 0);
  int j = 0;
  double z[kBlock];
  for (auto _ : state) {
    for (int r = 0; r < kBlock; ++r) z[r] = double((j + r) & 1023);
    j += kBlock;
    noise.rows(z, kBlock, 0, 1.0, kRow, out.data(), kRow);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  relief::detail::noise_simd_force_target(0);
  state.SetItemsProcessed(state.iterations() * kRow * kBlock);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<relief::detail::SimdTarget> targets = relief::detail::noise_simd_targets();
  for (const Case& c : kCases) {
    for (const auto& t : targets)
      benchmark::RegisterBenchmark((std::string(c.name) + "/" + t.name).c_str(), run_row, c, t.bits);
    for (const auto& t : targets)
      benchmark::RegisterBenchmark((std::string(c.name) + " rows16/" + t.name).c_str(), run_rows, c, t.bits);
    benchmark::RegisterBenchmark((std::string(c.name) + "/scalar-reference").c_str(), run_row, c, std::int64_t(-1));
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
