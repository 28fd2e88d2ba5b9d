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
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>

#include "relief/erosion.hpp"
#include "relief/error.hpp"
#include "relief/stage.hpp"
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

// The world's heights between the passes: one float per sample, row-major, in a temporary file of
// `dir` (WorldStageIO::scratch_dir; when empty the temporary folder, std::filesystem::
// temp_directory_path(): $TMPDIR, else /tmp) that has no name (O_TMPFILE; where the file system
// cannot, one made with mkstemp and unlinked at once), so that it disappears when closed or when the
// process ends, killed or not.
class Scratch {
 public:
  Scratch(std::string dir, std::int64_t nx, std::int64_t nz) : nx_(nx) {
    if (dir.empty()) {
      std::error_code ec;
      const std::filesystem::path t = std::filesystem::temp_directory_path(ec);
      dir = ec ? std::string("/tmp") : t.string();
    }
#ifdef O_TMPFILE
    fd_ = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
#endif
    if (fd_ < 0) {
      std::string name = (std::filesystem::path(dir) / "relief-hydraulic-XXXXXX").string();
      fd_ = ::mkstemp(name.data());
      if (fd_ < 0) fail("create, in " + dir + ",");
      ::unlink(name.c_str());
    }
    if (::ftruncate(fd_, off_t(nx * nz * 4)) != 0) {
      const int err = errno;
      ::close(fd_);
      errno = err;
      fail("size");
    }
  }
  ~Scratch() { ::close(fd_); }
  Scratch(const Scratch&) = delete;
  Scratch& operator=(const Scratch&) = delete;
  // Rows [z0, z0 + nz) × columns [x0, x0 + nx) to or from `data` (nx × nz, row-major).
  void read(std::int64_t x0, std::int64_t z0, int nx, int nz, float* data) const {
    for (int j = 0; j < nz; ++j) io(false, x0, z0 + j, nx, data + std::size_t(j) * std::size_t(nx));
  }
  void write(std::int64_t x0, std::int64_t z0, int nx, int nz, const float* data) const {
    for (int j = 0; j < nz; ++j) io(true, x0, z0 + j, nx, const_cast<float*>(data + std::size_t(j) * std::size_t(nx)));
  }

 private:
  void io(bool write, std::int64_t x0, std::int64_t z, int n, float* p) const {
    char* b = reinterpret_cast<char*>(p);
    std::size_t left = std::size_t(n) * 4;
    off_t at = off_t((z * nx_ + x0) * 4);
    while (left > 0) {
      const ssize_t got = write ? ::pwrite(fd_, b, left, at) : ::pread(fd_, b, left, at);
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) fail(write ? "write" : "read");
      b += got, left -= std::size_t(got), at += got;
    }
  }
  [[noreturn]] static void fail(const std::string& what) {
    throw Error("hydraulic", "could not " + what + " the temporary file of the world's heights: " + std::strerror(errno));
  }
  int fd_ = -1;
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
    std::int64_t G = group_blocks > 0 ? group_blocks : std::max<std::int64_t>(kHydraulicGroupBlocks, (g.tile - 1 + B - 1) / B);
    // A distributed build: groups halved (down to 2 blocks) until each pass has at least 4 per rank,
    // so that every rank gets some (the bytes do not depend on G).
    const int ranks = io.farm ? io.farm->ranks() : 1;
    while (group_blocks == 0 && ranks > 1 && G > 2 && ((nbx + G - 1) / G) * ((nbz + G - 1) / G) < 4 * ranks) G = (G + 1) / 2;
    const std::int64_t ngx = (nbx + G - 1) / G, ngz = (nbz + G - 1) / G;
    const double steps = double(g.count()) * 2 + 16.0 * double(ngx * ngz);
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
    std::unique_ptr<detail::WorldTransport> alone;  // no farm (outside build_world): this process's
    std::unique_ptr<detail::TileFarm> own;
    detail::TileFarm* farm = io.farm;
    if (!farm) {
      alone = detail::in_process_transport();
      own = std::make_unique<detail::TileFarm>(*alone);
      farm = own.get();
    }
    const detail::FarmKernel kernel = hydraulic_kernel(W, s);
    std::vector<std::int64_t> groups(static_cast<std::size_t>(ngx * ngz));
    for (std::int64_t q = 0; q < ngx * ngz; ++q) groups[std::size_t(q)] = q;
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
          "hydraulic", groups,
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

