// Engine tile sets and the LOD pyramid from a world's tile store (relief/world_engine.hpp).
//
// The engine tiles are encoded by the same functions as `relief generate`'s engine writer
// (engine_tiling, encode_engine_tile, engine_sidecar, engine_import_text in writer_export.cpp), fed
// with the tile's window read from the store: a world whose samples equal a whole-map build's gives
// the same files byte for byte.
//
// The LOD pyramid is a quadtree of 2ⁿ+1 tiles, each level point-sampled from the one below
// (every other sample, no filter), as geometry clipmaps and CDLOD use their nested grids:
//   Losasso and Hoppe, "Geometry clipmaps: terrain rendering using nested regular grids", SIGGRAPH 2004;
//   Strugar, "Continuous distance-dependent level of detail for rendering heightmaps" (CDLOD), JGT 2009.
// It is built depth first (a level-k tile from its four level-(k−1) children, each written as soon
// as it is made), so memory holds at most one tile per level.
#include "relief/world_engine.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "relief/encode_image.hpp"
#include "relief/error.hpp"
#include "relief/file_output.hpp"
#include "relief/pipeline.hpp"
#include "relief/world.hpp"

namespace relief {
namespace {

std::uint16_t to_u16(float v) {  // as the engine writer: round(clamp(v, 0, 1)·65535), halves up
  const double d = v;
  if (!(d > 0.0)) return 0;
  return std::uint16_t((d < 1.0 ? d : 1.0) * 65535.0 + 0.5);
}
std::uint8_t to_u8(float v) {
  const double d = v;
  if (!(d > 0.0)) return 0;
  return std::uint8_t((d < 1.0 ? d : 1.0) * 255.0 + 0.5);
}

// The whole world's frame, from the manifest (the fields read_world_window gives its windows).
Frame world_frame_of(const json& m) {
  const json& fr = m.at("frame");
  Frame f;
  f.world_width_m = fr.at("width_m").get<double>();
  f.world_depth_m = fr.at("depth_m").get<double>();
  f.spacing_m = fr.at("spacing_m").get<double>();
  f.height_m = fr.at("height_m").get<double>();
  f.sea_level = fr.at("sea_level").get<double>();
  return f.window(0, 0, int(fr.at("size").at(0).get<std::int64_t>()), int(fr.at("size").at(1).get<std::int64_t>()));
}

// The height layer of the window [ix0, ix0 + n) × [iz0, iz0 + n) of the store's world (inside it),
// assembled from the store tiles it touches: memory n² floats plus one decoded store tile (the
// other layers are dropped as each tile is read).
std::vector<float> read_height_window(const std::string& dir, const WorldGrid& g, const std::string& world_id, std::int64_t ix0,
                                      std::int64_t iz0, int n) {
  std::vector<float> out(std::size_t(n) * n);
  const std::int64_t step = g.tile - 1;
  const std::int64_t X0 = std::min(ix0 / step, g.tiles_x - 1), X1 = std::min((ix0 + n - 1) / step, g.tiles_x - 1);
  const std::int64_t Z0 = std::min(iz0 / step, g.tiles_z - 1), Z1 = std::min((iz0 + n - 1) / step, g.tiles_z - 1);
  for (std::int64_t Z = Z0; Z <= Z1; ++Z)
    for (std::int64_t X = X0; X <= X1; ++X) {
      const WorldTile t = read_world_tile(dir, X, Z);
      const WorldGrid::Window w = g.window(X, Z);
      if (t.world_id != world_id || t.window.ix0 != w.ix0 || t.window.iz0 != w.iz0 || t.window.nx != w.nx || t.window.nz != w.nz)
        throw Error("tile", world_tile_path(X, Z) + " is not the manifest's tile");
      const auto it = t.layers.find("height");
      if (it == t.layers.end() || it->second.channels != 1) throw Error("tile", world_tile_path(X, Z) + " lacks layer 'height'");
      const std::int64_t a0 = std::max(ix0, w.ix0), a1 = std::min(ix0 + n, w.ix0 + w.nx);
      const std::int64_t b0 = std::max(iz0, w.iz0), b1 = std::min(iz0 + n, w.iz0 + w.nz);
      for (std::int64_t z = b0; z < b1; ++z)
        std::copy_n(it->second.data.data() + std::size_t(z - w.iz0) * std::size_t(w.nx) + std::size_t(a0 - w.ix0), std::size_t(a1 - a0),
                    out.data() + std::size_t(z - iz0) * std::size_t(n) + std::size_t(a0 - ix0));
    }
  return out;
}

// Removes what an earlier export left in our own subfolders (a different split, engine or world
// size would leave stale tiles beside the new ones): in `dir`, the files named like engine tile
// sets; in the pyramid's folder, its level folders (names of digits) and lod.json.
void remove_engine_files(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    for (const char* p : {"unity_height", "unreal_height", "godot_height", "unity_import.txt", "unreal_import.txt", "godot_import.txt"})
      if (n.rfind(p, 0) == 0 && e.is_regular_file(ec)) std::filesystem::remove(e.path(), ec);
  }
}
void remove_lod_files(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    if (e.is_directory(ec) && !n.empty() && n.find_first_not_of("0123456789") == std::string::npos) std::filesystem::remove_all(e.path(), ec);
  }
  std::filesystem::remove(dir / "lod.json", ec);
}

