#include "relief/pipeline.hpp"

#include <tbb/task_arena.h>
#include <unistd.h>

#include <chrono>
#include <random>
#include <thread>

namespace relief {

std::uint64_t physical_memory_bytes() {
  long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? std::uint64_t(pages) * std::uint64_t(size) : 0;
}

std::uint64_t estimate_memory_bytes(const Recipe& r, bool with_mesh) {
  const std::uint64_t n = std::uint64_t(r.world.nx) * std::uint64_t(r.world.nz);
  // Layers: height, slope, slope_deg, shade (1 channel each), albedo and color (3 each), plus one
  // scratch layer per stage; then the encoders' buffers (16-bit + two RGB images, raw).
  std::uint64_t layers = 4 * (1 + 1 + 1 + 1 + 3 + 3 + r.stages.size());
  std::uint64_t encode = 2 + 2 + 3 + 3;
  std::uint64_t bytes = n * (layers + encode);
  // OBJ text: a vertex line (~30 B), normal (~25 B), uv (~16 B) and two faces (~2×40 B).
  if (with_mesh) bytes += n * 160;
  return bytes;
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
  const Frame& f = res.terrain.frame;
  if (f.nx < 2 || f.nz < 2) throw Error("world.size", "expected at least 2 samples per axis, got " +
                                                          std::to_string(f.nx) + "x" + std::to_string(f.nz));
  int threads = opt.threads > 0 ? opt.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  tbb::task_arena arena(threads);
  const auto t_all = std::chrono::steady_clock::now();
  arena.execute([&] {
    for (std::size_t i = first; i < r.stages.size(); ++i) {
      if (opt.cancelled && opt.cancelled()) throw Cancelled();
      const RecipeStage& s = r.stages[i];
      Context ctx;
      ctx.seed = res.seed;
      ctx.stage_index = int(i);
      ctx.progress = opt.progress;
      if (opt.progress) opt.progress(s.def->name, double(i) / double(r.stages.size()));
      const auto t0 = std::chrono::steady_clock::now();
      try {
        s.stage->apply(res.terrain, ctx);
      } catch (const Error& e) {
        // Stage errors about layers name the stage that failed.
        if (e.path().empty())
          throw Error("stages[" + std::to_string(i) + "]", std::string(e.what()));
        throw;
      }
      const auto t1 = std::chrono::steady_clock::now();
      res.timings.push_back({s.def->name, s.label, std::chrono::duration<double, std::milli>(t1 - t0).count()});
      if (opt.after_stage) opt.after_stage(res.terrain, s, int(i));
    }
  });
  if (opt.progress) opt.progress("done", 1.0);
  res.total_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_all).count();
  return res;
}

}  // namespace relief
