// Tilemaps: tile indices, tile shapes (marching squares on smoothed corner fields), generated
// tilesets and Tiled export. Contracts and sources: include/relief/tilemap.hpp.
#include "relief/tilemap.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <string>

#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/noise.hpp"
#include "relief/random.hpp"

namespace relief {

// ---- indices ---------------------------------------------------------------------------------

int base_tile_count(int k) { return k * k * k * k; }
int saddle_variant_count(int k) { return k * (k - 1); }
int tile_count(int k) { return k * k * k * k + k * k; }
int atlas_columns(int k) { return k * k; }
int atlas_rows(int k) { return k * k + 1; }

namespace {

void check_k(int k) {
  if (k < kMinTileTypes || k > kMaxTileTypes)
    throw Error("tile", "expected " + std::to_string(kMinTileTypes) + ".." + std::to_string(kMaxTileTypes) +
                            " terrain types, got " + std::to_string(k));
}

}  // namespace

int tile_index(const TileCorners& c, int k) {
  check_k(k);
  for (int t : {c.tl, c.tr, c.bl, c.br})
    if (t < 0 || t >= k) throw Error("tile", "corner type " + std::to_string(t) + " is outside 0.." + std::to_string(k - 1));
  return ((c.tl * k + c.tr) * k + c.bl) * k + c.br;
}

TileCorners tile_corners(int index, int k) {
  check_k(k);
  if (index < 0 || index >= tile_count(k))
    throw Error("tile", "tile index " + std::to_string(index) + " is outside 0.." + std::to_string(tile_count(k) - 1));
  const int base = base_tile_count(k);
  if (index >= base + saddle_variant_count(k)) {
    const int t = index - base - saddle_variant_count(k);
    return {t, t, t, t};
  }
  if (index >= base) {
    const int r = index - base;
    const int a = r / (k - 1), bb = r % (k - 1);
    const int b = bb < a ? bb : bb + 1;
    return {a, b, b, a};
  }
  return {index / (k * k * k), (index / (k * k)) % k, (index / k) % k, index % k};
}

bool is_saddle(const TileCorners& c) { return c.tl == c.br && c.tr == c.bl && c.tl != c.tr; }

int saddle_variant_index(const TileCorners& c, int k) {
  if (!is_saddle(c)) throw Error("tile", "not a saddle tile (expected TL = BR ≠ TR = BL)");
  tile_index(c, k);  // validates the corners
  const int a = c.tl, b = c.tr;
  return base_tile_count(k) + a * (k - 1) + (b < a ? b : b - 1);
}

int solid_variant_index(int type, int k) {
  check_k(k);
  if (type < 0 || type >= k) throw Error("tile", "type " + std::to_string(type) + " is outside 0.." + std::to_string(k - 1));
  return base_tile_count(k) + saddle_variant_count(k) + type;
}

TileShape tile_shape(int index, int k, Precedence p) {
  TileShape s;
  s.corners = tile_corners(index, k);
  const auto& c = s.corners;
  const int lo = std::min({c.tl, c.tr, c.bl, c.br}), hi = std::max({c.tl, c.tr, c.bl, c.br});
  s.favoured = p == Precedence::Lower ? lo : hi;
  const int base = base_tile_count(k);
  if (index >= base && index < base + saddle_variant_count(k)) s.favoured = p == Precedence::Lower ? hi : lo;
  s.alt_texture = index >= base + saddle_variant_count(k);
  s.precedence = p;
  return s;
}

// ---- shapes ------------------------------------------------------------------------------------

namespace {

constexpr double kBump = 0.18;  // β: how far the favoured type reaches into a tile's interior

// Sample positions of one axis: G = S·n fine positions x_g = (g + ½)/G. Everything the score needs
// is tabulated so that 1 − x is x mirrored (index G−1−g): a rotated tile then evaluates exactly
// the same numbers at the rotated position, and shapes are exactly rotation-symmetric.
struct Axis {
  std::vector<double> s;  // smoothstep(x_g)
  std::vector<double> q;  // x_g · x_{G−1−g} = x(1 − x), symmetric by construction
  explicit Axis(int G) : s(std::size_t(G)), q(std::size_t(G)) {
    std::vector<double> x(static_cast<std::size_t>(G));
    for (int g = 0; g < G; ++g) x[std::size_t(g)] = (g + 0.5) / G;
    for (int g = 0; g < G; ++g) {
      const double v = x[std::size_t(g)];
      s[std::size_t(g)] = v * v * (3.0 - 2.0 * v);
      q[std::size_t(g)] = v * x[std::size_t(G - 1 - g)];
    }
  }
};

struct Pick {
  int winner = 0, runner = -1;
  double margin = 1e9;  // score(winner) − score(runner)
  double centre = 0;    // (16·x(1−x)·y(1−y))², 1 at the centre, 0 with zero slope on the edges
};

// The shape rule of tile_type_map at fine position (gx, gy).
class ShapeEval {
 public:
  ShapeEval(const TileShape& sh, int G) : sh_(sh), ax_(G), G_(G) {
    const std::array<int, 4> c{sh.corners.tl, sh.corners.tr, sh.corners.bl, sh.corners.br};
    // Candidates in priority order: favoured first, then precedence order.
    std::array<int, 4> sorted = c;
    std::sort(sorted.begin(), sorted.end());
    if (sh.precedence == Precedence::Higher) std::reverse(sorted.begin(), sorted.end());
    types_[n_++] = sh.favoured;
    for (int t : sorted)
      if (std::find(types_.begin(), types_.begin() + n_, t) == types_.begin() + n_) types_[n_++] = t;
    for (int m = 0; m < n_; ++m) {
      Owned& o = owned_[m];
      for (int q = 0; q < 4; ++q)
        if (c[q] == types_[m]) o.q[o.n++] = q;
      if (o.n == 3)  // keep the one corner of another type in q[3]
        for (int q = 0; q < 4; ++q)
          if (c[q] != types_[m]) o.q[3] = q;
    }
    saddle_ = is_saddle(sh.corners);
  }

