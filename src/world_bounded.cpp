// World algorithms for hydraulic erosion and stream power, bounded against a whole-map build, and
// the seam metrics that measure them (relief/world_bounded.hpp, issue 18).
//
// Sources:
//   H. T. Beyer 2015 (droplets; src/erosion_hydraulic.cpp), Braun & Willett 2013 (stream power;
//   src/stream_power.cpp) for the stages themselves. The coarse global pass for stream power follows
//   the usual multi-resolution practice of landscape-evolution models (Cordonnier et al. 2016 run
//   their uplift/erosion on a coarse grid and amplify it); here the coarse change is interpolated
//   onto the fine input.
#include "relief/world_bounded.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>

#include "relief/erosion.hpp"
#include "relief/error.hpp"
#include "relief/hydrology.hpp"
#include "relief/stage.hpp"
#include "stream_power_detail.hpp"
#include "world_farm.hpp"

namespace relief {
namespace {

void check_cancelled(const WorldStageIO& io) {
  if (io.cancelled && io.cancelled()) throw Cancelled();
}

}  // namespace

WorldStageAlgorithm world_hydraulic() {
  return [](const WorldStageIO& io, const RecipeStage& st, int index) { world_hydraulic(io.seed)(io, st, index); };
}

namespace {

// The stage's resolved params (Stage::params(): every field of erosion::HydraulicSettings under its
// own name, see stage_erosion.cpp's table).
erosion::HydraulicSettings hydraulic_settings(const json& p) {
  erosion::HydraulicSettings s;
  s.droplets_per_km2 = p.at("droplets_per_km2").get<double>();
  s.lifetime = p.at("lifetime").get<int>();
  s.step_m = p.at("step_m").get<double>();
  s.brush_radius_m = p.at("brush_radius_m").get<double>();
  s.inertia = p.at("inertia").get<double>();
  s.capacity = p.at("capacity").get<double>();
  s.min_capacity = p.at("min_capacity").get<double>();
  s.erode = p.at("erode").get<double>();
  s.deposit = p.at("deposit").get<double>();
  s.evaporate = p.at("evaporate").get<double>();
  s.gravity = p.at("gravity").get<double>();
  return s;
}

// A temporary file of `dir` (WorldStageIO::scratch_dir; when empty the temporary folder, std::
// filesystem::temp_directory_path(): $TMPDIR, else /tmp) that has no name (O_TMPFILE; where the file
// system cannot, one made with mkstemp and unlinked at once), so that it disappears when closed or
// when the process ends, killed or not. Read and written at byte offsets; a failure throws
// Error(stage, …) naming the folder, what the file holds and the system's reason.
class TempFile {
 public:
  TempFile(std::string dir, std::string stage, std::string what) : stage_(std::move(stage)), what_(std::move(what)) {
    if (dir.empty()) {
      std::error_code ec;
      const std::filesystem::path t = std::filesystem::temp_directory_path(ec);
      dir = ec ? std::string("/tmp") : t.string();
    }
    dir_ = dir;
#ifdef O_TMPFILE
    fd_ = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
#endif
    if (fd_ < 0) {
      std::string name = (std::filesystem::path(dir) / ("relief-" + stage_ + "-XXXXXX")).string();
      fd_ = ::mkstemp(name.data());
      if (fd_ < 0) fail("create");
      ::unlink(name.c_str());
    }
  }
  ~TempFile() { ::close(fd_); }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  void resize(std::uint64_t bytes) const {
    if (::ftruncate(fd_, off_t(bytes)) != 0) fail("size");
  }
  void io(bool write, std::uint64_t at, void* p, std::size_t bytes) const {
    char* b = static_cast<char*>(p);
    while (bytes > 0) {
      const ssize_t got = write ? ::pwrite(fd_, b, bytes, off_t(at)) : ::pread(fd_, b, bytes, off_t(at));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) {
        if (got == 0) errno = write ? ENOSPC : EIO;  // a short file or a full disk
        fail(write ? "write" : "read");
      }
      b += got, bytes -= std::size_t(got), at += std::uint64_t(got);
    }
  }

 private:
  [[noreturn]] void fail(const std::string& verb) const {
    throw Error(stage_, "could not " + verb + " the temporary file of " + what_ + " in " + dir_ + ": " + std::strerror(errno));
  }
  int fd_ = -1;
  std::string stage_, what_, dir_;
};

// The world's heights between the passes: one float per sample, row-major, in a TempFile.
class Scratch {
 public:
  Scratch(std::string dir, std::int64_t nx, std::int64_t nz, std::string stage = "hydraulic")
      : file_(std::move(dir), std::move(stage), "the world's heights"), nx_(nx) {
    file_.resize(std::uint64_t(nx) * std::uint64_t(nz) * 4);
  }
  // Rows [z0, z0 + nz) × columns [x0, x0 + nx) to or from `data` (nx × nz, row-major).
  void read(std::int64_t x0, std::int64_t z0, int nx, int nz, float* data) const {
    for (int j = 0; j < nz; ++j) io(false, x0, z0 + j, nx, data + std::size_t(j) * std::size_t(nx));
  }
  void write(std::int64_t x0, std::int64_t z0, int nx, int nz, const float* data) const {
    for (int j = 0; j < nz; ++j) io(true, x0, z0 + j, nx, const_cast<float*>(data + std::size_t(j) * std::size_t(nx)));
  }

 private:
  void io(bool write, std::int64_t x0, std::int64_t z, int n, float* p) const {
    file_.io(write, std::uint64_t(z * nx_ + x0) * 4, p, std::size_t(n) * 4);
  }
  TempFile file_;
  std::int64_t nx_ = 0;
};

// One group of one pass as a farm task (src/world_farm.hpp): the input is the job and the group's
// window of heights as the pass found them; the result, the samples the pass changed (a byte per
// window sample, 1: changed, then their new values in row-major order). Groups of a pass change
// disjoint samples, and each reads none that another changes (relief/erosion.hpp), so the result
// does not depend on which of the pass's other groups were merged when its window was read, and
// writing only the changed samples leaves every other group's changes in place.
struct HydraulicJob {
  std::uint64_t stage_seed = 0;
  std::int64_t pass = 0, bx0 = 0, bx1 = 0, bz0 = 0, bz1 = 0, x0 = 0, z0 = 0, wnx = 0, wnz = 0;
};
constexpr std::size_t kHydraulicJobBytes = sizeof(HydraulicJob);

detail::FarmKernel hydraulic_kernel(const Frame& W, const erosion::HydraulicSettings& s) {
  return [W, s](std::int64_t, std::string_view in) {
    if (in.size() < kHydraulicJobBytes) throw std::runtime_error("world transport: a hydraulic task of " + std::to_string(in.size()) + " bytes");
    HydraulicJob j;
    std::memcpy(&j, in.data(), kHydraulicJobBytes);
    const std::size_t n = std::size_t(j.wnx) * std::size_t(j.wnz);
    if (j.wnx < 1 || j.wnz < 1 || j.pass < 0 || j.pass > 15 || in.size() != kHydraulicJobBytes + 4 * n)
      throw std::runtime_error("world transport: a malformed hydraulic task");
    std::vector<float> e(n);
    std::memcpy(e.data(), in.data() + kHydraulicJobBytes, 4 * n);
    erosion::HydraulicPart part;
    part.first_pass = int(j.pass), part.passes = 1;
    part.bx0 = j.bx0, part.bx1 = j.bx1, part.bz0 = j.bz0, part.bz1 = j.bz1;
    erosion::hydraulic_erosion_part(e.data(), W.window(j.x0, j.z0, int(j.wnx), int(j.wnz)), s, j.stage_seed, part);
    std::string out(n, '\0');
    const char* before = in.data() + kHydraulicJobBytes;
    for (std::size_t q = 0; q < n; ++q)
      if (std::memcmp(&e[q], before + 4 * q, 4) != 0) {
        out[q] = 1;
        out.append(reinterpret_cast<const char*>(&e[q]), 4);
      }
    return out;
  };
}

}  // namespace

namespace detail {
FarmKernel hydraulic_farm_kernel(const WorldStageIO& io, const RecipeStage& st) {
  return hydraulic_kernel(io.world, hydraulic_settings(st.stage->params()));
}
}  // namespace detail

std::int64_t world_hydraulic_group_blocks(std::int64_t tile, std::int64_t block) {
  const std::int64_t T = std::max<std::int64_t>(1, tile - 1), B = std::max<std::int64_t>(1, block);
  return std::max((T + B - 1) / B, std::min<std::int64_t>(kHydraulicGroupBlocks, std::max<std::int64_t>(1, 2 * T / B)));
}

std::uint64_t world_hydraulic_memory_bytes(const Frame& world, std::int64_t tile, const json& params, int lanes) {
  const erosion::HydraulicSettings s = hydraulic_settings(params);
  const std::int64_t reach = erosion::hydraulic_reach_cells(s, world.cell_m()), B = 2 * reach;
  const std::int64_t G = world_hydraulic_group_blocks(tile, B);
  const std::uint64_t wx = std::uint64_t(std::min<std::int64_t>(world.nx, G * B + 2 * reach + 2));
  const std::uint64_t wz = std::uint64_t(std::min<std::int64_t>(world.nz, G * B + 2 * reach + 2));
  // Per lane computing a group: its input (the window's floats), the kernel's heights and its result
  // (a byte and at most a float per sample: 13 bytes per sample) and its blocks' droplet starts (two
  // floats each, in the round it runs); per result waiting for its turn to merge (src/world_farm.cpp),
  // at most 5 bytes per sample; and the merge's copy of the window (4 bytes per sample).
  const std::uint64_t n = wx * wz, L = std::uint64_t(std::max(1, lanes));
  const double droplets = s.droplets_per_km2 * world.cell_m() * world.cell_m() * 1e-6 * double(n);
  return L * (13 * n + std::uint64_t(droplets * 8.0)) + L * 5 * n + 4 * n;
}