struct LodTile {
  int nx = 0, nz = 0;
  std::vector<float> h;  // nx·nz
  std::vector<float> c;  // nx·nz·3, empty without colour
};

struct Lod {
  std::string store, world_id;
  std::int64_t nx = 0, nz = 0;
  int T = 0;
  bool color = false;
  std::vector<std::unique_ptr<FileOutput>> outs;  // one folder per level: lod/<k>/
  std::string sub;  // "lod/"
  WorldExportReport* rep = nullptr;
  const WorldExportSettings* s = nullptr;
  std::int64_t total = 0;

  // Tiles of level k along an axis of n samples.
  std::int64_t tiles(std::int64_t n, int k) const {
    const std::int64_t span = std::int64_t(T - 1) << k;
    return (n - 1 + span - 1) / span;
  }
  int size(std::int64_t n, std::int64_t X, int k) const {
    const std::int64_t first = (std::int64_t(T - 1) << k) * X;
    return int(std::min<std::int64_t>(T, ((n - 1 - first) >> k) + 1));
  }

  void put(int k, const std::string& name, std::string bytes) {
    rep->bytes += bytes.size();
    rep->files.push_back(sub + std::to_string(k) + "/" + name);
    outs.at(std::size_t(k))->put(name, std::move(bytes));
  }

  void write(int k, std::int64_t X, std::int64_t Z, const LodTile& t) {
    if (s->cancelled && s->cancelled()) throw Cancelled();
    // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on "x" + std::to_string(X).
    std::string base = "x";
    base += std::to_string(X);
    base += "_z";
    base += std::to_string(Z);
    std::vector<std::uint16_t> px(t.h.size());
    for (std::size_t i = 0; i < px.size(); ++i) px[i] = to_u16(t.h[i]);
    put(k, base + ".png", encode_png_pixels(px.data(), px.size() * 2, t.nx, t.nz, 16, 1));
    if (color) {
      std::vector<std::uint8_t> rgb(t.c.size());
      for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] = to_u8(t.c[i]);
      put(k, base + "_color.png", encode_png_rgb8(rgb.data(), t.nx, t.nz));
    }
    ++rep->lod_tiles;
    if (s->progress) s->progress("lod", double(rep->lod_tiles) / double(total));
  }

  LodTile build(int k, std::int64_t X, std::int64_t Z) {
    LodTile p;
    p.nx = size(nx, X, k);
    p.nz = size(nz, Z, k);
    if (k == 0) {
      const WorldTile w = read_world_tile(store, X, Z);
      if (w.world_id != world_id || w.window.nx != p.nx || w.window.nz != p.nz)
        throw Error("tile", world_tile_path(X, Z) + " is not the manifest's tile");
      p.h = w.layers.at("height").data;
      if (color) p.c = w.layers.at("color").data;
    } else {
      p.h.assign(std::size_t(p.nx) * p.nz, 0.0f);
      if (color) p.c.assign(std::size_t(p.nx) * p.nz * 3, 0.0f);
      const int half = (T - 1) / 2;
      for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) {
          const std::int64_t cx = 2 * X + a, cz = 2 * Z + b;
          if (cx >= tiles(nx, k - 1) || cz >= tiles(nz, k - 1)) continue;
          const LodTile ch = build(k - 1, cx, cz);
          // Parent samples (i, j) taken from this child: 2i − a(T−1) in [0, ch.nx), the shared
          // middle column (i = half) from the first child (both hold the same value).
          const int i0 = a ? half + 1 : 0, i1 = std::min(a ? p.nx : half + 1, p.nx);
          const int j0 = b ? half + 1 : 0, j1 = std::min(b ? p.nz : half + 1, p.nz);
          for (int j = j0; j < j1; ++j) {
            const int cj = 2 * j - b * (T - 1);
            for (int i = i0; i < i1; ++i) {
              const int ci = 2 * i - a * (T - 1);
              const std::size_t d = std::size_t(j) * p.nx + i, sidx = std::size_t(cj) * ch.nx + ci;
              p.h[d] = ch.h[sidx];
              if (color)
                for (int c = 0; c < 3; ++c) p.c[3 * d + c] = ch.c[3 * sidx + c];
            }
          }
        }
    }
    write(k, X, Z, p);
    return p;
  }
};

}  // namespace

void check_world_export(const ExportOptions& o, std::int64_t nx, std::int64_t nz, const OptionPath& path_of,
                        const std::string& size_path) {
  validate_export_options(o, [&](const std::string& n) { return option_path(path_of, n); });
  if (o.engine == Engine::None) return;
  if (nx > kMaxWorldSize || nz > kMaxWorldSize) throw Error(size_path, "too large for an engine tile set");
  const EngineTiling t = engine_tiling(o, int(nx), int(nz), path_of, size_path);
  (void)t;
}