  Pick at(int gx, int gy) const {
    const double sx = ax_.s[gx], sy = ax_.s[gy];
    const double cx = ax_.s[G_ - 1 - gx], cy = ax_.s[G_ - 1 - gy];  // 1 − s(x), 1 − s(y) by symmetry
    const std::array<double, 4> w{cx * cy, sx * cy, cx * sy, sx * sy};  // TL, TR, BL, BR
    // A type's score is the sum of its corners' weights, written so that it does not depend on
    // the corners' order (exactly the same numbers for a rotated tile): one corner w, two corners
    // wa + wb (addition commutes), three corners 1 − w(the other corner), four corners 1.
    const double b = 16.0 * ax_.q[gx] * ax_.q[gy];
    Pick pk;
    pk.centre = b * b;
    std::array<double, 4> score{};
    for (int m = 0; m < n_; ++m) {
      const Owned& o = owned_[m];
      score[m] = o.n == 1 ? w[o.q[0]] : o.n == 2 ? w[o.q[0]] + w[o.q[1]] : o.n == 3 ? 1.0 - w[o.q[3]] : 1.0;
    }
    if (saddle_) score[0] += kBump * pk.centre;  // types_[0] is the favoured type
    int best = 0;
    for (int m = 1; m < n_; ++m)
      if (score[m] > score[best]) best = m;
    int second = -1;
    for (int m = 0; m < n_; ++m)
      if (m != best && (second < 0 || score[m] > score[second])) second = m;
    pk.winner = types_[best];
    if (second >= 0) {
      pk.runner = types_[second];
      pk.margin = score[best] - score[second];
    }
    return pk;
  }

