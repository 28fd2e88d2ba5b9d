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

std::uint64_t estimate_memory_bytes(const Recipe& r, bool with_mesh) {
  const std::uint64_t n = std::uint64_t(r.world.nx) * std::uint64_t(r.world.nz);
  // Layers the run leaves (each name once, whatever wrote it), float per channel.
  std::map<std::string, int> layers = {{"height", 1}};
  std::uint64_t scratch = 0, stage_encode = 0;
  // What each stage leaves and holds: StageDef::memory, declared with the stage.
  for (const RecipeStage& st : r.stages) {
    const StageMemory& m = st.def->memory;
    for (auto& [name, channels] : m.layers) layers[name] = std::max(layers[name], channels);
    const json p = st.stage->params();
    // A stage with a `mask` (stage_masked.cpp) also keeps a copy of the layer it changes.
    const bool masked = p.contains("mask") && p["mask"].is_string() && !p["mask"].get<std::string>().empty();
    scratch = std::max(scratch, (m.scratch_per_sample + (masked ? 4 : 0)) * n);
    if (m.layer_param.empty() && !m.encode_bytes) continue;
    if (!m.layer_param.empty() && p.contains(m.layer_param) && p[m.layer_param].is_string())
      layers[p[m.layer_param].get<std::string>()] = std::max(layers[p[m.layer_param].get<std::string>()], 1);
    if (m.encode_bytes) stage_encode = std::max(stage_encode, m.encode_bytes(p));
  }
  std::uint64_t channels = 0;
  for (auto& [name, c] : layers) channels += std::uint64_t(c);
  const std::uint64_t kept = n * 4 * channels;
  // Encoding (writers run concurrently, each file written as it is encoded): heightmap (16-bit
  // pixels, PNG, r16), colour and albedo PNGs (RGB pixels and PNG each). The OBJ streams its text
  // through a small pool of ~256 KiB blocks, so it adds a fixed few MiB, not a per-sample term.
  const std::uint64_t encode = n * ((2 + 2 + 2) + 2 * (3 + 3)) + (with_mesh ? 8ull << 20 : 0) + stage_encode;
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

namespace {

// The frame a run computes on: the whole world, or a window grown by the halo of the recipe's
// stages (refusing global stages), never beyond the world's edge. `world_nx/nz` are the world's
// sample counts on the frame's grid.
Frame work_frame(const Recipe& r, const Frame& frame) {
  const std::int64_t world_nx = std::llround(frame.world_width_m / frame.spacing_m) + 1;
  const std::int64_t world_nz = std::llround(frame.world_depth_m / frame.spacing_m) + 1;
  if (frame.ix0 == 0 && frame.iz0 == 0 && frame.nx == world_nx && frame.nz == world_nz) return frame;
  std::int64_t halo = 0;
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    const RecipeStage& s = r.stages[i];
    const Reach re = s.stage->reach(frame);
    if (re.locality == Locality::Global)
      throw Error("stages[" + std::to_string(i) + "]",
                  "'" + s.def->name + "' needs the whole map (" + (re.why.empty() ? "a global stage" : re.why) +
                      "), so it cannot run on a window of the world; run the whole world instead");
    if (re.locality == Locality::Neighbourhood) halo += std::max(0, re.halo);
  }
  if (halo == 0) return frame;
  // One side grows by the halo while it lies inside the world, and stops at the world's edge,
  // where the whole map's neighbourhood stages read clamped samples too.
  auto grow = [halo](std::int64_t lo, int n, std::int64_t world_n, std::int64_t& out_lo, int& out_n) {
    std::int64_t a = lo, b = lo + n - 1;
    if (a > 0) a = std::max<std::int64_t>(0, a - halo);
    if (b < world_n - 1) b = std::min<std::int64_t>(world_n - 1, b + halo);
    out_lo = a;
    out_n = int(b - a + 1);
  };
  Frame work = frame;
  grow(frame.ix0, frame.nx, world_nx, work.ix0, work.nx);
  grow(frame.iz0, frame.nz, world_nz, work.iz0, work.nz);
  return work;
}

// Crops every layer of `t` (on its frame) to `window`, a sub-rectangle of it, and drops the
// points outside the window.
void crop(Terrain& t, const Frame& window) {
  const Frame& f = t.frame;
  const std::size_t di = std::size_t(window.ix0 - f.ix0), dj = std::size_t(window.iz0 - f.iz0);
  for (auto& entry : t.layers) {
    Layer& l = entry.second;  // (not a structured binding: clang 14 cannot capture one in the lambda)
    const std::size_t c = std::size_t(l.channels), row = std::size_t(window.nx) * c;
    // The grown layer's buffer goes back to the process-wide buffer cache: the next tile of a world
    // takes it. (The cropped one is allocated: a cache holding both would keep two tiles' layers.)
    std::vector<float> out(window.count() * c);
    detail::parallel_rows(window.nz, [&](int j) {
      const float* src = l.data.data() + ((dj + std::size_t(j)) * std::size_t(f.nx) + di) * c;
      std::copy(src, src + row, out.data() + std::size_t(j) * row);
    });
    detail::cache_buffer(std::move(l.data));
    l.data = std::move(out);
  }
  const double x0 = window.x0_m(), x1 = window.x_m(window.nx - 1), z0 = window.z0_m(), z1 = window.z_m(window.nz - 1);
  std::erase_if(t.points, [&](const Point& p) { return p.x_m < x0 || p.x_m > x1 || p.z_m < z0 || p.z_m > z1; });
  t.frame = window;
}

}  // namespace