WorldExportReport export_world(const WorldExportSettings& s) {
  WorldExportReport rep;
  const json m = read_world_manifest(s.store_dir);
  if (m.value("status", std::string()) != "complete")
    throw Error("output", s.store_dir + " holds an unfinished world: run the same relief world command again to finish it");
  const Frame world = world_frame_of(m);
  const int T = m.at("grid").at("tile").get<int>();
  const WorldGrid grid = world_grid(world.nx, world.nz, T);
  const std::string world_id = m.at("world_id").get<std::string>();
  bool has_color = false;
  for (const json& l : m.at("layers"))
    if (l.at("name") == "color" && l.at("channels") == 3) has_color = true;
  namespace fs = std::filesystem;

  if (s.options.engine != Engine::None) {
    const EngineTiling tl = engine_tiling(s.options, world.nx, world.nz, s.option_path, s.size_path);
    remove_engine_files(fs::path(s.store_dir) / s.engine_subdir);
    FileOutput out((fs::path(s.store_dir) / s.engine_subdir).string(), FileOutput::Mode::Immediate, FileOutput::Sync::Atomic);
    const std::string sub = s.engine_subdir + "/";
    auto put = [&](const std::string& name, std::string bytes) {
      rep.bytes += bytes.size();
      rep.files.push_back(sub + name);
      out.put(name, std::move(bytes));
    };
    const int n = tl.tiles_x * tl.tiles_z;
    for (int tz = 0; tz < tl.tiles_z; ++tz)
      for (int tx = 0; tx < tl.tiles_x; ++tx) {
        if (s.cancelled && s.cancelled()) throw Cancelled();
        const std::vector<float> h =
            read_height_window(s.store_dir, grid, world_id, std::int64_t(tx) * tl.stride, std::int64_t(tz) * tl.stride, tl.tile);
        put(tl.file_name(tx, tz), encode_engine_tile(tl, world, h.data()));
        ++rep.engine_tiles;
        if (s.progress) s.progress("engine tiles", double(rep.engine_tiles) / n);
      }
    put(to_string(tl.engine) + "_height.json", engine_sidecar(tl, world));
    put(to_string(tl.engine) + "_import.txt", engine_import_text(tl, world));
  }

  if (s.lod) {
    remove_lod_files(fs::path(s.store_dir) / s.lod_subdir);
    FileOutput out((fs::path(s.store_dir) / s.lod_subdir).string(), FileOutput::Mode::Immediate, FileOutput::Sync::Atomic);
    Lod lod;
    lod.store = s.store_dir;
    lod.world_id = world_id;
    lod.nx = world.nx;
    lod.nz = world.nz;
    lod.T = T;
    lod.color = has_color;
    lod.sub = s.lod_subdir + "/";
    lod.rep = &rep;
    lod.s = &s;
    int top = 0;
    while (lod.tiles(lod.nx, top) > 1 || lod.tiles(lod.nz, top) > 1) ++top;
    json levels = json::array();
    for (int k = 0; k <= top; ++k) {
      lod.outs.push_back(std::make_unique<FileOutput>((fs::path(s.store_dir) / s.lod_subdir / std::to_string(k)).string(),
                                                      FileOutput::Mode::Immediate, FileOutput::Sync::Atomic));
      lod.total += lod.tiles(lod.nx, k) * lod.tiles(lod.nz, k);
      levels.push_back({{"level", k},
                        {"tiles_x", lod.tiles(lod.nx, k)},
                        {"tiles_z", lod.tiles(lod.nz, k)},
                        {"step_samples", std::int64_t(1) << k},
                        {"spacing_m", world.cell_m() * double(std::int64_t(1) << k)},
                        {"tile_extent_m", world.cell_m() * double(std::int64_t(T - 1) << k)}});
    }
    lod.build(top, 0, 0);
    json d;
    d["format"] = 1;
    d["world_id"] = m.at("world_id");
    d["world_samples"] = {world.nx, world.nz};
    d["tile_samples"] = T;
    d["metres_per_sample"] = world.cell_m();
    d["levels"] = levels;
    d["sampling"] = "point: sample (i, j) of level-k tile (X, Z) is world sample (X*(T-1)*2^k + i*2^k, Z*(T-1)*2^k + j*2^k); "
                    "samples past the world's last one are left out (edge tiles are smaller); level k is level k-1 at every "
                    "other sample";
    d["height"] = {{"file", "<level>/x<X>_z<Z>.png"},
                   {"format", "PNG 16-bit greyscale, row 0 = z-min edge, column = +x"},
                   {"value_to_metres", "y_m = (value / 65535 - sea_level) * height_m"},
                   {"sea_level", world.sea_level},
                   {"height_m", world.height_m},
                   {"min_m", world.y_m(0.0)},
                   {"max_m", world.y_m(1.0)}};
    if (has_color) d["color"] = {{"file", "<level>/x<X>_z<Z>_color.png"}, {"format", "PNG 8-bit RGB of the color layer, round(c*255)"}};
    rep.lod_levels = top + 1;
    const std::string text = d.dump(2) + "\n";
    rep.bytes += text.size();
    rep.files.push_back(lod.sub + "lod.json");
    out.put("lod.json", text);
  }
  return rep;
}

}  // namespace relief