 private:
  TileShape sh_;
  Axis ax_;
  int G_;
  std::array<int, 4> types_{};
  struct Owned {
    int n = 0;                  // corners of this type
    std::array<int, 4> q{};     // their indices (TL, TR, BL, BR = 0..3)
  };
  std::array<Owned, 4> owned_{};
  int n_ = 0;
  bool saddle_ = false;
};

}  // namespace

std::vector<std::uint8_t> tile_type_map(const TileShape& shape, int S) {
  if (S < 1 || S > 4096) throw Error("tile_size", "expected 1..4096 pixels, got " + std::to_string(S));
  const ShapeEval ev(shape, S);
  std::vector<std::uint8_t> out(std::size_t(S) * S);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) out[std::size_t(y) * S + x] = std::uint8_t(ev.at(x, y).winner);
  return out;
}

// ---- textures ----------------------------------------------------------------------------------

namespace {

enum class Kind { Deep, Water, Sand, Grass, Forest, Rock, Snow, Plain };

bool has_word(const std::string& lower, std::initializer_list<const char*> words) {
  for (const char* w : words)
    if (lower.find(w) != std::string::npos) return true;
  return false;
}

Kind texture_kind(const std::string& name) {
  std::string l = name;
  for (char& c : l) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (has_word(l, {"deep"})) return Kind::Deep;
  if (has_word(l, {"water", "sea", "ocean", "lake", "river"})) return Kind::Water;
  if (has_word(l, {"sand", "beach", "desert", "dune"})) return Kind::Sand;
  if (has_word(l, {"grass", "meadow", "field", "plain"})) return Kind::Grass;
  if (has_word(l, {"forest", "wood", "tree", "jungle"})) return Kind::Forest;
  if (has_word(l, {"rock", "stone", "mountain", "cliff"})) return Kind::Rock;
  if (has_word(l, {"snow", "ice", "glacier"})) return Kind::Snow;
  return Kind::Plain;
}

// S × S values of a tile-periodic noise with `cells` lattice cells per tile.
std::vector<float> periodic(int S, NoiseBasis basis, Fractal fractal, int octaves, double cells_x, double cells_z,
                            std::uint64_t seed, CellularReturn cr = CellularReturn::F1) {
  NoiseSettings ns;
  ns.basis = basis;
  ns.fractal = fractal;
  ns.octaves = octaves;
  ns.frequency = cells_x / S;
  ns.scale_z = cells_z / cells_x;
  ns.period_x_m = S;
  ns.period_z_m = S;
  ns.cellular = cr;
  ns.jitter = 0.8;
  ns.seed = seed;
  Noise n(ns);
  std::vector<float> out(std::size_t(S) * S);
  for (int y = 0; y < S; ++y) n.row(double(y), 0, 1.0, S, out.data() + std::size_t(y) * S);
  return out;
}

// Lattice cells per tile for features of about `feature_px` pixels (at least 2): features keep
// their size in pixels whatever the tile size, so a texture repeats less visibly in big tiles.
double cells(int S, double feature_px) { return std::max(2.0, std::round(S / feature_px)); }

// Texture of one type: relative brightness L(x, y) (about −1..1) and its amplitude, plus a tint.
struct Texture {
  std::vector<float> L;  // S × S
  double amp = 0.08;
};

Texture make_texture(Kind kind, int S, std::uint64_t seed) {
  Texture t;
  const auto px = [&](int x, int y) { return unit_double(hash64(seed ^ 0x7069786Cull, std::uint64_t(x), std::uint64_t(y))); };
  t.L.assign(std::size_t(S) * S, 0.0f);
  // L = grain(a, r) per pixel: a the noise there, r the pixel's own hash in [0, 1).
  const auto grained = [&](const std::vector<float>& a, auto grain) {
    for (int y = 0; y < S; ++y)
      for (int x = 0; x < S; ++x) {
        const std::size_t i = std::size_t(y) * S + x;
        t.L[i] = float(grain(a[i], px(x, y)));
      }
  };
  switch (kind) {
    case Kind::Deep:
    case Kind::Water: {  // long horizontal swells with a few bright glints
      auto a = periodic(S, NoiseBasis::Value, Fractal::Fbm, 2, cells(S, 24), cells(S, 6), seed);
      auto b = periodic(S, NoiseBasis::Value, Fractal::Fbm, 2, cells(S, 10), cells(S, 4), seed + 1);
      for (std::size_t i = 0; i < t.L.size(); ++i) t.L[i] = float(0.8 * a[i] + (b[i] > 0.45f ? 3.0 * (b[i] - 0.45) : 0.0));
      t.amp = kind == Kind::Deep ? 0.06 : 0.08;
      break;
    }
    case Kind::Sand: {  // fine grain and a few dark specks
      auto a = periodic(S, NoiseBasis::Value, Fractal::Fbm, 2, cells(S, 5), cells(S, 5), seed);
      grained(a, [](float n, double r) { return 0.6 * n + (r - 0.5) * 0.8 - (r > 0.96 ? 1.5 : 0.0); });
      t.amp = 0.07;
      break;
    }
    case Kind::Grass: {  // soft patches with light and dark tufts
      auto a = periodic(S, NoiseBasis::Perlin, Fractal::Fbm, 2, cells(S, 8), cells(S, 8), seed);
      grained(a, [](float n, double r) { return n * 0.8 + (r > 0.9 ? 0.9 : r < 0.08 ? -0.9 : 0.0); });
      t.amp = 0.09;
      break;
    }
    case Kind::Forest: {  // tree crowns of varied tone: bright centres, dark gaps between them
      auto f1 = periodic(S, NoiseBasis::Cellular, Fractal::None, 1, cells(S, 8), cells(S, 8), seed, CellularReturn::F1);
      auto id = periodic(S, NoiseBasis::Cellular, Fractal::None, 1, cells(S, 8), cells(S, 8), seed, CellularReturn::CellValue);
      auto a = periodic(S, NoiseBasis::Value, Fractal::None, 1, cells(S, 12), cells(S, 12), seed + 2);
      for (std::size_t i = 0; i < t.L.size(); ++i) {
        const double d = 0.5 * (f1[i] + 1.0);  // distance to the crown's centre, 0..1 cells
        t.L[i] = float(0.8 - 2.2 * d * d + 0.45 * id[i] + 0.35 * a[i]);
      }
      t.amp = 0.18;
      break;
    }
    case Kind::Rock: {  // angular plates split by cracks (Worley F2 − F1 is small along cell borders)
      auto e = periodic(S, NoiseBasis::Cellular, Fractal::None, 1, cells(S, 11), cells(S, 11), seed, CellularReturn::F2MinusF1);
      auto a = periodic(S, NoiseBasis::Value, Fractal::Fbm, 2, cells(S, 6), cells(S, 6), seed + 3);
      auto w = periodic(S, NoiseBasis::Value, Fractal::None, 1, cells(S, 12), cells(S, 12), seed + 4);
      for (std::size_t i = 0; i < t.L.size(); ++i) {
        const double d = 0.5 * (e[i] + 1.0);  // F2 − F1 in cells
        const double crack = std::max(0.0, 1.0 - d / 0.08) * std::clamp(0.3 + w[i], 0.0, 1.0);  // some cracks fade out
        t.L[i] = float(0.6 * a[i] + 0.6 * std::min(d, 0.5) - 1.1 * crack);
      }
      t.amp = 0.16;
      break;
    }
    case Kind::Snow: {
      auto a = periodic(S, NoiseBasis::Perlin, Fractal::Fbm, 2, cells(S, 16), cells(S, 24), seed);
      for (std::size_t i = 0; i < t.L.size(); ++i) t.L[i] = a[i];
      t.amp = 0.04;
      break;
    }
    case Kind::Plain: {
      auto a = periodic(S, NoiseBasis::Perlin, Fractal::Fbm, 2, cells(S, 10), cells(S, 10), seed);
      for (std::size_t i = 0; i < t.L.size(); ++i) t.L[i] = a[i];
      t.amp = 0.08;
      break;
    }
  }
  return t;
}

double clamp01(double v) { return v < 0 ? 0 : v > 1 ? 1 : v; }

// Everything needed to draw any tile of a style: per type, the main and alternative textured
// colours (S × S × 3, linear 0..1).
struct Palette {
  int S = 0, k = 0;
  std::vector<std::vector<float>> main, alt;
};

Palette make_palette(const TileStyle& st) {
  Palette p;
  p.S = st.tile_px;
  p.k = st.k();
  const int S = p.S;
  for (int t = 0; t < p.k; ++t) {
    const Kind kind = texture_kind(st.types[std::size_t(t)].name);
    const Rgb c = st.types[std::size_t(t)].color;
    for (int v = 0; v < 2; ++v) {
      const Texture tx = make_texture(kind, S, hash64(st.seed, 0x54455854ull + std::uint64_t(t), std::uint64_t(v)));
      std::vector<float> img(std::size_t(S) * S * 3);
      for (std::size_t i = 0; i < tx.L.size(); ++i) {
        const double f = 1.0 + st.texture * tx.amp * double(tx.L[i]);
        img[3 * i + 0] = float(clamp01(c.r * f));
        img[3 * i + 1] = float(clamp01(c.g * f));
        img[3 * i + 2] = float(clamp01(c.b * f));
      }
      (v == 0 ? p.main : p.alt).push_back(std::move(img));
    }
  }
  return p;
}

constexpr int kSub = 4;  // supersampling per axis

// Draws tile `index` into rgb (3 bytes per pixel) with row stride `stride` bytes.
void draw_tile(const TileStyle& st, const Palette& pal, int index, std::uint8_t* rgb, std::size_t stride) {
  const int S = pal.S, k = pal.k;
  const TileShape sh = tile_shape(index, k, st.precedence);
  const ShapeEval ev(sh, S * kSub);
  // Edge lines about 1.2 px wide: the score difference grows by about 3 per tile width.
  const double delta = 3.0 * 1.2 / S;
  for (int y = 0; y < S; ++y) {
    std::uint8_t* row = rgb + std::size_t(y) * stride;
    for (int x = 0; x < S; ++x) {
      const std::size_t pix = (std::size_t(y) * S + x) * 3;
      double acc[3] = {0, 0, 0};
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx) {
          const Pick pk = ev.at(x * kSub + sx, y * kSub + sy);
          const float* m = pal.main[std::size_t(pk.winner)].data() + pix;
          double c[3] = {m[0], m[1], m[2]};
          if (sh.alt_texture) {
            const float* a = pal.alt[std::size_t(pk.winner)].data() + pix;
            for (int ch = 0; ch < 3; ++ch) c[ch] += (a[ch] - c[ch]) * pk.centre;
          }
          if (st.edges > 0 && pk.runner >= 0 && pk.margin < delta) {
            const double f = st.edges * (1.0 - pk.margin / delta);
            if (pk.winner < pk.runner) {  // the lower side of a boundary: a light shore line
              for (double& v : c) v += (1.0 - v) * 0.45 * f;
            } else {  // the higher side: a dark outline
              for (double& v : c) v *= 1.0 - 0.3 * f;
            }
          }
          for (int ch = 0; ch < 3; ++ch) acc[ch] += c[ch];
        }
      for (int ch = 0; ch < 3; ++ch)
        row[std::size_t(x) * 3 + ch] = std::uint8_t(clamp01(acc[ch] / (kSub * kSub)) * 255.0 + 0.5);
    }
  }
}

}  // namespace

