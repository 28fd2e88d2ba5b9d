// The "tilemap" stage (corner types at the tile grid's vertices → tile indices) and the "tilemap"
// writer (tileset atlas, Tiled TSX/TMX/TMJ, CSV, map render, sidecar).
//
// Why a stage and not writer options: the tile grid is generated data (its corner types, the
// seeded saddle/solid variant choices) that belongs to the recipe, is saved with --save-recipe,
// shows in `relief explain tilemap` and is validated by the one parameter table like every other
// parameter. The writer only encodes what the stage produced. The CLI's --tile-size and
// --map-tiles are shortcuts that set this stage's parameters (adding the stage if the recipe has
// none), so every value still goes through the same table and error paths.
//
// Sources: see include/relief/tilemap.hpp (seed 002's inside-outside tiles, marching squares,
// Tiled's Wang sets).
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/output.hpp"
#include "relief/tilemap.hpp"
#include "shared_tables.hpp"
#include "stages.hpp"
#include "writer_defs.hpp"

namespace relief {
namespace {
// The stage's `classify` strings; the sidecar (tilemap.json) writes the same ones.
const ChoiceNames<TileMap::Classify> kClassifyNames{{TileMap::Classify::Elevation, "elevation"},
                                                    {TileMap::Classify::Biome, "biome"}};

}  // namespace

namespace stages {
namespace {

constexpr int kMaxRenderSide = 16384;    // pixels per side of tilemap.png
constexpr double kMaxRenderPixels = double(1 << 28);

struct TilemapParams {
  int tiles_x = 128, tiles_z = 128;
  int tile_size = 32;
  TileMap::Classify classify = TileMap::Classify::Elevation;
  std::vector<Level> types = default_tile_types();
  bool sea_relative = true;
  std::vector<int> biome_types;
  Precedence precedence = Precedence::Lower;
  double saddle_variants = 0.5;
  double solid_variants = 0.5;
  double texture = 1.0;
  double edges = 1.0;
};

TileStyle style_of(const TilemapParams& p, std::uint64_t seed) {
  TileStyle s;
  s.tile_px = p.tile_size;
  for (auto& l : p.types) s.types.push_back({l.name, l.color, l.at});
  s.precedence = p.precedence;
  s.texture = p.texture;
  s.edges = p.edges;
  s.seed = seed;
  return s;
}

void validate_tilemap(const TilemapParams& p, const std::string& path) {
  const int k = int(p.types.size());
  if (k < kMinTileTypes || k > kMaxTileTypes)
    throw Error(path + ".types", "expected " + std::to_string(kMinTileTypes) + ".." + std::to_string(kMaxTileTypes) +
                                     " terrain types, got " + std::to_string(k));
  for (const char* axis : {"x", "z"}) {
    const int n = axis[0] == 'x' ? p.tiles_x : p.tiles_z;
    if (std::int64_t(n) * p.tile_size > kMaxRenderSide)
      throw Error(path + ".tiles_" + axis, std::to_string(n) + " tiles of " + std::to_string(p.tile_size) + " px make a " +
                                               std::to_string(std::int64_t(n) * p.tile_size) +
                                               " px map image; at most " + std::to_string(kMaxRenderSide) +
                                               " px per side (use fewer tiles or a smaller tile_size)");
  }
  if (double(p.tiles_x) * p.tiles_z * p.tile_size * p.tile_size > kMaxRenderPixels)
    throw Error(path + ".tiles_x", "the map image would have more than 2^28 pixels; use fewer tiles or a smaller tile_size");
  if (p.classify == TileMap::Classify::Biome) {
    if (p.biome_types.empty())
      throw Error(path + ".biome_types", "classify \"biome\" needs a type for each biome id, e.g. [0, 1, 2, 2, 3]");
    for (std::size_t i = 0; i < p.biome_types.size(); ++i)
      if (p.biome_types[i] >= k)
        throw Error(path + ".biome_types[" + std::to_string(i) + "]",
                    "expected a type in 0.." + std::to_string(k - 1) + " (there are " + std::to_string(k) + " types), got " +
                        std::to_string(p.biome_types[i]));
  }
}

// Elevation as the `types` thresholds see it: with sea_relative, piecewise linear so that the
// world's sea level lands on 0.4 (0 and 1 stay put); otherwise unchanged.
double reference_elevation(double e, double sea, bool sea_relative) {
  return sea_relative ? detail::to_reference_elevation(e, sea) : e;
}

void apply_tilemap(Terrain& t, const TilemapParams& p, const Context& ctx) {
  const Frame& f = t.frame;
  auto m = std::make_shared<TileMap>();
  m->style = style_of(p, ctx.stage_seed(1));
  m->tiles_x = p.tiles_x;
  m->tiles_z = p.tiles_z;
  m->classify = p.classify;
  const int k = m->style.k(), W = p.tiles_x, H = p.tiles_z;
  const std::int64_t sx = f.nx - 1, sz = f.nz - 1;
  m->corner_v.assign(std::size_t(W + 1) * std::size_t(H + 1), 0);

  if (p.classify == TileMap::Classify::Biome) {
    if (!t.has("biome"))
      throw Error("", "classify is \"biome\" but the terrain has no 'biome' layer (add a biome stage before the "
                      "tilemap, or use classify \"elevation\")");
    const Layer& b = t.get("biome");
    if (b.data.size() < f.count() * std::size_t(b.channels)) throw Error("", "layer 'biome' does not match the frame");
    // Biome ids cannot be interpolated: each vertex takes the nearest sample (halves round up).
    for (int v = 0; v <= H; ++v) {
      const std::int64_t j = (2 * v * sz + H) / (2 * std::int64_t(H));
      for (int u = 0; u <= W; ++u) {
        const std::int64_t i = (2 * u * sx + W) / (2 * std::int64_t(W));
        const double id = b.data[(std::size_t(j) * f.nx + std::size_t(i)) * b.channels];
        if (!(id >= 0) || id != std::floor(id) || id >= double(p.biome_types.size()))
          throw Error("", "biome id " + std::to_string(id) + " at sample (" + std::to_string(i) + ", " + std::to_string(j) +
                              ") has no entry in biome_types (" + std::to_string(p.biome_types.size()) + " entries)");
        m->corner_v[std::size_t(v) * (W + 1) + u] = std::uint8_t(p.biome_types[std::size_t(id)]);
      }
    }
  } else {
    const Layer& h = t.get("height");
    if (h.data.size() < f.count() * std::size_t(h.channels)) throw Error("", "layer 'height' does not match the frame");
    auto at = [&](std::int64_t i, std::int64_t j) { return double(h.data[(std::size_t(j) * f.nx + std::size_t(i)) * h.channels]); };
    std::vector<float> thresholds;
    for (auto& l : p.types) thresholds.push_back(float(l.at));
    detail::parallel_rows(H + 1, [&](int v) {
      // Vertex (u, v) at fractional sample (u·sx/W, v·sz/H), split exactly into index + fraction.
      const std::int64_t nj = std::int64_t(v) * sz, j0 = nj / H, j1 = std::min(j0 + 1, sz);
      const double fz = double(nj % H) / H;
      for (int u = 0; u <= W; ++u) {
        const std::int64_t ni = std::int64_t(u) * sx, i0 = ni / W, i1 = std::min(i0 + 1, sx);
        const double fx = double(ni % W) / W;
        const double top = at(i0, j0) + (at(i1, j0) - at(i0, j0)) * fx;
        const double bottom = at(i0, j1) + (at(i1, j1) - at(i0, j1)) * fx;
        // Single precision like the colour stage's bands, so a height of 0.3f counts as "at" 0.3.
        const float e = float(reference_elevation(top + (bottom - top) * fz, f.sea_level, p.sea_relative));
        int type = k - 1;
        for (int c = 0; c < k; ++c)
          if (e <= thresholds[std::size_t(c)]) {
            type = c;
            break;
          }
        m->corner_v[std::size_t(v) * (W + 1) + u] = std::uint8_t(type);
      }
    });
  }
  choose_tiles(*m, ctx.stage_seed(2), p.saddle_variants, p.solid_variants);
  t.tilemap = std::move(m);
}

}  // namespace

StageDef tilemap() {
  using P = TilemapParams;
  Table<P> table{{
      param(&P::tiles_x, "tiles_x", 1, 4096, "tiles", "Tiles across (x); the grid stretches over the whole map"),
      param(&P::tiles_z, "tiles_z", 1, 4096, "tiles", "Tiles down (z)"),
      param(&P::tile_size, "tile_size", 8, 128, "px", "Tile size in pixels in the tileset and the map render (16, 32, 64 …)",
            Effect::Recolour),
      choice(&P::classify, "classify", kClassifyNames,
             "Corner types from elevation thresholds (types[].at) or from the 'biome' layer through biome_types"),
      levels(&P::types, "types", 0.0, 1.0,
             "2..8 ordered terrain types [{\"at\", \"color\", \"name\"}]: a corner takes the first type with "
             "elevation ≤ at (the last takes the rest); the name picks the texture (water, sand, grass, forest, rock, snow…)",
             Effect::Regenerate),
      param(&P::sea_relative, "sea_relative", 0, 1, "",
            "Thresholds are written for sea level 0.4 and follow the world's sea level (piecewise linear remap)"),
      int_list(&P::biome_types, "biome_types", 0, kMaxTileTypes - 1,
               "classify biome: the type of each biome id (entry i is the type of id i)"),
      choice(&P::precedence, "precedence", {{Precedence::Lower, "lower"}, {Precedence::Higher, "higher"}},
             "Which type wins inside a tile where types meet: lower (water wins, seed 002) or higher (land wins)"),
      param(&P::saddle_variants, "saddle_variants", 0.0, 1.0, "",
            "Share of ambiguous saddle tiles drawn with the other type connected (chosen from the seed per tile)"),
      param(&P::solid_variants, "solid_variants", 0.0, 1.0, "",
            "Share of single-type tiles drawn with the alternative texture (chosen from the seed per tile)"),
      param(&P::texture, "texture", 0.0, 2.0, "", "Strength of the per-type texture (0 = flat colours)", Effect::Recolour),
      param(&P::edges, "edges", 0.0, 1.0, "", "Strength of shore and outline lines where types meet", Effect::Recolour),
  }};
  StageDef d = make_stage<P>("tilemap",
                       "Inside-outside tilemap: corner types at tile vertices → base-k tile indices (seed 002), "
                       "for the tilemap writer",
                       global("its tile grid stretches over the whole map"), std::move(table), apply_tilemap,
                       validate_tilemap);
  // The tilemap writer's map: tiles × tile_size² RGB pixels, plus its PNG while encoding.
  d.memory.encode_bytes = [](const json& p) -> std::uint64_t {
    if (!p.contains("tiles_x") || !p.contains("tiles_z") || !p.contains("tile_size")) return 0;
    const std::uint64_t px = p["tiles_x"].get<std::uint64_t>() * p["tiles_z"].get<std::uint64_t>() *
                             p["tile_size"].get<std::uint64_t>() * p["tile_size"].get<std::uint64_t>();
    return px * 3 + px * 3 / 2;
  };
  return d;
}

}  // namespace stages

// ---- writer ------------------------------------------------------------------------------------

namespace writers {
namespace {

void write_tilemap(const Terrain& t, const WriteContext& ctx, Output& out) {
  if (!t.tilemap)
    throw Error("formats", "tilemap needs a 'tilemap' stage in the recipe (the CLI adds one with --formats tilemap)");
  const TileMap& m = *t.tilemap;
  const TileStyle& s = m.style;
  const int k = s.k();
  auto progress = [&](double f) {
    if (ctx.progress) ctx.progress("tilemap", f);
  };
  const RgbImage atlas = render_atlas(s);
  progress(0.3);
  out.put(kTilesetPng, encode_png_rgb8(atlas.rgb.data(), atlas.width, atlas.height));
  out.put(kTilesetTsx, encode_tsx(s));
  out.put("tilemap.tmx", encode_tmx(m));
  out.put("tilemap.tmj", encode_tmj(m));
  out.put("tilemap.csv", encode_tile_csv(m));
  progress(0.5);
  {
    const RgbImage map = render_map(m, atlas);
    out.put("tilemap.png", encode_png_rgb8(map.rgb.data(), map.width, map.height));
  }
  progress(0.95);

  json j;
  j["tiles"] = json::array({m.tiles_x, m.tiles_z});
  j["tile_size"] = s.tile_px;
  j["classify"] = choice_name(kClassifyNames, m.classify);
  json types = json::array();
  for (int i = 0; i < k; ++i) {
    const TileType& ty = s.types[std::size_t(i)];
    json o{{"id", i}, {"wang_color", i + 1}, {"name", ty.name}, {"color", write_color(ty.color)}};
    if (m.classify == TileMap::Classify::Elevation) o["max_elevation"] = ty.max_elevation;
    types.push_back(o);
  }
  j["types"] = types;
  j["tile_count"] = tile_count(k);
  j["index"] = "TL*k^3 + TR*k^2 + BL*k + BR, corners top-left, top-right, bottom-left, bottom-right; top = image row 0 (z-min)";
  j["gid"] = "TMX/TMJ gid = index + 1 (firstgid 1); tilemap.csv holds the indices";
  j["atlas"] = {{"file", kTilesetPng}, {"columns", atlas_columns(k)}, {"rows", atlas_rows(k)},
                {"cell", "index i at column i % columns, row i / columns"}};
  json saddles = json::array(), solids = json::array();
  const int base = base_tile_count(k);
  for (int i = base; i < tile_count(k); ++i) {
    const TileShape sh = tile_shape(i, k, s.precedence);
    const int b = tile_index(sh.corners, k);
    if (i < base + saddle_variant_count(k)) saddles.push_back({{"index", i}, {"base", b}, {"connected_type", sh.favoured}});
    else solids.push_back({{"index", i}, {"base", b}, {"type", sh.corners.tl}});
  }
  j["saddle_variants"] = saddles;
  j["solid_variants"] = solids;
  j["vertices"] =
      "vertex (u, v) of the (tiles_x+1) x (tiles_z+1) grid sits at fractional height sample (u*(nx-1)/tiles_x, "
      "v*(nz-1)/tiles_z), elevation interpolated bilinearly (biome: nearest sample)";
  j["height_samples"] = json::array({t.frame.nx, t.frame.nz});
  out.put("tilemap.json", j.dump(2) + "\n");
  progress(1.0);
}

}  // namespace

WriterDef tilemap() {
  WriterDef w{"tilemap",
          "Tiles from the tilemap stage: generated tileset atlas + Tiled TSX (corner Wang set), TMX and TMJ maps, CSV of "
          "tile indices, a PNG render and a JSON sidecar",
          {kTilesetPng, kTilesetTsx, "tilemap.tmx", "tilemap.tmj", "tilemap.csv", "tilemap.png", "tilemap.json"},
          false,
          write_tilemap};
  w.applies = [](const Terrain& t) { return t.tilemap != nullptr; };
  w.needs = "a tilemap: add a tilemap stage to the recipe";
  return w;
}

}  // namespace writers
}  // namespace relief
