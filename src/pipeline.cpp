#include "relief/pipeline.hpp"

#include <tbb/info.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <random>
#include <thread>

#include "parallel.hpp"
#include "relief/stage.hpp"

namespace relief {

std::uint64_t physical_memory_bytes() {
  long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? std::uint64_t(pages) * std::uint64_t(size) : 0;
}

namespace {

// What each stage leaves in the terrain (layer name → channels) and the most scratch memory it
// holds while it runs (bytes per sample), for estimate_memory_bytes. Kept next to the estimate;
// tests/test_cli.cpp (CliMemory) holds the estimate to the measured peak for the presets, so a
// stage that starts keeping more than listed here shows up there.
struct StageFootprint {
  std::vector<std::pair<const char*, int>> layers;
  std::uint64_t scratch = 0;  // bytes per sample, released when the stage ends
};
const StageFootprint& footprint(const std::string& stage) {
  static const std::map<std::string, StageFootprint> table = {
      {"noise", {{}, 0}},  // writes its `layer` parameter (see below)
      {"jiggle", {{{"offset", 2}}, 0}},
      {"slope", {{{"slope", 1}, {"slope_deg", 1}}, 0}},
      {"color", {{{"albedo", 3}}, 8}},
      {"hillshade", {{{"shade", 1}, {"color", 3}}, 0}},
      // h and uplift (double), receivers, stack and donor counts (u32), Priority-Flood's queue
      {"stream_power", {{}, 16 + 12 + 16}},
      {"hydraulic", {{}, 12}},
      {"thermal", {{}, 8}},
      {"fill", {{}, 16}},
      // receivers, order, donor counts, lake ids (u32), visit and channel flags, the flood queue
      {"flow", {{{"flow", 1}, {"water", 1}}, 16 + 2 + 5 + 16}},
      {"biomes", {{{"albedo", 3}, {"biome", 1}}, 12}},
      {"climate", {{{"temperature", 1}, {"moisture", 1}, {"biome", 1}, {"albedo", 3}}, 8}},
      {"volcano", {{{"volcano", 1}}, 4}},
  };
  static const StageFootprint none;
  auto it = table.find(stage);
  return it == table.end() ? none : it->second;
}

}  // namespace

std::uint64_t estimate_memory_bytes(const Recipe& r, bool with_mesh) {
  const std::uint64_t n = std::uint64_t(r.world.nx) * std::uint64_t(r.world.nz);
  // Layers the run leaves (each name once, whatever wrote it), float per channel.
  std::map<std::string, int> layers = {{"height", 1}};
  std::uint64_t scratch = 0, tilemap_render = 0;
  for (const RecipeStage& st : r.stages) {
    const StageFootprint& f = footprint(st.def->name);
    for (auto& [name, channels] : f.layers) layers[name] = std::max(layers[name], channels);
    scratch = std::max(scratch, f.scratch * n);
    const json p = st.stage->params();
    if (st.def->name == "noise" && p.contains("layer") && p["layer"].is_string()) layers[p["layer"].get<std::string>()] =
        std::max(layers[p["layer"].get<std::string>()], 1);
    if (st.def->name == "tilemap" && p.contains("tiles_x") && p.contains("tiles_z") && p.contains("tile_size")) {
      // The tilemap writer's map: tiles × tile_size² RGB pixels, plus its PNG while encoding.
      const std::uint64_t px = p["tiles_x"].get<std::uint64_t>() * p["tiles_z"].get<std::uint64_t>() *
                               p["tile_size"].get<std::uint64_t>() * p["tile_size"].get<std::uint64_t>();
      tilemap_render = px * 3 + px * 3 / 2;
    }
  }
  std::uint64_t channels = 0;
  for (auto& [name, c] : layers) channels += std::uint64_t(c);
  const std::uint64_t kept = n * 4 * channels;
  // Encoding (writers run concurrently, each file written as it is encoded): heightmap (16-bit
  // pixels, PNG, r16), colour and albedo PNGs (RGB pixels and PNG each). The OBJ streams its text
  // through a small pool of ~256 KiB blocks, so it adds a fixed few MiB, not a per-sample term.
  const std::uint64_t encode = n * ((2 + 2 + 2) + 2 * (3 + 3)) + (with_mesh ? 8ull << 20 : 0) + tilemap_render;
  // The program itself: code, thread stacks, allocator arenas (a 17² run peaks at ~10 MiB).
  const std::uint64_t base = 12ull << 20;
  return base + kept + std::max(scratch, encode);
}

std::uint64_t random_seed() {
  std::random_device rd;
  std::uint64_t s = (std::uint64_t(rd()) << 32) ^ std::uint64_t(rd());
  return s & kMaxSeed;
}

namespace {
bool same_frame(const Frame& a, const Frame& b) {
  return a.world_width_m == b.world_width_m && a.world_depth_m == b.world_depth_m && a.spacing_m == b.spacing_m &&
         a.nx == b.nx && a.nz == b.nz && a.ix0 == b.ix0 && a.iz0 == b.iz0 && a.height_m == b.height_m &&
         a.sea_level == b.sea_level;
}
}  // namespace

int capped_threads(int requested) {
  return requested <= 0 ? requested : std::min(requested, std::max(1, tbb::info::default_concurrency()));
}

RunResult run(const Recipe& r, const RunOptions& opt) {
  RunResult res;
  res.seed = r.seed ? *r.seed : random_seed();
  const Frame frame = opt.window ? *opt.window : r.world.frame();
  std::size_t first = 0;
  if (opt.resume) {
    const Resume& rs = *opt.resume;
    if (!r.seed) throw Error("seed", "resuming a run needs the recipe's seed (the snapshot was made with one)");
    if (!rs.terrain) throw Error("resume", "no snapshot given");
    if (rs.first_stage < 0 || std::size_t(rs.first_stage) > r.stages.size())
      throw Error("resume", "expected a first stage in 0.." + std::to_string(r.stages.size()) + ", got " +
                                std::to_string(rs.first_stage));
    if (!same_frame(rs.terrain->frame, frame)) throw Error("resume", "the snapshot's frame differs from the run's");
    res.terrain = *rs.terrain;
    first = std::size_t(rs.first_stage);
  } else {
    res.terrain.frame = frame;
  }
  if (opt.recycle && opt.recycle != &res.terrain) {
    for (auto& [name, l] : opt.recycle->layers) res.terrain.spare.push_back(std::move(l.data));
    for (auto& b : opt.recycle->spare) res.terrain.spare.push_back(std::move(b));
    opt.recycle->layers.clear();
    opt.recycle->spare.clear();
  }
  const Frame& f = res.terrain.frame;
  if (f.nx < 2 || f.nz < 2) throw Error("world.size", "expected at least 2 samples per axis, got " +
                                                          std::to_string(f.nx) + "x" + std::to_string(f.nz));
  int threads = opt.threads > 0 ? capped_threads(opt.threads) : tbb::info::default_concurrency();
  tbb::task_arena arena(threads);
  const auto t_all = std::chrono::steady_clock::now();
  const bool fuse = opt.fuse && !opt.after_stage;
  auto context = [&](std::size_t i) {
    Context ctx;
    ctx.seed = res.seed;
    ctx.stage_index = int(i);
    // A stage reports the fraction of its own work; the run's listener gets the run's fraction
    // (each stage one equal share), never going backwards.
    if (opt.progress)
      ctx.progress = [&opt, i, n = double(r.stages.size())](std::string_view name, double f) {
        opt.progress(name, (double(i) + std::clamp(f, 0.0, 1.0)) / n);
      };
    return ctx;
  };
  // Stage errors about layers name the stage that failed.
  auto named = [](std::size_t i, auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      if (e.path().empty()) throw Error("stages[" + std::to_string(i) + "]", std::string(e.what()));
      throw;
    }
  };
  using clock = std::chrono::steady_clock;
  auto ms_since = [](clock::time_point t0) { return std::chrono::duration<double, std::milli>(clock::now() - t0).count(); };
  arena.execute([&] {
    for (std::size_t i = first; i < r.stages.size();) {
      if (opt.cancelled && opt.cancelled()) throw Cancelled();
      // A chain of consecutive fusable stages [i, end): one pass over the rows.
      std::size_t end = i + 1;
      if (fuse && r.stages[i].stage->fusable())
        while (end < r.stages.size() && r.stages[end].stage->fusable()) ++end;
      if (end == i + 1) {
        const RecipeStage& s = r.stages[i];
        if (opt.progress) opt.progress(s.def->name, double(i) / double(r.stages.size()));
        const auto t0 = clock::now();
        named(i, [&] { s.stage->apply(res.terrain, context(i)); });
        res.timings.push_back({s.def->name, s.label, ms_since(t0)});
        if (opt.after_stage) opt.after_stage(res.terrain, s, int(i));
        i = end;
        continue;
      }
      const auto t0 = clock::now();
      std::vector<std::unique_ptr<RowKernel>> kernels;
      for (std::size_t k = i; k < end; ++k) {
        const RecipeStage& s = r.stages[k];
        if (k > i && opt.cancelled && opt.cancelled()) throw Cancelled();  // checked once per stage
        if (opt.progress) opt.progress(s.def->name, double(k) / double(r.stages.size()));
        named(k, [&] { kernels.push_back(s.stage->prepare_rows(res.terrain, context(k))); });
      }
      // Layers are looked up once every kernel is prepared (preparing may create layers).
      std::vector<float*> data;
      for (std::size_t k = 0; k < kernels.size(); ++k) {
        Layer* l = nullptr;
        named(i + k, [&] { l = &res.terrain.get(kernels[k]->layer()); });
        if (l->channels != 1 || l->data.size() != f.count())
          throw Error("stages[" + std::to_string(i + k) + "]",
                      "layer '" + kernels[k]->layer() + "' must have one channel and one value per sample");
        data.push_back(l->data.data());
      }
      detail::parallel_rows(f.nz, [&](int j) {
        const std::size_t offset = std::size_t(j) * std::size_t(f.nx);
        for (std::size_t k = 0; k < kernels.size(); ++k) kernels[k]->apply_row(j, data[k] + offset);
      });
      const double chain_ms = ms_since(t0);
      for (std::size_t k = i; k < end; ++k) {
        const RecipeStage& s = r.stages[k];
        res.timings.push_back({s.def->name, s.label, k == i ? chain_ms : 0.0, k > i});
      }
      i = end;
    }
  });
  res.terrain.spare.clear();  // unused spare buffers go back to the allocator
  res.terrain.spare.shrink_to_fit();
  if (opt.progress) opt.progress("done", 1.0);
  res.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_all).count();
  return res;
}

}  // namespace relief