WorldStageAlgorithm world_hydraulic(std::uint64_t seed, int group_blocks) {
  if (group_blocks < 0)
    throw Error("group_blocks", "expected 0 (automatic) or at least 1 block, got " + std::to_string(group_blocks));
  return [seed, group_blocks](const WorldStageIO& io, const RecipeStage& st, int index) {
    const WorldGrid& g = io.grid;
    const Frame& W = io.world;
    const erosion::HydraulicSettings s = hydraulic_settings(st.stage->params());
    Context ctx;
    ctx.seed = seed;
    ctx.stage_index = index;
    const std::uint64_t stage_seed = ctx.stage_seed(kHydraulicSeedSalt);
    const std::int64_t reach = erosion::hydraulic_reach_cells(s, W.cell_m()), B = 2 * reach;
    // World blocks cover the world's cells [0, n − 1) along each axis.
    const std::int64_t nbx = (g.nx - 2) / B + 1, nbz = (g.nz - 2) / B + 1;
    std::int64_t G = group_blocks > 0 ? group_blocks : world_hydraulic_group_blocks(g.tile, B);
    // A distributed build: groups halved (down to 2 blocks) until each pass has at least 4 per rank,
    // so that every rank gets some (the bytes do not depend on G).
    const int ranks = io.farm ? io.farm->ranks() : 1;
    while (group_blocks == 0 && ranks > 1 && G > 2 && ((nbx + G - 1) / G) * ((nbz + G - 1) / G) < 4 * ranks) G = (G + 1) / 2;
    const std::int64_t ngx = (nbx + G - 1) / G, ngz = (nbz + G - 1) / G;
    // Pass p runs the blocks of colour p % 4 ((bx & 1) + 2·(bz & 1), erosion::hydraulic_erosion_part):
    // a group with no block of that colour (a group of one block, in three passes of four) changes
    // nothing, so it is not run (its window is not read nor sent).
    auto has_colour = [&](std::int64_t q, int colour) {
      const std::int64_t gx = q % ngx, gz = q / ngx;
      const std::int64_t bx0 = gx * G, bx1 = std::min(nbx, (gx + 1) * G), bz0 = gz * G, bz1 = std::min(nbz, (gz + 1) * G);
      const bool x_ok = bx1 - bx0 >= 2 || (bx0 & 1) == (colour & 1);
      const bool z_ok = bz1 - bz0 >= 2 || (bz0 & 1) == (colour >> 1);
      return x_ok && z_ok;
    };
    std::vector<std::int64_t> live[4];
    for (int c = 0; c < 4; ++c)
      for (std::int64_t q = 0; q < ngx * ngz; ++q)
        if (has_colour(q, c)) live[c].push_back(q);
    const double steps = double(g.count()) * 2 + 4.0 * double(live[0].size() + live[1].size() + live[2].size() + live[3].size());
    double done = 0;
    auto step = [&] {
      done += 1;
      if (io.progress) io.progress(std::min(1.0, done / steps));
    };
    Scratch scratch(io.scratch_dir, g.nx, g.nz);
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        const WorldTile in = io.load_layers ? io.load_layers(X, Z, {"height"}) : io.load(X, Z);
        scratch.write(w.ix0, w.iz0, w.nx, w.nz, in.layers.at("height").data.data());
        step();
      }
    // The 16 passes in order; in each, the groups of G × G blocks, each on its blocks' cells grown
    // by the reach (and one sample), clipped to the world: farm tasks (src/world_farm.hpp), run on
    // this rank's threads or on other ranks (a distributed build), merged in group order.
    const detail::FarmOf farm(io.farm);
    const detail::FarmKernel kernel = hydraulic_kernel(W, s);
    for (int pass = 0; pass < 16; ++pass) {
      auto job_of = [&](std::int64_t q) {
        HydraulicJob j;
        j.stage_seed = stage_seed;
        j.pass = pass;
        const std::int64_t gx = q % ngx, gz = q / ngx;
        j.bx0 = gx * G, j.bx1 = std::min(nbx, (gx + 1) * G);
        j.bz0 = gz * G, j.bz1 = std::min(nbz, (gz + 1) * G);
        j.x0 = std::max<std::int64_t>(0, j.bx0 * B - reach);
        j.z0 = std::max<std::int64_t>(0, j.bz0 * B - reach);
        j.wnx = std::min<std::int64_t>(g.nx - 1, j.bx1 * B + reach + 1) - j.x0 + 1;
        j.wnz = std::min<std::int64_t>(g.nz - 1, j.bz1 * B + reach + 1) - j.z0 + 1;
        return j;
      };
      farm->run(
          "hydraulic", live[pass % 4],
          [&](std::int64_t q) {
            check_cancelled(io);
            const HydraulicJob j = job_of(q);
            std::string in(kHydraulicJobBytes + 4 * std::size_t(j.wnx) * std::size_t(j.wnz), '\0');
            std::memcpy(in.data(), &j, kHydraulicJobBytes);
            scratch.read(j.x0, j.z0, int(j.wnx), int(j.wnz), reinterpret_cast<float*>(in.data() + kHydraulicJobBytes));
            return in;
          },
          kernel,
          [&](std::int64_t q, std::string out) {
            const HydraulicJob j = job_of(q);
            const std::size_t n = std::size_t(j.wnx) * std::size_t(j.wnz);
            if (out.size() < n) throw std::runtime_error("world transport: a malformed hydraulic result");
            std::size_t changed = 0;
            for (std::size_t k = 0; k < n; ++k) changed += out[k] != 0;
            if (out.size() != n + 4 * changed) throw std::runtime_error("world transport: a malformed hydraulic result");
            if (changed > 0) {  // the changed samples written over the window as it is now
              std::vector<float> e(n);
              scratch.read(j.x0, j.z0, int(j.wnx), int(j.wnz), e.data());
              const char* v = out.data() + n;
              for (std::size_t k = 0; k < n; ++k)
                if (out[k]) std::memcpy(&e[k], v, 4), v += 4;
              scratch.write(j.x0, j.z0, int(j.wnx), int(j.wnz), e.data());
            }
            step();
          });
    }
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        std::vector<float> h(std::size_t(w.nx) * std::size_t(w.nz));
        scratch.read(w.ix0, w.iz0, w.nx, w.nz, h.data());
        if (io.update) {
          WorldTile changed;
          changed.window = w;
          changed.layers["height"] = Layer{1, std::move(h)};
          io.update(X, Z, std::move(changed));
        } else {
          WorldTile tile = io.load(X, Z);
          tile.layers.at("height").data = std::move(h);
          io.store(X, Z, std::move(tile));
        }
        step();
      }
  };
}

namespace {

// One axis of the refinement's blocks: block k's core [k·B, min((k + 1)·B, n − 1)], its window the
// core grown by the halo (clipped to the world), its weight 1 inside the core away from its ends
// and a smoothstep across ± r of each inner core end, where the neighbour's weight is its complement.
struct BlockAxis {
  std::int64_t n = 0, B = 0, halo = 0, r = 0, count = 0;
  BlockAxis(std::int64_t n_, std::int64_t B_, std::int64_t halo_) : n(n_), B(B_), halo(halo_), r(halo_ / 2) {
    count = std::max<std::int64_t>(1, (n - 1 + B - 1) / B);
  }
  std::int64_t lo(std::int64_t k) const { return std::max<std::int64_t>(0, k * B - halo); }
  std::int64_t hi(std::int64_t k) const { return std::min<std::int64_t>(n - 1, (k + 1) * B + halo); }  // inclusive
  // The share of the upper block at offset u from a core end (u in [−r, r]): 0 → 1.
  double ramp(std::int64_t u) const {
    if (u <= -r) return 0;
    if (u >= r) return 1;
    const double x = double(u + r) / double(2 * r);
    return x * x * (3 - 2 * x);
  }
  // The block whose core holds sample i (a shared core end: the lower block).
  std::int64_t owner(std::int64_t i) const { return i <= 0 ? 0 : std::min(count - 1, (i - 1) / B); }
  double weight(std::int64_t k, std::int64_t i) const {
    const double up = k == 0 ? 1.0 : ramp(i - k * B);
    const double down = k == count - 1 ? 1.0 : 1.0 - ramp(i - (k + 1) * B);
    return up * down;
  }
};

}  // namespace

namespace {
// The coarse grid's step (world samples per coarse cell) for an nx × nz world.
std::int64_t coarse_step(std::int64_t nx, std::int64_t nz, int coarse_max) {
  const std::int64_t cmax = std::max(2, coarse_max) - 1;
  return std::max<std::int64_t>({1, (nx - 1 + cmax - 1) / cmax, (nz - 1 + cmax - 1) / cmax});
}
}  // namespace