void validate_style(const TileStyle& s, const std::string& path) {
  auto field = [&](const char* f) { return path.empty() ? std::string(f) : path + "." + f; };
  if (s.tile_px < 8 || s.tile_px > 128)
    throw Error(field("tile_size"), "expected an integer in 8..128, got " + std::to_string(s.tile_px));
  if (s.k() < kMinTileTypes || s.k() > kMaxTileTypes)
    throw Error(field("types"), "expected " + std::to_string(kMinTileTypes) + ".." + std::to_string(kMaxTileTypes) +
                                    " terrain types, got " + std::to_string(s.k()));
  if (!(s.texture >= 0 && s.texture <= 2)) throw Error(field("texture"), "expected a number in 0..2");
  if (!(s.edges >= 0 && s.edges <= 1)) throw Error(field("edges"), "expected a number in 0..1");
}

RgbImage render_tile(int index, const TileStyle& style) {
  validate_style(style, "");
  tile_corners(index, style.k());  // range check
  const Palette pal = make_palette(style);
  RgbImage img;
  img.width = img.height = style.tile_px;
  img.rgb.resize(std::size_t(img.width) * img.height * 3);
  draw_tile(style, pal, index, img.rgb.data(), std::size_t(img.width) * 3);
  return img;
}

RgbImage render_atlas(const TileStyle& style) {
  validate_style(style, "");
  const int k = style.k(), S = style.tile_px, cols = atlas_columns(k), rows = atlas_rows(k);
  const Palette pal = make_palette(style);
  RgbImage img;
  img.width = cols * S;
  img.height = rows * S;
  img.rgb.assign(std::size_t(img.width) * img.height * 3, 0);
  const std::size_t stride = std::size_t(img.width) * 3;
  const int n = tile_count(k);
  detail::parallel_rows(rows, [&](int r) {
    for (int c = 0; c < cols; ++c) {
      const int index = r * cols + c;
      if (index >= n) break;
      draw_tile(style, pal, index, img.rgb.data() + std::size_t(r) * S * stride + std::size_t(c) * S * 3, stride);
    }
  }, 1);
  return img;
}