WorldStageAlgorithm world_stream_power(int coarse_max) {
  if (coarse_max < 3) throw Error("coarse_max", "expected at least 3 samples, got " + std::to_string(coarse_max));
  return [coarse_max](const WorldStageIO& io, const RecipeStage& st, int index) {
    const WorldGrid& g = io.grid;
    const Frame& W = io.world;
    const std::int64_t cmax = coarse_max - 1;
    const std::int64_t s = std::max<std::int64_t>({1, (g.nx - 1 + cmax - 1) / cmax, (g.nz - 1 + cmax - 1) / cmax});
    const int cnx = int((g.nx - 1 + s - 1) / s + 1), cnz = int((g.nz - 1 + s - 1) / s + 1);
    // Coarse sample c sits at world sample min(c·s, n − 1).
    auto world_of = [&](std::int64_t c, std::int64_t n) { return std::min(c * s, n - 1); };
    Terrain t;
    t.frame = W;
    t.frame.nx = cnx, t.frame.nz = cnz, t.frame.ix0 = 0, t.frame.iz0 = 0;
    t.frame.spacing_m = W.spacing_m * double(s);
    std::vector<float>& e = t.layer("height", 1).data;
    for (std::int64_t Z = 0; Z < g.tiles_z; ++Z)
      for (std::int64_t X = 0; X < g.tiles_x; ++X) {
        check_cancelled(io);
        const WorldGrid::Window w = g.window(X, Z);
        const WorldTile in = io.load(X, Z);
        const std::vector<float>& h = in.layers.at("height").data;
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
        // Progress: the gathering pass spans [0, 0.3), the coarse solve [0.3, 0.4), the pass that
        // writes the tiles back [0.4, 1] (a step per tile in each pass).
        if (io.progress) io.progress(0.3 * double(Z * g.tiles_x + X + 1) / double(g.count()));
      }
    const std::vector<float> before = e;
    Context ctx;
    ctx.stage_index = index;  // stream power draws no random numbers
    st.stage->apply(t, ctx);
    if (io.progress) io.progress(0.4);
    const std::vector<float>& after = t.get("height").data;
    std::vector<float> delta;
    if (s > 1) {
      delta.resize(after.size());
      for (std::size_t c = 0; c < after.size(); ++c) delta[c] = after[c] - before[c];
    }
    // Interpolation along one axis: the coarse cell holding world sample i and the fraction in it.
    auto locate = [&](std::int64_t i, std::int64_t n, int cn, int& c0, float& f) {
      c0 = int(std::min<std::int64_t>(i / s, cn - 2));
      const std::int64_t a = world_of(c0, n), b = world_of(c0 + 1, n);
      f = float(double(i - a) / double(b - a));
    };
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
        if (io.progress) io.progress(0.4 + 0.6 * double(Z * g.tiles_x + X + 1) / double(g.count()));
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
  std::vector<float> seam;
  auto add = [&](std::size_t c, std::size_t stride, bool across) {
    const float j = jump_of(tiled, c, stride);
    if (!across) {
      interior.push_back(j);
      return;
    }
    seam.push_back(j);
    m.seam_jump_max = std::max(m.seam_jump_max, double(j));
    m.whole_seam_jump_max = std::max(m.whole_seam_jump_max, double(jump_of(whole, c, stride)));
  };
  for (std::int64_t iz = 0; iz < g.nz; ++iz)
    for (std::int64_t ix = 0; ix < g.nx; ++ix) {
      const std::size_t c = std::size_t(iz) * std::size_t(g.nx) + std::size_t(ix);
      if (ix > 0 && ix < g.nx - 1) add(c, 1, at_seam(ix, g.nx));
      if (iz > 0 && iz < g.nz - 1) add(c, std::size_t(g.nx), at_seam(iz, g.nz));
    }
  m.seam_jumps = std::int64_t(seam.size());
  if (!seam.empty()) {
    const std::size_t k = std::size_t(0.999 * double(seam.size() - 1));
    std::nth_element(seam.begin(), seam.begin() + std::ptrdiff_t(k), seam.end());
    m.seam_jump_p999 = seam[k];
  }
  m.interior_jumps = std::int64_t(interior.size());
  if (!interior.empty()) {
    const std::size_t k = std::size_t(0.999 * double(interior.size() - 1));
    std::nth_element(interior.begin(), interior.begin() + std::ptrdiff_t(k), interior.end());
    m.interior_jump_p999 = interior[k];
    m.interior_jump_max = *std::max_element(interior.begin(), interior.end());
  }
  return m;
}

}  // namespace relief