namespace {
// The refinement's record figures for blocks of `block` grown by `halo` on an nx × nz world (the
// files' and one block's, by the code above): per block, the window and its ring (4 · window side
// samples), and the targets a block gives its neighbours: the ring samples in its core, at most
// block + 1 on each edge neighbour's ring and 2 · halo + 1 on each diagonal one's (so at most
// 4 · block + 8 · halo + 8 per block; all blocks' sum within 1 % over the count on 1025², 4097²
// and 8193² worlds, blocks 128 to 1024, halos 48 to 192). (Before session 20 every block whose
// blend weight reached a ring sample gave it: block + halo and 3 · halo.)
struct RecordFigures {
  std::uint64_t blocks = 0, ring = 0, window = 0, targets = 0, all_targets = 0, segments = 0;
};
RecordFigures record_figures(std::int64_t nx, std::int64_t nz, int block, int halo) {
  const BlockAxis ax(nx, std::max(block, 1), halo), az(nz, std::max(block, 1), halo);
  RecordFigures f;
  const std::uint64_t B = std::uint64_t(std::max(block, 1)), h = std::uint64_t(std::max(halo, 0));
  const std::uint64_t wn = B + 2 * h + 1, cx = std::uint64_t(ax.count), cz = std::uint64_t(az.count);
  f.blocks = cx * cz;
  f.window = wn * wn;
  f.ring = 4 * wn;
  f.targets = 4 * B + 8 * h + 8;
  const std::uint64_t edges = 2 * (cx - 1) * cz + 2 * cx * (cz - 1), diagonals = 4 * (cx - 1) * (cz - 1);  // ordered pairs
  f.all_targets = edges * (B + 1) + diagonals * (2 * h + 1);
  f.segments = edges + diagonals;
  return f;
}
}  // namespace