// ---- maps --------------------------------------------------------------------------------------

TileCorners TileMap::corners(int u, int v) const {
  const std::size_t w = std::size_t(tiles_x) + 1;
  auto at = [&](int a, int b) { return int(corner_v[std::size_t(b) * w + std::size_t(a)]); };
  return {at(u, v), at(u + 1, v), at(u, v + 1), at(u + 1, v + 1)};
}

void choose_tiles(TileMap& m, std::uint64_t seed, double saddle_variants, double solid_variants) {
  const int k = m.style.k();
  if (m.tiles_x < 1 || m.tiles_z < 1 || m.corner_v.size() != std::size_t(m.tiles_x + 1) * std::size_t(m.tiles_z + 1))
    throw Error("tilemap", "corner grid does not match " + std::to_string(m.tiles_x) + "x" + std::to_string(m.tiles_z) + " tiles");
  m.tile_t.assign(std::size_t(m.tiles_x) * m.tiles_z, 0);
  const std::uint64_t s_saddle = hash64(seed, 0x534144444C45ull), s_solid = hash64(seed, 0x534F4C4944ull);
  detail::parallel_rows(m.tiles_z, [&](int v) {
    for (int u = 0; u < m.tiles_x; ++u) {
      const TileCorners c = m.corners(u, v);
      int index = tile_index(c, k);
      if (is_saddle(c) && unit_double(hash64(s_saddle, std::uint64_t(u), std::uint64_t(v))) < saddle_variants)
        index = saddle_variant_index(c, k);
      else if (c.tl == c.tr && c.tl == c.bl && c.tl == c.br &&
               unit_double(hash64(s_solid, std::uint64_t(u), std::uint64_t(v))) < solid_variants)
        index = solid_variant_index(c.tl, k);
      m.tile_t[std::size_t(v) * m.tiles_x + u] = std::uint32_t(index);
    }
  });
}

