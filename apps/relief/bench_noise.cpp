// Noise: our bases and fractals through Noise::rows against libnoise's modules, per sample.
#include <libnoise/noise.h>

#include <memory>

#include "bench_common.hpp"
#include "relief/noise.hpp"

namespace relief::cli {

namespace {

struct NoiseCase {
  std::string name;
  NoiseBasis basis;
  Fractal fractal;
  int octaves;
  const char* peer;  // libnoise module or nullptr
};

}  // namespace

void bench_noise(const BenchSettings& s, json& entries) {
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
          // Blocks of 16 rows: Noise::rows computes the x-only terms once per block and strip.
          parallel_rows((n + 15) / 16, [&](int b) {
            const int j0 = b * 16, m = std::min(16, n - j0);
            double z[16];
            for (int r = 0; r < m; ++r) z[r] = double(j0 + r);
            noise.rows(z, m, 0, 1.0, n, buf.data() + std::size_t(j0) * n, n);
          }, 1);
        });
      });
      json e = timing_entry(c.name, n, n, threads, t);
      e["simd_target"] = noise_simd_target();
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
            parallel_rows(pn, [&](int j) {
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
      e["peak_memory_bytes"] = peak_rss_bytes();
      print_row(e);
      entries.push_back(e);
    }
  }
}

}  // namespace relief::cli