namespace {
// Stream power's refinement as farm tasks (src/world_farm.hpp): a block of a sweep is a pure function
// of the bytes rank 0 sends (its window of the filled input, its ring's coarse change, the records
// its neighbours gave it last (in this sweep or the previous one) or the coarse inflow, and the
// targets it gives its neighbours), so any rank solves it, and rank 0 merges the results in the
// blocks' turns: the record files and the blend get the same bytes for any rank count.
struct SpInflow {
  std::uint32_t cell;  // in the block's window
  float cells;
};
static_assert(sizeof(SpInflow) == 8, "an inflow entry is written as 8 bytes");

// The window's border samples (row-major order).
std::vector<std::uint32_t> window_ring(int wnx, int wnz) {
  std::vector<std::uint32_t> r;
  r.reserve(2 * std::size_t(wnx + wnz));
  for (int j = 0; j < wnz; ++j)
    for (int i = 0; i < wnx; ++i)
      if (hydro::on_border(i, j, wnx, wnz)) r.push_back(std::uint32_t(j * wnx + i));
  return r;
}

// A block's window in world samples.
struct SpBox {
  std::int64_t x0 = 0, z0 = 0;
  int wnx = 0, wnz = 0;
  bool inside(std::int64_t x, std::int64_t z) const { return x > x0 && x < x0 + wnx - 1 && z > z0 && z < z0 + wnz - 1; }
  // Made when needed: a block's and its neighbours' at a time, never the world's.
  std::vector<std::uint32_t> ring() const { return window_ring(wnx, wnz); }
};

// The coarse solve's snapshots: snapshot k (0..K) after step_of[k] of `steps` steps.
std::vector<int> snapshot_steps(int steps, int K) {
  std::vector<int> step_of;
  for (int k = 0; k <= K; ++k) step_of.push_back(int((std::int64_t(k) * steps + K / 2) / K));
  return step_of;
}
// Time: the snapshots around `done` steps, and the share of the later one.
void snapshot_at(const std::vector<int>& step_of, int done, int& k, double& a) {
  const int K = int(step_of.size()) - 1;
  k = 0;
  while (k + 1 < K && step_of[std::size_t(k) + 1] <= done) ++k;
  a = std::clamp(double(done - step_of[std::size_t(k)]) / double(step_of[std::size_t(k) + 1] - step_of[std::size_t(k)]), 0.0, 1.0);
}

// Raw bytes of a task or a result (the ranks share one architecture, src/world_farm.hpp).
struct SpPut {
  std::string s;
  template <class T>
  void one(T v) {
    s.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <class T>
  void many(const T* p, std::size_t n) {
    if (n > 0) s.append(reinterpret_cast<const char*>(p), n * sizeof(T));
  }
};
struct SpGet {
  std::string_view s;
  std::size_t at = 0;
  const char* what;
  [[noreturn]] void bad() const { throw std::runtime_error(std::string("world transport: a malformed stream power ") + what); }
  template <class T>
  T one() {
    T v;
    many(&v, 1);
    return v;
  }
  template <class T>
  void many(T* p, std::size_t n) {
    if (n > (s.size() - at) / sizeof(T)) bad();
    if (n > 0) std::memcpy(static_cast<void*>(p), s.data() + at, n * sizeof(T));
    at += n * sizeof(T);
  }
  template <class T>
  std::vector<T> vec(std::size_t n) {
    if (n > (s.size() - at) / sizeof(T)) bad();
    std::vector<T> v(n);
    many(v.data(), n);
    return v;
  }
  void end() const {
    if (at != s.size()) bad();
  }
};

// The task of one block in one sweep (rank 0 writes it, any rank's kernel reads it):
//   i64 x0, z0; i32 wnx, wnz, K, steps; u8 prev (a sweep after the first), last; u32 outs;
//   the window's heights (wnx · wnz floats, the filled input);
//   the ring's coarse change at snapshots 1..K (K · R doubles; R = the ring's samples);
//   prev: the levels held on the ring, seen then solved (2 · steps · R doubles), whether a neighbour
//     owns each ring sample (R bytes, 1 or 0: a sample on the world's edge has none), the inflow per
//     step (steps u32 counts, then the entries);
//   else: the coarse inflow per snapshot (K + 1 u32 counts, then the entries);
//   per neighbour it gives to (every one before the last sweep; in the last, those whose turn comes
//   later; in neighbour order): its window (i64 x0, z0; i32 wnx, wnz), u32 n, then n targets (u32
//   sample in this window).
// The result: per neighbour it gives to, a u64 length and its segment of the ring records (the
// levels seen then solved, steps · n doubles each; steps u32 inflow counts; the entries);
// then, in the last sweep, the solved window (wnx · wnz floats).
constexpr int kSpMaxSide = 65535;  // a window's side at most (cells are 32-bit indices)

detail::FarmKernel stream_power_kernel(const Frame& W, const erosion::StreamPowerSettings& sp) {
  return [W, sp](std::int64_t, std::string_view bytes) {
    SpGet in{bytes, 0, "task"};
    const std::int64_t x0 = in.one<std::int64_t>(), z0 = in.one<std::int64_t>();
    const int wnx = in.one<std::int32_t>(), wnz = in.one<std::int32_t>(), K = in.one<std::int32_t>(), steps = in.one<std::int32_t>();
    const bool prev = in.one<std::uint8_t>() != 0, last = in.one<std::uint8_t>() != 0;
    const std::uint32_t nouts = in.one<std::uint32_t>();
    // A window of the world (its side within kSpMaxSide).
    auto window_ok = [&](std::int64_t x, std::int64_t z, int nx, int nz) {
      return nx >= 3 && nz >= 3 && nx <= kSpMaxSide && nz <= kSpMaxSide && x >= 0 && z >= 0 && x <= std::int64_t(W.nx) - nx &&
             z <= std::int64_t(W.nz) - nz;
    };
    if (!window_ok(x0, z0, wnx, wnz) || K < 1 || steps < K || steps != sp.steps || nouts > 8) in.bad();
    const std::size_t n = std::size_t(wnx) * std::size_t(wnz), S = std::size_t(steps);
    std::vector<float> h = in.vec<float>(n);
    const std::vector<std::uint32_t> ring = window_ring(wnx, wnz);
    const std::size_t R = ring.size();
    std::vector<std::vector<double>> change(std::size_t(K) + 1, std::vector<double>(R, 0.0));
    for (int k = 1; k <= K; ++k) in.many(change[std::size_t(k)].data(), R);
    std::vector<double> seen, solved;
    std::vector<std::uint8_t> owned;
    std::vector<std::vector<SpInflow>> inflow(prev ? S : std::size_t(K) + 1);
    if (prev) {
      seen = in.vec<double>(S * R);
      solved = in.vec<double>(S * R);
      owned = in.vec<std::uint8_t>(R);
      for (const std::uint8_t o : owned)
        if (o > 1) in.bad();
    }
    {
      const std::vector<std::uint32_t> counts = in.vec<std::uint32_t>(inflow.size());
      for (std::size_t i = 0; i < inflow.size(); ++i) {
        inflow[i] = in.vec<SpInflow>(counts[i]);
        for (const SpInflow& f : inflow[i])
          if (f.cell >= n) in.bad();
      }
    }
    struct Out {
      SpBox box;
      std::vector<std::uint32_t> local;
      std::vector<double> levels;
      std::vector<std::vector<SpInflow>> inflow;
    };
    std::vector<Out> outs(nouts);
    for (Out& o : outs) {
      o.box.x0 = in.one<std::int64_t>(), o.box.z0 = in.one<std::int64_t>();
      o.box.wnx = in.one<std::int32_t>(), o.box.wnz = in.one<std::int32_t>();
      const std::uint32_t m = in.one<std::uint32_t>();  // at most the neighbour's ring
      if (!window_ok(o.box.x0, o.box.z0, o.box.wnx, o.box.wnz) || m > 2 * std::uint32_t(o.box.wnx + o.box.wnz)) in.bad();
      o.local = in.vec<std::uint32_t>(m);
      for (const std::uint32_t c : o.local)
        if (c >= n) in.bad();
      o.levels.assign(2 * S * m, 0.0);
      o.inflow.resize(S);
    }
    in.end();
    const std::vector<int> step_of = snapshot_steps(steps, K);
    std::vector<double> start(R);
    erosion::detail::StreamPowerWindow win;
    // The ring: held at its owner's latest solve where a neighbour owns it (every ring sample off
    // the world's edge), else at its start level plus the coarse change.
    win.ring = [&](int step, bool after_step, double* hw) {
      if (step == 0 && !after_step)
        for (std::size_t q = 0; q < R; ++q) start[q] = hw[ring[q]];
      int k = 0;
      double a = 0;
      snapshot_at(step_of, step + (after_step ? 1 : 0), k, a);
      const double* held = prev ? (after_step ? solved : seen).data() + std::size_t(step) * R : nullptr;
      for (std::size_t q = 0; q < R; ++q)
        hw[ring[q]] = held && owned[q] != 0 ? held[q]
                                            : start[q] + (1 - a) * change[std::size_t(k)][q] + a * change[std::size_t(k) + 1][q];
    };
    // Inflow in whole cells (rounded once per sample and step): the solver then reads A^m from its
    // table instead of calling std::pow for every cell downstream.
    win.inflow = [&](int step, double* extra) {
      if (prev) {
        for (const SpInflow& f : inflow[std::size_t(step)]) extra[f.cell] += double(f.cells);
      } else {
        int k = 0;
        double a = 0;
        snapshot_at(step_of, step, k, a);
        for (const SpInflow& f : inflow[std::size_t(k)]) extra[f.cell] += (1 - a) * double(f.cells);
        for (const SpInflow& f : inflow[std::size_t(k) + 1]) extra[f.cell] += a * double(f.cells);
      }
      for (std::size_t c = 0; c < n; ++c) extra[c] = std::nearbyint(extra[c]);
    };
    // What this block gives its neighbours: their targets' levels (seen, then solved) and the
    // drainage area crossing into their insides.
    if (!outs.empty()) {
      auto record = [&](bool solved_levels) {
        return [&, solved_levels](int step, const double* hw) {
          for (Out& o : outs) {
            const std::size_t m = o.local.size();
            double* dst = o.levels.data() + (solved_levels ? S * m : 0) + std::size_t(step) * m;
            for (std::size_t i = 0; i < m; ++i) dst[i] = hw[o.local[i]];
          }
        };
      };
      win.seen = record(false);
      win.solved = record(true);
      win.routed = [&](int step, const std::uint8_t* dir, const double* area) {
        for (Out& o : outs)
          for (std::size_t i = 0; i < o.local.size(); ++i) {
            const std::uint32_t c = o.local[i];
            const std::uint8_t d = dir[c];
            if (d == hydro::kNoReceiver) continue;
            const std::int64_t x = x0 + std::int64_t(c % std::uint32_t(wnx)) + hydro::kDi[d];
            const std::int64_t z = z0 + std::int64_t(c / std::uint32_t(wnx)) + hydro::kDj[d];
            if (!o.box.inside(x, z)) continue;
            o.inflow[std::size_t(step)].push_back(
                {std::uint32_t((z - o.box.z0) * o.box.wnx + (x - o.box.x0)), float(area[c])});
          }
      };
    }
    erosion::detail::stream_power_window(h.data(), W.window(x0, z0, wnx, wnz), sp, win);
    SpPut res;
    for (const Out& o : outs) {
      std::size_t entries = 0;
      for (const auto& v : o.inflow) entries += v.size();
      res.one(std::uint64_t(o.levels.size() * sizeof(double) + S * sizeof(std::uint32_t) + entries * sizeof(SpInflow)));
      res.many(o.levels.data(), o.levels.size());
      for (const auto& v : o.inflow) res.one(std::uint32_t(v.size()));
      for (const auto& v : o.inflow) res.many(v.data(), v.size());
    }
    if (last) res.many(h.data(), n);
    return std::move(res.s);
  };
}
}  // namespace

namespace detail {
FarmKernel stream_power_farm_kernel(const WorldStageIO& io, const RecipeStage& st) {
  return stream_power_kernel(io.world, erosion::detail::stream_power_settings(st.stage->params()));
}
}  // namespace detail

std::uint64_t world_stream_power_scratch_bytes(std::int64_t nx, std::int64_t nz, int coarse_max, int sweeps, int steps, int block,
                                               int halo) {
  if (nx < 1 || nz < 1 || sweeps <= 0 || coarse_step(nx, nz, coarse_max) == 1) return 0;
  const RecordFigures f = record_figures(nx, nz, block, halo);
  const std::uint64_t S = std::uint64_t(std::max(steps, 1)), K = std::uint64_t(std::min(std::max(steps, 1), kStreamPowerSnapshots)) + 1;
  // The filled input and the blend (4 bytes per world sample each); the coarse inflow's lists (8
  // bytes per entry, at most a ring per block and snapshot); with more than one sweep the two ring
  // record files, each per step the targets' levels seen and solved (doubles), inflow entries (8
  // bytes; measured on 31 % of the targets and steps on a 1025² world, counted on half) and a count
  // per segment (a block and a neighbour: 4 bytes).
  std::uint64_t bytes = 2 * 4 * std::uint64_t(nx) * std::uint64_t(nz) + f.blocks * K * f.ring * 8;
  // Two files from two sweeps on; a sweep gives records only to the neighbours whose turn comes
  // after the giver's, half of the pairs (the row order's or its reverse's): both files together
  // hold about every pair's records once.
  if (sweeps > 1) bytes += S * (f.all_targets * (16 + 4) + f.segments * 4);
  return bytes;
}

std::uint64_t world_stream_power_memory_bytes(std::int64_t nx, std::int64_t nz, int steps, int coarse_max, int block, int halo,
                                              int sweeps) {
  if (nx < 1 || nz < 1) return 0;
  const std::int64_t s = coarse_step(nx, nz, coarse_max);
  const std::uint64_t cnx = std::uint64_t((nx - 1 + s - 1) / s + 1), cnz = std::uint64_t((nz - 1 + s - 1) / s + 1);
  const bool refine = s > 1 && sweeps > 0;
  if (!refine) return cnx * cnz * (40 + 4);
  const std::uint64_t snapshots = std::uint64_t(std::min(std::max(steps, 1), kStreamPowerSnapshots)) + 1;
  const RecordFigures f = record_figures(nx, nz, block, halo);
  const std::uint64_t S = std::uint64_t(std::max(steps, 1));
  // The coarse heights and snapshots, held throughout; then either the coarse solve and the inflow
  // pass (40 + 20 bytes per coarse sample), or one block at a time: its window with the solver's
  // arrays (128 bytes per sample: measured 45 to 195 on windows of 161² at 2 threads, the solver's
  // per-thread buffers growing with the largest drainage basin met), its coarse inflow lists (at
  // most a ring per snapshot), and with more than one sweep its records: what it gives its
  // neighbours (levels seen and solved as doubles, at most an inflow entry per target and step),
  // what it reads (levels as doubles since session 20, inflow; once more in the kernel) and one
  // neighbour's segment being read. The index: 2 · 9
  // file offsets and a list span per snapshot, per block.
  const std::uint64_t coarse = cnx * cnz * (4 * snapshots + 4);
  const std::uint64_t solve = cnx * cnz * (40 + 20);
  // The block travels as a farm task (src/world_farm.hpp): its window's heights in the task and the
  // kernel's copy, the solved window in the result (12 bytes per sample), and the records it reads
  // once more in the kernel.
  std::uint64_t blocks = f.window * (128 + 12) + snapshots * f.ring * 8;
  if (sweeps > 1) blocks += S * (f.targets * (16 + 8) + f.ring * (16 + 8 + 16) + f.ring / 4 * 16);
  return coarse + std::max(solve, blocks) + f.blocks * (2 * 9 * 8 + snapshots * 16);
}

WorldAlgorithmNeedsFn world_stream_power_needs(int coarse_max, int block, int halo, int sweeps) {
  return [coarse_max, block, halo, sweeps](const RecipeStage& st, const WorldGrid& g) {
    const json params = st.stage->params();
    const int steps = params.value("steps", 1);
    // A masked stage is not refined (below).
    const bool masked = params.contains("mask") && params["mask"].is_string() && !params["mask"].get<std::string>().empty();
    const int passes = masked ? 0 : sweeps;
    WorldAlgorithmNeeds n;
    n.memory_bytes = world_stream_power_memory_bytes(g.nx, g.nz, steps, coarse_max, block, halo, passes);
    n.scratch_bytes = world_stream_power_scratch_bytes(g.nx, g.nz, coarse_max, passes, steps, block, halo);
    return n;
  };
}

WorldStageAlgorithm world_stream_power(int coarse_max, int block, int halo, int sweeps) {
  if (coarse_max < 3) throw Error("coarse_max", "expected at least 3 samples, got " + std::to_string(coarse_max));
  if (halo < 4) throw Error("halo", "expected at least 4 samples, got " + std::to_string(halo));
  if (block < 2 * halo)
    throw Error("block", "expected at least 2 × halo = " + std::to_string(2 * halo) + " samples, got " + std::to_string(block));
  if (sweeps < 0) throw Error("sweeps", "expected 0 (the coarse change alone) or more sweeps, got " + std::to_string(sweeps));
  if (std::int64_t(block) + 2 * std::int64_t(halo) + 1 > kSpMaxSide)
    throw Error("block", "expected a window (block + 2 × halo + 1 samples) of at most " + std::to_string(kSpMaxSide) + " samples, got " +
                             std::to_string(std::int64_t(block) + 2 * std::int64_t(halo) + 1));
  return [coarse_max, block, halo, sweeps](const WorldStageIO& io, const RecipeStage& st, int index) {
    const WorldGrid& g = io.grid;
    const Frame& W = io.world;
    const std::int64_t cmax = coarse_max - 1;
    const std::int64_t s = std::max<std::int64_t>({1, (g.nx - 1 + cmax - 1) / cmax, (g.nz - 1 + cmax - 1) / cmax});
    const int cnx = int((g.nx - 1 + s - 1) / s + 1), cnz = int((g.nz - 1 + s - 1) / s + 1);
    const json params = st.stage->params();
    // A masked stage (stage_masked.cpp) is refined by nothing: the coarse change alone, as the mask
    // scales it there.
    const bool refine = s > 1 && sweeps > 0 && !(params.contains("mask") && params["mask"].is_string() && !params["mask"].get<std::string>().empty());
    // Coarse sample c sits at world sample min(c·s, n − 1).
    auto world_of = [&](std::int64_t c, std::int64_t n) { return std::min(c * s, n - 1); };
    Terrain t;
    t.frame = W;
    t.frame.nx = cnx, t.frame.nz = cnz, t.frame.ix0 = 0, t.frame.iz0 = 0;
    t.frame.spacing_m = W.spacing_m * double(s);
    std::vector<float>& e = t.layer("height", 1).data;
    // The refinement reads windows of the input and sums the blocks' shares into the output: both
    // world-sized temporary files (4 bytes per sample each), not memory.
    std::unique_ptr<Scratch> input, output;
    if (refine) {
      input = std::make_unique<Scratch>(io.scratch_dir, g.nx, g.nz, "stream_power");
      output = std::make_unique<Scratch>(io.scratch_dir, g.nx, g.nz, "stream_power");
    }
    const double gather_end = refine ? 0.1 : 0.3, solve_end = refine ? 0.2 : 0.4;
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        const WorldTile in = io.load(X, Z);
        const std::vector<float>& h = in.layers.at("height").data;
        if (input) input->write(w.ix0, w.iz0, w.nx, w.nz, h.data());
        for (int cz = 0; cz < cnz; ++cz) {
          const std::int64_t iz = world_of(cz, g.nz);
          if (iz < w.iz0 || iz >= w.iz0 + w.nz) continue;
          for (int cx = 0; cx < cnx; ++cx) {
            const std::int64_t ix = world_of(cx, g.nx);
            if (ix < w.ix0 || ix >= w.ix0 + w.nx) continue;
            e[std::size_t(cz) * std::size_t(cnx) + std::size_t(cx)] =
                h[std::size_t(iz - w.iz0) * std::size_t(w.nx) + std::size_t(ix - w.ix0)];
          }
        }
        // Progress: the gathering pass, the coarse solve, [the refinement's blocks,] the pass that
        // writes the tiles (a step per tile or block in each pass).
        if (io.progress) io.progress(gather_end * double(Z * g.tiles_x + X + 1) / double(g.count()));
      }
    if (refine) {
      // The whole map's solver starts from its input filled (ε = 0): so do the blocks, from the world's
      // input filled across tiles (the same bytes, into the output's file), so that a lake a block's ring cuts starts at its
      // level and spill, not drained across the ring (stream_power_detail.hpp).
      fill_depressions_tiled(
          g, float(W.sea_level), 0.0f,
          [&](std::int64_t X, std::int64_t Z) {
            check_cancelled(io);
            const WorldGrid::Window w = g.window(X, Z);
            std::vector<float> h(std::size_t(w.nx) * std::size_t(w.nz));
            input->read(w.ix0, w.iz0, w.nx, w.nz, h.data());
            return h;
          },
          [&](std::int64_t X, std::int64_t Z, std::vector<float> h) {
            const WorldGrid::Window w = g.window(X, Z);
            output->write(w.ix0, w.iz0, w.nx, w.nz, h.data());
          },
          {});
      // The filled input becomes the input; the blend starts from a fresh (zero) file.
      std::swap(input, output);
      output.reset();
      output = std::make_unique<Scratch>(io.scratch_dir, g.nx, g.nz, "stream_power");
    }
    std::vector<float> before;
    if (s > 1 && !refine) before = e;
    Context ctx;
    ctx.stage_index = index;  // stream power draws no random numbers
    // The refinement's record of the coarse solve: its heights (metres above the sea, as the solver
    // holds them) at K + 1 times, snapshot k after step_of[k] steps (k = 0: the start).
    const erosion::StreamPowerSettings sp = refine ? erosion::detail::stream_power_settings(params) : erosion::StreamPowerSettings{};
    const int steps = sp.steps, K = std::min(steps, kStreamPowerSnapshots);
    std::vector<int> step_of;
    std::vector<std::vector<float>> snap;
    if (!refine) {
      st.stage->apply(t, ctx);
    } else {
      step_of = snapshot_steps(steps, K);
      snap.resize(std::size_t(K) + 1);
      erosion::detail::StreamPowerWindow record;
      record.seen = [&](int step, const double* h) {
        if (step == 0) snap[0].assign(h, h + e.size());
      };
      record.solved = [&](int step, const double* h) {
        for (int k = 1; k <= K; ++k)
          if (step_of[std::size_t(k)] == step + 1) snap[std::size_t(k)].assign(h, h + e.size());
      };
      erosion::detail::stream_power_window(e.data(), t.frame, sp, record, [&](double f) {
        if (io.progress) io.progress(gather_end + (solve_end - gather_end) * f);
      });
    }
    if (io.progress) io.progress(solve_end);
    const std::vector<float>& after = t.get("height").data;
    std::vector<float> delta;
    if (s > 1 && !refine) {
      delta.resize(after.size());
      for (std::size_t c = 0; c < after.size(); ++c) delta[c] = after[c] - before[c];
    }
    // Interpolation along one axis: the coarse cell holding world sample i and the fraction in it.
    auto locate = [&](std::int64_t i, std::int64_t n, int cn, int& c0, float& f) {
      c0 = int(std::min<std::int64_t>(i / s, cn - 2));
      const std::int64_t a = world_of(c0, n), b = world_of(c0 + 1, n);
      f = float(double(i - a) / double(b - a));
    };
    if (refine) {
      // Refinement (relief/world_bounded.hpp): world blocks, each solved at full resolution on its
      // window with the coarse solution's levels on the window's ring and the coarse drainage area
      // that enters it, blended by weights of world position.
      const BlockAxis ax(g.nx, block, halo), az(g.nz, block, halo);
      const std::int64_t blocks = ax.count * az.count;
      // The coarse change since the start at snapshot k, at a world sample (bilinear).
      auto coarse_change = [&](int k, std::int64_t ix, std::int64_t iz) {
        int cx = 0, cz = 0;
        float fx = 0, fz = 0;
        locate(ix, g.nx, cnx, cx, fx);
        locate(iz, g.nz, cnz, cz, fz);
        const std::vector<float>& a = snap[std::size_t(k)];
        const std::vector<float>& z = snap[0];
        const std::size_t c = std::size_t(cz) * std::size_t(cnx) + std::size_t(cx), C = std::size_t(cnx);
        auto d = [&](std::size_t q) { return double(a[q]) - double(z[q]); };
        return (d(c) * (1 - fx) + d(c + 1) * fx) * (1 - fz) + (d(c + C) * (1 - fx) + d(c + C + 1) * fx) * fz;
      };
      // Inflow: for every snapshot, the coarse receivers and drainage areas (on the snapshot's
      // levels, filled as the solver fills them); a coarse cell outside a window's inside (or on its
      // ring) whose receiver is inside brings its area, in fine cells (s² per coarse cell), to the
      // window's inside sample nearest to it. Per block and snapshot, a short list.
      using Inflow = SpInflow;
      // The lists go to a temporary file as they are made, block after block for each snapshot
      // (memory: the coarse grid's receivers and one list; the index, 16 bytes per block and
      // snapshot). A block's list holds its entries in the order of the coarse cells d: its own
      // scan covers every d whose receiver can be inside its window (a D8 neighbour of d, so d
      // within one coarse cell of the coarse cells inside).
      TempFile coarse_inflow(io.scratch_dir, "stream_power", "the refinement's coarse inflow");
      struct Span {
        std::uint64_t at = 0;
        std::uint32_t count = 0;
      };
      std::vector<Span> inflow_at(std::size_t(blocks) * (std::size_t(K) + 1));
      {
        std::vector<double> hk(e.size());
        std::vector<std::uint32_t> rec(e.size()), order, count(e.size());
        std::vector<Inflow> list;
        std::uint64_t written = 0;
        for (int k = 0; k <= K; ++k) {
          check_cancelled(io);
          for (std::size_t c = 0; c < e.size(); ++c) hk[c] = snap[std::size_t(k)][c];
          hydro::fill_depressions<double>(hk.data(), cnx, cnz, 0.0, 1e-6);
          hydro::d8_receivers<double>(hk.data(), cnx, cnz, 0.0, rec.data());
          hydro::flow_order(rec.data(), e.size(), order, count.data());
          for (std::int64_t bz = 0; bz < az.count; ++bz)
            for (std::int64_t bx = 0; bx < ax.count; ++bx) {
              const std::int64_t x0 = ax.lo(bx), x1 = ax.hi(bx), z0 = az.lo(bz), z1 = az.hi(bz);
              auto in = [&](std::int64_t x, std::int64_t z) { return x > x0 && x < x1 && z > z0 && z < z1; };
              const std::int64_t cx0 = std::max<std::int64_t>(0, x0 / s - 1), cx1 = std::min<std::int64_t>(cnx - 1, x1 / s + 1);
              const std::int64_t cz0 = std::max<std::int64_t>(0, z0 / s - 1), cz1 = std::min<std::int64_t>(cnz - 1, z1 / s + 1);
              list.clear();
              for (std::int64_t cz = cz0; cz <= cz1; ++cz)
                for (std::int64_t cx = cx0; cx <= cx1; ++cx) {
                  const std::size_t d = std::size_t(cz) * std::size_t(cnx) + std::size_t(cx);
                  const std::size_t r = rec[d];
                  if (r == d) continue;
                  const std::int64_t dx = world_of(cx, g.nx), dz = world_of(cz, g.nz);
                  const std::int64_t rx = world_of(std::int64_t(r % std::size_t(cnx)), g.nx), rz = world_of(std::int64_t(r / std::size_t(cnx)), g.nz);
                  if (!in(rx, rz) || in(dx, dz)) continue;
                  const std::int64_t ix = std::clamp(dx, x0 + 1, x1 - 1), iz = std::clamp(dz, z0 + 1, z1 - 1);
                  list.push_back({std::uint32_t((iz - z0) * (x1 - x0 + 1) + (ix - x0)), float(double(count[d]) * double(s * s))});
                }
              Span& sp_ = inflow_at[std::size_t(bz * ax.count + bx) * (std::size_t(K) + 1) + std::size_t(k)];
              sp_.at = written, sp_.count = std::uint32_t(list.size());
              if (!list.empty()) coarse_inflow.io(true, written, list.data(), list.size() * sizeof(Inflow));
              written += list.size() * sizeof(Inflow);
            }
        }
      }
      // Block b's lists, one per snapshot, read back from the file.
      auto coarse_inflow_of = [&](std::size_t b) {
        std::vector<std::vector<Inflow>> lists(std::size_t(K) + 1);
        for (std::size_t k = 0; k <= std::size_t(K); ++k) {
          const Span& sp_ = inflow_at[b * (std::size_t(K) + 1) + k];
          lists[k].resize(sp_.count);
          if (sp_.count > 0) coarse_inflow.io(false, sp_.at, lists[k].data(), lists[k].size() * sizeof(Inflow));
        }
        return lists;
      };
      const double blocks_end = 0.9;
      // Sweeps (an overlapping Schwarz iteration): the first holds each window's ring at the coarse
      // levels and gives it the coarse inflow; each later one holds it, step by step, at the latest
      // solve of the neighbour whose core holds the ring sample (every ring sample that is not on the
      // world's edge, where the ring is the world's border, at base level; targets_of below) and
      // gives it the drainage area entering across it (that neighbour's receivers and areas there).
      // The levels travel as doubles, the solver's own (floats until session 20: 1025² in blocks of
      // 128, halo 48, 6 sweeps, stream power alone: 0.368 % near the seams, 0.291 % as doubles). With
      // exact levels and inflow a window is exact
      // (StreamPower.WindowGivenTheWholeMapsRingAndInflowReproducesItsInside).
      // The later sweeps are multiplicative (Gauss-Seidel): a block reads what its neighbours gave in
      // this sweep if their turn came before its own, else what they gave in the previous one. The
      // turns alternate between the blocks' row order (odd sweeps) and its reverse (even sweeps), so
      // one sweep carries the fine solution across the whole world along every river running down
      // the rows or along them one way (area downstream, levels upstream), and the next along the
      // others. (A Jacobi sweep carried it one block further; at 8193² in blocks of 1024 a river
      // crosses 8 blocks, which 4 such sweeps did not reach.) The row order runs as waves
      // bx + 2·bz: a block's four neighbours before it in the rows (W, NW, N, NE) are in earlier
      // waves, the other four in later ones, so the blocks of a wave are no neighbours of each other
      // and run at once, on any rank count, reading the same records.
      using Box = SpBox;
      std::vector<Box> boxes(static_cast<std::size_t>(blocks));
      for (std::int64_t bz = 0; bz < az.count; ++bz)
        for (std::int64_t bx = 0; bx < ax.count; ++bx) {
          Box& b = boxes[std::size_t(bz * ax.count + bx)];
          b.x0 = ax.lo(bx), b.z0 = az.lo(bz);
          b.wnx = int(ax.hi(bx) - b.x0 + 1), b.wnz = int(az.hi(bz) - b.z0 + 1);
        }
      // What block j gives to block k's ring (k a neighbour of j, k ≠ j): the ring samples q of k
      // that lie in j's core (BlockAxis::owner: a shared core end belongs to the lower block), in ring
      // order, with the sample in j's window. Geometry only: the writer (j) and the
      // reader (k, in a later turn) make the same list. Each ring sample off the world's edge has one
      // giver, its owner, where it lies at least `halo` samples inside the giver's window (or at the
      // world's edge, its border): until
      // session 20 the givers' weights of world position (the blend's) were used, so a ring sample
      // near a core end was a blend of two neighbours' levels and areas, one of them as little as
      // halo/2 from its own ring, and their routes could disagree (1025² in blocks of 128, halo 48, 6
      // sweeps, stream power alone: 0.291 % of the relief near the seams, 0.182 % with one owner).
      struct Target {
        std::uint32_t q, local;
      };
      auto targets_of = [&](std::size_t j, std::size_t k, const std::vector<std::uint32_t>& kring) {
        std::vector<Target> ts;
        const Box& b = boxes[j];
        const Box& o = boxes[k];
        const std::int64_t bx = std::int64_t(j) % ax.count, bz = std::int64_t(j) / ax.count;
        for (std::size_t q = 0; q < kring.size(); ++q) {
          const std::int64_t x = o.x0 + kring[q] % std::uint32_t(o.wnx), z = o.z0 + kring[q] / std::uint32_t(o.wnx);
          if (!b.inside(x, z)) continue;
          if (ax.owner(x) != bx || az.owner(z) != bz) continue;
          ts.push_back({std::uint32_t(q), std::uint32_t((z - b.z0) * b.wnx + (x - b.x0))});
        }
        return ts;
      };
      // Turns: sweep 0 (Jacobi) has none; odd sweeps run the waves up, even ones down.
      auto wave_of = [&](std::size_t b) { return std::int64_t(b) % ax.count + 2 * (std::int64_t(b) / ax.count); };
      auto turn_before = [&](int sweep, std::size_t j, std::size_t k) {
        if (sweep == 0) return false;
        return sweep % 2 == 1 ? wave_of(j) < wave_of(k) : wave_of(j) > wave_of(k);
      };
      // The neighbours of block j (k ≠ j), in block order, and their slot (0..8) around j.
      auto neighbours = [&](std::size_t j) {
        std::vector<std::pair<std::size_t, int>> ns;
        const std::int64_t bx = std::int64_t(j) % ax.count, bz = std::int64_t(j) / ax.count;
        for (std::int64_t nz_ = std::max<std::int64_t>(0, bz - 1); nz_ <= std::min(az.count - 1, bz + 1); ++nz_)
          for (std::int64_t nx_ = std::max<std::int64_t>(0, bx - 1); nx_ <= std::min(ax.count - 1, bx + 1); ++nx_) {
            const std::size_t k = std::size_t(nz_ * ax.count + nx_);
            if (k != j) ns.push_back({k, int((nz_ - bz + 1) * 3 + (nx_ - bx + 1))});
          }
        return ns;
      };
      // A block's levels and inflow from its neighbours, as block k reads them: per step, the ring's
      // levels seen and solved (steps × ring samples), whether a neighbour owns each ring sample, and
      // the inflow.
      struct History {
        std::vector<double> seen, solved;
        std::vector<std::uint8_t> owned;
        std::vector<std::vector<Inflow>> inflow;
      };
      // The records between turns live in two temporary files (sweep s writes file s mod 2; see
      // `latest` below), not in memory: block j, once solved, writes what it gives each neighbour k
      // whose turn comes after its own (a segment: for its targets, in their order, the levels seen,
      // then solved, as doubles, steps × targets each; then the inflow entries' count per step
      // (uint32) and the entries, step after step), and block k, in its turn, reads the segments its
      // neighbours wrote for it last, in block order: each ring sample's levels from its one owner,
      // the inflow entries of all of them, appended. Memory: one block's
      // segments and one block's History; the index (a segment's offset per block and neighbour
      // slot, 72 bytes per block and file, two files).
      std::unique_ptr<TempFile> records[2];
      std::vector<std::array<std::uint64_t, 9>> offsets[2];
      for (int f = 0; f < (sweeps > 1 ? 2 : 0); ++f) {
        records[f] = std::make_unique<TempFile>(io.scratch_dir, "stream_power", "the refinement's ring records");
        offsets[f].assign(std::size_t(blocks), std::array<std::uint64_t, 9>{});
      }
      // The file holding each block's latest records (sweep s writes file s % 2, so a sweep reads
      // the previous one's records, never overwritten while it runs, and its own earlier turns').
      std::vector<int> latest(static_cast<std::size_t>(blocks), -1);
      // The neighbours block j gives records to in a sweep: those whose turn comes after j's. Only
      // they read them: in this sweep, and in the next one, whose order is the reverse, before j's
      // turn comes again (a neighbour whose turn came before j's reads j's records of this sweep
      // nowhere: the next sweep gives it newer ones first). Sweep 0 gives as if in the reverse
      // order: sweep 1 runs the row order, and a block reads sweep 0's records of the neighbours
      // whose turn comes after its own there. With one sweep, none.
      auto gives = [&](int sweep, std::size_t j) {
        std::vector<std::pair<std::size_t, int>> ns;
        if (sweeps < 2) return ns;
        for (const auto& n : neighbours(j))
          if (turn_before(sweep == 0 ? 2 : sweep, j, n.first)) ns.push_back(n);
        return ns;
      };
      const std::size_t S = std::size_t(steps);
      auto read_history = [&](std::size_t k, const std::vector<std::uint32_t>& kring) {
        History hs;
        const std::size_t R = kring.size();
        hs.seen.assign(S * R, 0.0);
        hs.solved.assign(S * R, 0.0);
        hs.owned.assign(R, 0);
        hs.inflow.resize(S);
        std::vector<double> levels;
        std::vector<std::uint32_t> counts(S);
        std::vector<Inflow> entries;
        for (const auto& nj : neighbours(k)) {
          const std::size_t j = nj.first;
          const std::vector<Target> ts = targets_of(j, k, kring);
          for (const Target& t : ts) {
            if (hs.owned[t.q] != 0) throw std::logic_error("world_stream_power: a ring sample with two owners");
            hs.owned[t.q] = 1;
          }
          // j's slot around k is the mirror of k's slot around j.
          int slot = -1;
          for (const auto& [kk, s2] : neighbours(j))
            if (kk == k) slot = s2;
          const int from = latest[j];
          if (from < 0) throw std::logic_error("world_stream_power: a block's records read before it gave them");
          std::uint64_t at = offsets[std::size_t(from)][j][std::size_t(slot)];
          const std::size_t n = ts.size();
          levels.resize(2 * S * n);
          records[from]->io(false, at, levels.data(), levels.size() * sizeof(double));
          at += levels.size() * sizeof(double);
          for (int half = 0; half < 2; ++half) {
            std::vector<double>& v = half == 0 ? hs.seen : hs.solved;
            const double* src = levels.data() + std::size_t(half) * S * n;
            for (std::size_t step = 0; step < S; ++step)
              for (std::size_t i = 0; i < n; ++i) v[step * R + ts[i].q] = src[step * n + i];
          }
          records[from]->io(false, at, counts.data(), S * sizeof(std::uint32_t));
          at += S * sizeof(std::uint32_t);
          std::size_t total = 0;
          for (std::uint32_t c : counts) total += c;
          entries.resize(total);
          if (total > 0) records[from]->io(false, at, entries.data(), total * sizeof(Inflow));
          std::size_t e0 = 0;
          for (std::size_t step = 0; step < S; ++step) {
            hs.inflow[step].insert(hs.inflow[step].end(), entries.begin() + std::ptrdiff_t(e0), entries.begin() + std::ptrdiff_t(e0 + counts[step]));
            e0 += counts[step];
          }
        }
        return hs;
      };
      // The blocks of each sweep are farm tasks (src/world_farm.hpp; stream_power_kernel above): on
      // this rank, one at a time (the solver uses the rank's threads; so the memory is one block's),
      // or on other ranks in a distributed build; a sweep after the first runs wave after wave, each
      // wave's blocks at once, merged in the order of `items`, so the record files and the blend are
      // the same bytes for any rank count.
      const detail::FarmOf farm(io.farm);
      const detail::FarmKernel kernel = stream_power_kernel(W, sp);
      std::vector<std::int64_t> ids(static_cast<std::size_t>(blocks));
      for (std::int64_t b = 0; b < blocks; ++b) ids[std::size_t(b)] = b;
      const double work = double(blocks) * double(sweeps);
      std::int64_t done = 0;
      for (int sweep = 0; sweep < sweeps; ++sweep) {
        const bool last = sweep + 1 == sweeps;
        const int to = sweep % 2;  // the file this sweep writes
        std::uint64_t written = 0;
        auto task = [&](std::int64_t b) {
          check_cancelled(io);
          const std::size_t id = std::size_t(b);
          const Box& box = boxes[id];
          const std::int64_t x0 = box.x0, z0 = box.z0;
          const int wnx = box.wnx, wnz = box.wnz;
          const std::vector<std::uint32_t> ring = box.ring();
          const std::vector<std::pair<std::size_t, int>> ns = gives(sweep, id);
          SpPut t;
          t.one(x0), t.one(z0);
          t.one(std::int32_t(wnx)), t.one(std::int32_t(wnz)), t.one(std::int32_t(K)), t.one(std::int32_t(steps));
          t.one(std::uint8_t(sweep > 0)), t.one(std::uint8_t(last)), t.one(std::uint32_t(ns.size()));
          {
            std::vector<float> h(std::size_t(wnx) * std::size_t(wnz));
            input->read(x0, z0, wnx, wnz, h.data());
            t.many(h.data(), h.size());
          }
          // The ring's coarse change at each snapshot (the first sweep, and the world's edge in every sweep).
          std::vector<double> change(ring.size());
          for (int k = 1; k <= K; ++k) {
            for (std::size_t q = 0; q < ring.size(); ++q)
              change[q] = coarse_change(k, x0 + ring[q] % std::uint32_t(wnx), z0 + ring[q] / std::uint32_t(wnx));
            t.many(change.data(), change.size());
          }
          std::vector<std::vector<Inflow>> lists;
          if (sweep > 0) {
            const History hs = read_history(id, ring);
            t.many(hs.seen.data(), hs.seen.size());
            t.many(hs.solved.data(), hs.solved.size());
            t.many(hs.owned.data(), hs.owned.size());
            lists = hs.inflow;
          } else {
            lists = coarse_inflow_of(id);
          }
          for (const auto& l : lists) t.one(std::uint32_t(l.size()));
          for (const auto& l : lists) t.many(l.data(), l.size());
          for (const auto& [k, slot] : ns) {
            const Box& o = boxes[k];
            t.one(o.x0), t.one(o.z0), t.one(std::int32_t(o.wnx)), t.one(std::int32_t(o.wnz));
            const std::vector<Target> ts = targets_of(id, k, o.ring());
            t.one(std::uint32_t(ts.size()));
            for (const Target& x : ts) t.one(x.local);
          }
          return std::move(t.s);
        };
        auto merge = [&](std::int64_t b, std::string out) {
          const std::size_t id = std::size_t(b);
          const Box& box = boxes[id];
          const std::int64_t x0 = box.x0, z0 = box.z0;
          const int wnx = box.wnx, wnz = box.wnz;
          SpGet r{out, 0, "result"};
          // This block's segments, appended to the sweep's file.
          const std::vector<std::pair<std::size_t, int>> ns = gives(sweep, id);
          for (const auto& [k, slot] : ns) {
            const std::uint64_t len = r.one<std::uint64_t>();
            if (len > out.size() - r.at) r.bad();
            offsets[to][id][std::size_t(slot)] = written;
            if (len > 0) records[to]->io(true, written, out.data() + r.at, std::size_t(len));
            written += len;
            r.at += std::size_t(len);
          }
          if (!ns.empty()) latest[id] = to;
          if (!last) {
            r.end();
          } else {
            // This block's share, added to the output in its turn (the same order for every tiling).
            // The solved window, read in place (wnx · wnz floats).
            const std::size_t at = r.at;
            if (out.size() - at != 4 * std::size_t(wnx) * std::size_t(wnz)) r.bad();
            auto solved = [&](std::size_t c) {
              float v;
              std::memcpy(&v, out.data() + at + 4 * c, 4);
              return v;
            };
            const std::int64_t kx = b % ax.count, kz = b / ax.count;
            std::int64_t ux0 = x0, ux1 = x0 + wnx - 1, uz0 = z0, uz1 = z0 + wnz - 1;
            while (ux0 < ux1 && ax.weight(kx, ux0) == 0) ++ux0;
            while (ux1 > ux0 && ax.weight(kx, ux1) == 0) --ux1;
            while (uz0 < uz1 && az.weight(kz, uz0) == 0) ++uz0;
            while (uz1 > uz0 && az.weight(kz, uz1) == 0) --uz1;
            const int unx = int(ux1 - ux0 + 1), unz = int(uz1 - uz0 + 1);
            std::vector<float> sum(std::size_t(unx) * std::size_t(unz));
            output->read(ux0, uz0, unx, unz, sum.data());
            for (int j = 0; j < unz; ++j) {
              const double wz = az.weight(kz, uz0 + j);
              for (int i = 0; i < unx; ++i) {
                const double w = wz * ax.weight(kx, ux0 + i);
                const float v = solved(std::size_t(uz0 + j - z0) * std::size_t(wnx) + std::size_t(ux0 + i - x0));
                float& o = sum[std::size_t(j) * std::size_t(unx) + std::size_t(i)];
                if (w == 1.0)
                  o = v;
                else if (w > 0)
                  o = float(double(o) + w * double(v));
              }
            }
            output->write(ux0, uz0, unx, unz, sum.data());
          }
          if (io.progress) io.progress(solve_end + (blocks_end - solve_end) * double(++done) / work);
        };
        if (sweep == 0) {
          farm->run("stream-power", ids, task, kernel, merge, 1);
          continue;
        }
        const std::int64_t waves = (ax.count - 1) + 2 * (az.count - 1) + 1;
        for (std::int64_t i = 0; i < waves; ++i) {
          const std::int64_t w = sweep % 2 == 1 ? i : waves - 1 - i;
          std::vector<std::int64_t> wave;
          for (std::int64_t bz = 0; bz < az.count && 2 * bz <= w; ++bz)
            if (w - 2 * bz < ax.count) wave.push_back(bz * ax.count + (w - 2 * bz));
          if (!wave.empty()) farm->run("stream-power", wave, task, kernel, merge, 1);
        }
      }
      // The whole map's stage ends ε-filled (it drains); so does the world: the blend, clamped to
      // [0, 1] as the stage clamps, filled across tiles as the world's fill stage fills (exact: the
      // whole world's fill_depressions, ε = 0), into the input's file (no longer needed).
      const double fill_end = 0.97;
      fill_depressions_tiled(
          g, float(W.sea_level), 0.0f,
          [&](std::int64_t X, std::int64_t Z) {
            check_cancelled(io);
            const WorldGrid::Window w = g.window(X, Z);
            std::vector<float> h(std::size_t(w.nx) * std::size_t(w.nz));
            output->read(w.ix0, w.iz0, w.nx, w.nz, h.data());
            for (float& v : h) v = std::clamp(v, 0.0f, 1.0f);
            return h;
          },
          [&](std::int64_t X, std::int64_t Z, std::vector<float> h) {
            const WorldGrid::Window w = g.window(X, Z);
            input->write(w.ix0, w.iz0, w.nx, w.nz, h.data());
          },
          [&](double f) {
            if (io.progress) io.progress(blocks_end + (fill_end - blocks_end) * f);
          });
      for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
        for (std::int64_t X = 0; X < g.tiles_x; ++X) {
          check_cancelled(io);
          const WorldGrid::Window w = g.window(X, Z);
          WorldTile tile = io.load(X, Z);
          std::vector<float>& h = tile.layers.at("height").data;
          input->read(w.ix0, w.iz0, w.nx, w.nz, h.data());
          io.store(X, Z, std::move(tile));
          if (io.progress) io.progress(fill_end + (1 - fill_end) * double(Z * g.tiles_x + X + 1) / double(g.count()));
        }
      return;
    }
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        WorldTile tile = io.load(X, Z);
        std::vector<float>& h = tile.layers.at("height").data;
        for (int j = 0; j < w.nz; ++j) {
          int cz = 0;
          float fz = 0;
          if (s > 1) locate(w.iz0 + j, g.nz, cnz, cz, fz);
          for (int i = 0; i < w.nx; ++i) {
            float& v = h[std::size_t(j) * w.nx + i];
            if (s == 1) {
              v = after[std::size_t(w.iz0 + j) * std::size_t(cnx) + std::size_t(w.ix0 + i)];
              continue;
            }
            int cx = 0;
            float fx = 0;
            locate(w.ix0 + i, g.nx, cnx, cx, fx);
            const std::size_t c = std::size_t(cz) * std::size_t(cnx) + std::size_t(cx);
            const float d = (delta[c] * (1 - fx) + delta[c + 1] * fx) * (1 - fz) +
                            (delta[c + std::size_t(cnx)] * (1 - fx) + delta[c + std::size_t(cnx) + 1] * fx) * fz;
            v = std::clamp(v + d, 0.0f, 1.0f);
          }
        }
        io.store(X, Z, std::move(tile));
        if (io.progress) io.progress(solve_end + (1 - solve_end) * double(Z * g.tiles_x + X + 1) / double(g.count()));
      }
  };
}