RgbImage render_map(const TileMap& m, const RgbImage& atlas) {
  const int k = m.style.k(), S = m.style.tile_px, cols = atlas_columns(k);
  if (atlas.width != cols * S || atlas.height != atlas_rows(k) * S)
    throw Error("tilemap", "atlas is " + std::to_string(atlas.width) + "x" + std::to_string(atlas.height) + ", expected " +
                               std::to_string(cols * S) + "x" + std::to_string(atlas_rows(k) * S));
  RgbImage img;
  img.width = m.tiles_x * S;
  img.height = m.tiles_z * S;
  img.rgb.resize(std::size_t(img.width) * img.height * 3);
  const std::size_t stride = std::size_t(img.width) * 3, astride = std::size_t(atlas.width) * 3;
  const std::size_t n = std::size_t(tile_count(k));
  detail::parallel_rows(m.tiles_z, [&](int v) {
    for (int u = 0; u < m.tiles_x; ++u) {
      const std::uint32_t id = m.tile_t[std::size_t(v) * m.tiles_x + u];
      if (id >= n) throw Error("tilemap", "tile index " + std::to_string(id) + " out of range");
      const std::size_t ax = std::size_t(id % cols) * S * 3, ay = std::size_t(id / cols) * S;
      for (int y = 0; y < S; ++y)
        std::memcpy(img.rgb.data() + (std::size_t(v) * S + y) * stride + std::size_t(u) * S * 3,
                    atlas.rgb.data() + (ay + y) * astride + ax, std::size_t(S) * 3);
    }
  });
  return img;
}

