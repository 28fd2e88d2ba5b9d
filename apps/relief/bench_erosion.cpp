// Erosion: the hydraulic, thermal and stream-power kernels, and Priority-Flood + D8 + accumulation.
#include "bench_common.hpp"
#include "relief/erosion.hpp"
#include "relief/hydrology.hpp"

namespace relief::cli {

void bench_erosion(const BenchSettings& s, json& entries) {
  // Terrains: the island preset's fBm relief at the sizes, with the sea lowered so that
  // almost every droplet starts on land.
  auto terrain = [](int size) {
    json doc = preset_doc("island", size);
    doc["world"]["sea_level"] = 0.05;
    doc["stages"] = json::array({doc["stages"][0], doc["stages"][1]});
    RunOptions o;
    return run(parse_recipe(doc), o).terrain;
  };
  auto record = [&](const std::string& name, int size, int threads, const Sample& t, json extra) {
    json e = timing_entry(name, size, size, threads, t);
    for (auto it = extra.begin(); it != extra.end(); ++it) e[it.key()] = it.value();
    e["peak_memory_bytes"] = peak_rss_bytes();
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
  {
    // Priority-Flood+ε alone (sequential, ε = 0), as a ratio to a plain copy of the layer timed in
    // the same run, so that the figure travels between machines: on the island above and on the
    // mountains preset's relief (its noise and redistribute stages, before any fill). The peer is
    // RichDEM's Wei et al. 2018 Priority-Flood (not packaged: measured outside the project on the
    // same inputs, as a ratio to the same copy; issue 17 targets ≤ 1.0× its time).
    json md = preset_doc("mountains", m);
    md["stages"] = json::array({md["stages"][0], md["stages"][1], md["stages"][2]});
    const Terrain mountains = run(parse_recipe(md), RunOptions{}).terrain;
    using Case = std::pair<const char*, const Terrain*>;
    for (const auto& [label, t] : {Case{"island", &big}, Case{"mountains", &mountains}}) {
      const std::vector<float>& src = t->get("height").data;
      const float sea = float(t->frame.sea_level);
      std::vector<float> work(src.size());
      const Sample copy = time_runs(s.runs, [&] { work = src; });
      const Sample fill = time_runs(
          s.runs, [&] { hydro::fill_depressions<float>(work.data(), m, m, sea, 0.0f); }, [&] { work = src; });
      record(std::string("fill, ") + label, m, 1, fill, {{"vs_copy", fill.median / copy.median}, {"copy_median_ms", copy.median}});
      std::printf("    fill on the %s: %.1fx a copy of the layer (copy %.2f ms)\n", label, fill.median / copy.median,
                  copy.median);
    }
  }
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

    // A recipe with `fill` then `flow`: the flow stage checks that the height already drains (one
    // pass, hydrology.hpp already_drains) instead of filling it again. The check's cost as a ratio
    // to a plain copy of the layer, and the flow stage on a filled height against the raw one.
    std::vector<float> filled = b0;
    hydro::fill_depressions<float>(filled.data(), m, m, sea, 0.0f);
    bool drains = false;
    const Sample copy = time_runs(s.runs, [&] { arena.execute([&] { b = filled; }); });
    const Sample check = time_runs(s.runs, [&] {
      arena.execute([&] { drains = hydro::already_drains<float>(filled.data(), m, m, sea); });
    });
    record("already_drains check (filled)", m, threads, check, {{"vs_copy", check.median / copy.median}, {"drains", drains}});
    const StageDef* flow = find_stage("flow");
    auto flow_stage = flow->parse(json{{"stage", "flow"}}, "bench");
    Terrain raw_t = big, filled_t = big;
    filled_t.get("height").data = filled;
    Context ctx;
    Terrain w;
    const Sample on_raw = time_runs(
        std::max(3, s.runs / 2 + 1), [&] { arena.execute([&] { flow_stage->apply(w, ctx); }); }, [&] { w = raw_t; });
    record("flow stage on the raw height", m, threads, on_raw, json::object());
    const Sample on_filled = time_runs(
        std::max(3, s.runs / 2 + 1), [&] { arena.execute([&] { flow_stage->apply(w, ctx); }); }, [&] { w = filled_t; });
    record("flow stage after a fill stage", m, threads, on_filled, {{"vs_raw", on_filled.median / on_raw.median}});
    std::printf("    flow after fill: %.2fx flow on the raw height (the fill is not repeated); check %.2fx a copy\n",
                on_filled.median / on_raw.median, check.median / copy.median);
  }
}

}  // namespace relief::cli