SeamMetrics seam_metrics(const std::vector<float>& tiled, const std::vector<float>& whole, const WorldGrid& g, int band,
                         const Frame& world) {
  const std::size_t n = std::size_t(g.nx) * std::size_t(g.nz);
  if (tiled.size() != n || whole.size() != n)
    throw Error("seam_metrics", "expected " + std::to_string(n) + " heights for both worlds, got " +
                                    std::to_string(tiled.size()) + " and " + std::to_string(whole.size()));
  SeamMetrics m;
  const std::int64_t step = g.tile - 1;
  auto is_seam = [&](std::int64_t i, std::int64_t count) { return i > 0 && i < count - 1 && i % step == 0; };
  // Distance to the nearest seam line along each axis.
  auto near_line = [&](std::int64_t count) {
    std::vector<std::uint8_t> near(std::size_t(count), 0);
    for (std::int64_t i = 0; i < count; ++i)
      if (is_seam(i, count))
        for (std::int64_t d = -band; d <= band; ++d)
          if (i + d >= 0 && i + d < count) near[std::size_t(i + d)] = 1;
    return near;
  };
  const std::vector<std::uint8_t> near_x = near_line(g.nx), near_z = near_line(g.nz);
  float lo = whole[0], hi = whole[0];
  double sum_band = 0, sum_all = 0;
  for (std::int64_t iz = 0; iz < g.nz; ++iz)
    for (std::int64_t ix = 0; ix < g.nx; ++ix) {
      const std::size_t c = std::size_t(iz) * std::size_t(g.nx) + std::size_t(ix);
      lo = std::min(lo, whole[c]), hi = std::max(hi, whole[c]);
      const double d = double(tiled[c]) - double(whole[c]);
      sum_all += d * d;
      m.max_abs_diff = std::max(m.max_abs_diff, std::fabs(d));
      if (near_x[std::size_t(ix)] || near_z[std::size_t(iz)]) {
        sum_band += d * d;
        ++m.band_samples;
      }
    }
  m.relief = double(hi) - double(lo);
  m.rms_all = std::sqrt(sum_all / double(n));
  m.rms_near_seams = m.band_samples ? std::sqrt(sum_band / double(m.band_samples)) : 0.0;
  m.rms_fraction = m.relief > 0 ? m.rms_near_seams / m.relief : 0.0;
  // Slope jumps.
  const double scale = world.height_m / world.cell_m();
  std::vector<float> interior;
  interior.reserve(2 * n);
  auto jump_of = [&](const std::vector<float>& h, std::size_t c, std::size_t stride) {
    return float(std::fabs((double(h[c + stride]) - h[c]) - (double(h[c]) - h[c - stride])) * scale);
  };
  auto at_seam = [&](std::int64_t i, std::int64_t count) {
    return is_seam(i, count) || is_seam(i - 1, count) || is_seam(i + 1, count);
  };
  std::vector<float> seam, whole_seam;
  auto add = [&](std::size_t c, std::size_t stride, bool across) {
    const float j = jump_of(tiled, c, stride);
    if (!across) {
      interior.push_back(j);
      return;
    }
    seam.push_back(j);
    whole_seam.push_back(jump_of(whole, c, stride));
  };
  for (std::int64_t iz = 0; iz < g.nz; ++iz)
    for (std::int64_t ix = 0; ix < g.nx; ++ix) {
      const std::size_t c = std::size_t(iz) * std::size_t(g.nx) + std::size_t(ix);
      if (ix > 0 && ix < g.nx - 1) add(c, 1, at_seam(ix, g.nx));
      if (iz > 0 && iz < g.nz - 1) add(c, std::size_t(g.nx), at_seam(iz, g.nz));
    }
  auto largest = [](const std::vector<float>& v) { return v.empty() ? 0.0 : double(*std::max_element(v.begin(), v.end())); };
  m.seam_jump_max = largest(seam);
  m.whole_seam_jump_max = largest(whole_seam);
  m.interior_jump_max = largest(interior);
  auto p999 = [](std::vector<float>& v) {
    if (v.empty()) return 0.0;
    const std::size_t k = std::size_t(0.999 * double(v.size() - 1));
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
    return double(v[k]);
  };
  m.seam_jumps = std::int64_t(seam.size());
  m.seam_jump_p999 = p999(seam);
  m.whole_seam_jump_p999 = p999(whole_seam);
  m.interior_jumps = std::int64_t(interior.size());
  m.interior_jump_p999 = p999(interior);
  return m;
}

}  // namespace relief