// ---- Tiled export ------------------------------------------------------------------------------

namespace {

std::string xml_escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&apos;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string hex_color(const Rgb& c) { return write_color(c).get<std::string>(); }

std::string type_name(const TileStyle& s, int t) {
  const std::string& n = s.types[std::size_t(t)].name;
  return n.empty() ? "type " + std::to_string(t) : n;
}

// Tiled's corner wangid: top, top-right, right, bottom-right, bottom, bottom-left, left, top-left;
// colours are 1-based, 0 = none.
std::string wangid(const TileCorners& c) {
  return "0," + std::to_string(c.tr + 1) + ",0," + std::to_string(c.br + 1) + ",0," + std::to_string(c.bl + 1) + ",0," +
         std::to_string(c.tl + 1);
}

constexpr const char* kTiledVersion = "1.8.2";

void check_map(const TileMap& m) {
  const std::size_t n = std::size_t(tile_count(m.style.k()));
  if (m.tile_t.size() != std::size_t(m.tiles_x) * std::size_t(m.tiles_z))
    throw Error("tilemap", "tile grid does not match " + std::to_string(m.tiles_x) + "x" + std::to_string(m.tiles_z));
  for (std::uint32_t id : m.tile_t)
    if (id >= n) throw Error("tilemap", "tile index " + std::to_string(id) + " out of range");
}

}  // namespace

std::string encode_tsx(const TileStyle& s, const std::string& image) {
  validate_style(s, "");
  const int k = s.k(), S = s.tile_px, cols = atlas_columns(k), n = tile_count(k);
  std::string o;
  o.reserve(std::size_t(n) * 48 + 1024);
  o += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  o += "<tileset version=\"1.8\" tiledversion=\"" + std::string(kTiledVersion) + "\" name=\"relief-terrain\" tilewidth=\"" +
       std::to_string(S) + "\" tileheight=\"" + std::to_string(S) + "\" tilecount=\"" + std::to_string(n) +
       "\" columns=\"" + std::to_string(cols) + "\">\n";
  o += " <image source=\"" + xml_escape(image) + "\" width=\"" + std::to_string(cols * S) + "\" height=\"" +
       std::to_string(atlas_rows(k) * S) + "\"/>\n";
  o += " <wangsets>\n";
  o += "  <wangset name=\"terrain\" type=\"corner\" tile=\"" + std::to_string(tile_index({k - 1, k - 1, k - 1, k - 1}, k)) + "\">\n";
  for (int t = 0; t < k; ++t)
    o += "   <wangcolor name=\"" + xml_escape(type_name(s, t)) + "\" color=\"" + hex_color(s.types[std::size_t(t)].color) +
         "\" tile=\"" + std::to_string(tile_index({t, t, t, t}, k)) + "\" probability=\"1\"/>\n";
  for (int i = 0; i < n; ++i)
    o += "   <wangtile tileid=\"" + std::to_string(i) + "\" wangid=\"" + wangid(tile_corners(i, k)) + "\"/>\n";
  o += "  </wangset>\n </wangsets>\n</tileset>\n";
  return o;
}