int capped_threads(int requested) {
  return requested <= 0 ? requested : std::min(requested, std::max(1, tbb::info::default_concurrency()));
}

RunResult run(const Recipe& r, const RunOptions& opt) {
  RunResult res;
  res.seed = r.seed ? *r.seed : random_seed();
  const Frame window = opt.window ? *opt.window : r.world.frame();
  if (window.nx < 2 || window.nz < 2)
    throw Error("world.size", "expected at least 2 samples per axis, got " + std::to_string(window.nx) + "x" +
                                  std::to_string(window.nz));
  const Frame frame = work_frame(r, window);
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
  const bool fuse = opt.fuse && (!opt.after_stage || opt.after_stage_keeps_fusion);
  auto context = [&](std::size_t i) {
    Context ctx;
    ctx.seed = res.seed;
    ctx.stage_index = int(i);
    // A stage reports the fraction of its own work; the run's listener gets the run's fraction
    // (each stage one equal share), never going backwards.
    // Where a long stage reports progress, the run also checks for cancellation, so that one
    // erosion or flow stage does not outlast a cancel by its whole duration.
    if (opt.progress || opt.cancelled)
      ctx.progress = [&opt, i, n = double(r.stages.size())](std::string_view name, double f) {
        if (opt.cancelled && opt.cancelled()) throw Cancelled();
        if (opt.progress) opt.progress(name, (double(i) + std::clamp(f, 0.0, 1.0)) / n);
      };
    return ctx;
  };
  // Stage errors about layers name the stage that failed.
  auto named = [](std::size_t i, auto&& f) {
    try {
      f();
    } catch (const Error& e) {
      if (e.path().empty()) throw Error("stages[" + std::to_string(i) + "]", e.message());
      throw;
    }
  };
  using clock = std::chrono::steady_clock;
  auto ms_since = [](clock::time_point t0) { return std::chrono::duration<double, std::milli>(clock::now() - t0).count(); };
  arena.execute([&] {
    for (std::size_t i = first; i < r.stages.size();) {
      if (opt.cancelled && opt.cancelled()) throw Cancelled();
      // A chain of consecutive fusable stages [i, end): one pass over the rows.
      // A lone fusable stage takes the row pass too (the same bits), so that it can be cancelled
      // between row blocks like a chain.
      std::size_t end = i + 1;
      const bool rows = r.stages[i].stage->fusable();
      if (rows && fuse)
        while (end < r.stages.size() && r.stages[end].stage->fusable()) ++end;
      if (!rows) {
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
      // In blocks of rows with a cancellation check between them (at most 16 checks a pass; rows
      // are independent, so the blocking changes no bit).
      const int block = std::max(32, (f.nz + 15) / 16);
      for (int j0 = 0; j0 < f.nz; j0 += block) {
        if (j0 > 0 && opt.cancelled && opt.cancelled()) throw Cancelled();
        const int rows_here = std::min(block, f.nz - j0);
        detail::parallel_rows(rows_here, [&](int jj) {
          const int j = j0 + jj;
          const std::size_t offset = std::size_t(j) * std::size_t(f.nx);
          for (std::size_t k = 0; k < kernels.size(); ++k) kernels[k]->apply_row(j, data[k] + offset);
        });
      }
      const double chain_ms = ms_since(t0);
      for (std::size_t k = i; k < end; ++k) {
        const RecipeStage& s = r.stages[k];
        res.timings.push_back({s.def->name, s.label, k == i ? chain_ms : 0.0, k > i});
      }
      if (opt.after_stage) opt.after_stage(res.terrain, r.stages[end - 1], int(end - 1));
      i = end;
    }
  });
  if (!same_frame(res.terrain.frame, window)) crop(res.terrain, window);
  for (auto& b : res.terrain.spare) detail::cache_buffer(std::move(b));  // unused spare buffers: to the
  res.terrain.spare.clear();                                                 // process-wide cache or freed
  res.terrain.spare.shrink_to_fit();
  if (opt.progress) opt.progress("done", 1.0);
  res.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_all).count();
  return res;
}

}  // namespace relief