namespace {

// The map's tiles as Tiled global ids (index + 1, firstgid 1), one row of the map per line, each
// line after `indent`, commas between all ids (TMX CSV data and TMJ's data array alike).
void append_gid_rows(std::string& o, const TileMap& m, const char* indent) {
  for (int v = 0; v < m.tiles_z; ++v) {
    o += indent;
    for (int u = 0; u < m.tiles_x; ++u) {
      o += std::to_string(m.tile_t[std::size_t(v) * m.tiles_x + u] + 1);
      if (u + 1 < m.tiles_x || v + 1 < m.tiles_z) o += ',';
    }
    o += '\n';
  }
}

}  // namespace

std::string encode_tmx(const TileMap& m, const std::string& tsx) {
  check_map(m);
  const std::string W = std::to_string(m.tiles_x), H = std::to_string(m.tiles_z), S = std::to_string(m.style.tile_px);
  std::string o;
  o.reserve(m.tile_t.size() * 6 + 1024);
  o += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  o += "<map version=\"1.8\" tiledversion=\"" + std::string(kTiledVersion) +
       "\" orientation=\"orthogonal\" renderorder=\"right-down\" width=\"" + W + "\" height=\"" + H + "\" tilewidth=\"" +
       S + "\" tileheight=\"" + S + "\" infinite=\"0\" nextlayerid=\"2\" nextobjectid=\"1\">\n";
  o += " <tileset firstgid=\"1\" source=\"" + xml_escape(tsx) + "\"/>\n";
  o += " <layer id=\"1\" name=\"terrain\" width=\"" + W + "\" height=\"" + H + "\">\n  <data encoding=\"csv\">\n";
  append_gid_rows(o, m, "");
  o += "</data>\n </layer>\n</map>\n";
  return o;
}

std::string encode_tmj(const TileMap& m, const std::string& tsx) {
  check_map(m);
  // Built by hand (not via json::dump) to keep one row of the map per line.
  std::string o;
  o.reserve(m.tile_t.size() * 6 + 1024);
  const std::string W = std::to_string(m.tiles_x), H = std::to_string(m.tiles_z), S = std::to_string(m.style.tile_px);
  o += "{\n \"type\": \"map\",\n \"version\": \"1.8\",\n \"tiledversion\": \"" + std::string(kTiledVersion) + "\",\n";
  o += " \"orientation\": \"orthogonal\",\n \"renderorder\": \"right-down\",\n";
  o += " \"width\": " + W + ",\n \"height\": " + H + ",\n \"tilewidth\": " + S + ",\n \"tileheight\": " + S + ",\n";
  o += " \"infinite\": false,\n \"compressionlevel\": -1,\n \"nextlayerid\": 2,\n \"nextobjectid\": 1,\n";
  o += " \"tilesets\": [{\"firstgid\": 1, \"source\": " + json(tsx).dump() + "}],\n";
  o += " \"layers\": [{\n  \"id\": 1,\n  \"name\": \"terrain\",\n  \"type\": \"tilelayer\",\n  \"x\": 0,\n  \"y\": 0,\n";
  o += "  \"width\": " + W + ",\n  \"height\": " + H + ",\n  \"opacity\": 1,\n  \"visible\": true,\n  \"data\": [\n";
  append_gid_rows(o, m, "   ");
  o += "  ]\n }]\n}\n";
  return o;
}

std::string encode_tile_csv(const TileMap& m) {
  check_map(m);
  std::string o;
  o.reserve(m.tile_t.size() * 5);
  for (int v = 0; v < m.tiles_z; ++v) {
    for (int u = 0; u < m.tiles_x; ++u) {
      if (u) o += ',';
      o += std::to_string(m.tile_t[std::size_t(v) * m.tiles_x + u]);
    }
    o += '\n';
  }
  return o;
}

std::vector<Level> default_tile_types() {
  return {
      {0.30, rgb_hex(0x1d4877), "deep water"}, {0.40, rgb_hex(0x3a7cb8), "water"},  {0.43, rgb_hex(0xd8c88e), "sand"},
      {0.58, rgb_hex(0x6b9b45), "grass"},      {0.74, rgb_hex(0x3c6b32), "forest"}, {1.00, rgb_hex(0x8a8178), "rock"},
  };
}

}  // namespace relief
