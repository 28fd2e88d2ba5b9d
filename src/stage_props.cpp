// The `props` stage: seed 003's prop placement (§3.2.3, figure 6).
//
// A fixed number of attempts, each at a seeded uniform position of the world. An attempt fails in
// the sea, on the volcano (where the 'volcano' footprint layer is > 0), on slopes steeper than
// max_slope_deg, or where no prop type allowed in the sample's biome passes its own noise test
// (its noise field n ∈ [0, 1] at the position must reach its tolerance); among the passing types
// one is chosen by hash. The chosen prop is then rejected if an earlier candidate (a lower attempt
// number that passed every test above, placed or not) is closer than the larger of their two
// spacings: B. Matérn's type II hard-core thinning ("Spatial Variation", 1960; 2nd ed. Springer
// 1986, §3.6), with the attempt number as the mark. Passing noise "hills" group similar props into
// clusters; each type has its own field, so two types cluster independently of each other.
//
// Determinism: the candidate of attempt k (position, type, rotation, scale) is a pure function of
// (seed, k) and the terrain within 2 samples of its position (bilinear height, nearest biome and
// volcano samples, the central-difference slope of its nearest sample; positions are taken to world
// grid units before the window's offset is subtracted, features.hpp), computed in parallel; a
// candidate survives unless an earlier candidate lies within the largest spacing S of it. Props are
// emitted in world row-major order of their positions (z, then x). So the result is the same for any thread count, and the stage is a
// neighbourhood stage (issue 18): a prop depends on the terrain within ceil(S / cell) + 2 samples
// of its position, and a window grown by that halo holds, for every position inside the original
// window, the same props as the whole map (world_points.hpp picks each tile's own).
// Before issue 18 a candidate was tested against placed props only (greedy, in attempt order),
// which chains across the whole map; Matérn's rule drops the few candidates that were blocked only
// by a candidate that was itself dropped (at the presets' densities, about λ·π·S² ≈ 0.1 % of them).
#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>
#include <vector>

#include "features.hpp"
#include "surface.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/noise.hpp"
#include "relief/random.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

struct PropType {
  std::string name = "tree";
  std::vector<std::string> biomes;
  double wavelength_m = 300;
  double tolerance = 0.55;
  double spacing_m = 6;
  double scale_min = 0.8, scale_max = 1.2;
};

std::vector<PropType> default_props() {
  return {
      PropType{"tree", {"forest", "plains", "hills"}, 320, 0.5, 7, 0.8, 1.3},
      PropType{"pine", {"mountains", "spiky_mountains", "hills", "forest"}, 260, 0.55, 6, 0.7, 1.2},
      PropType{"bush", {"plains", "hills", "forest", "desert"}, 160, 0.6, 3, 0.6, 1.1},
      PropType{"rock", {"mountains", "spiky_mountains", "plateau", "desert", "hills", "beach"}, 220, 0.62, 5, 0.5, 1.6},
      PropType{"cactus", {"desert"}, 200, 0.5, 8, 0.8, 1.4},
      PropType{"mushroom", {"plateau", "forest"}, 120, 0.6, 2.5, 0.5, 1.5},
  };
}

struct PropsParams {
  int attempts = 40000;
  std::vector<PropType> types = default_props();
  double rotation_deg = 360;
  double max_slope_deg = 40;
};

struct Candidate {
  int type = -1;  // −1: the attempt failed before the spacing test
  double x = 0, z = 0, e = 0, rot = 0, scale = 1;
};

void apply_props(Terrain& t, const PropsParams& p, const Context& ctx) {
  const Frame& fr = t.frame;
  const std::string path = "stages[" + std::to_string(ctx.stage_index) + "]";
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != fr.count()) throw Error("", "layer 'height' does not match the frame");
  const Layer* biome = t.has("biome") ? &t.get("biome") : nullptr;
  const Layer* volcano = t.has("volcano") ? &t.get("volcano") : nullptr;
  const std::size_t nt = p.types.size();
  // Allowed biome ids per type (an empty list: every biome).
  std::vector<std::vector<char>> allowed(nt);
  for (std::size_t k = 0; k < nt; ++k) {
    const PropType& pt = p.types[k];
    if (pt.biomes.empty()) continue;
    if (!biome || t.biomes.empty())
      throw Error(path + ".types[" + std::to_string(k) + "].biomes",
                  "names biomes, but there is no 'biome' layer: add a biomes or climate stage before props");
    allowed[k].assign(t.biomes.size(), 0);
    for (std::size_t b = 0; b < pt.biomes.size(); ++b) {
      int id = -1;
      for (std::size_t c = 0; c < t.biomes.size(); ++c)
        if (t.biomes[c].name == pt.biomes[b]) id = int(c);
      if (id < 0) {
        std::string list;
        for (auto& bi : t.biomes) list += (list.empty() ? "" : ", ") + bi.name;
        throw Error(path + ".types[" + std::to_string(k) + "].biomes[" + std::to_string(b) + "]",
                    "unknown biome \"" + pt.biomes[b] + "\"; this terrain has: " + list);
      }
      allowed[k][std::size_t(id)] = 1;
    }
  }
  const std::uint64_t seed = ctx.stage_seed();
  std::vector<Noise> noises;
  for (std::size_t k = 0; k < nt; ++k) {
    NoiseSettings s;
    s.basis = NoiseBasis::Perlin;
    s.fractal = Fractal::Fbm;
    s.octaves = 3;
    s.frequency = 1.0 / p.types[k].wavelength_m;
    s.seed = hash64(seed, 0x6e6f697365ull, k);
    noises.emplace_back(s);
  }
  const double max_tan = std::tan(p.max_slope_deg * 3.14159265358979323846 / 180.0);
  // The window's first and last samples' positions (as run()'s crop keeps points): at the world's
  // edges every window that reaches them has the same bounds as the whole map.
  const double x0 = fr.x0_m(), x1 = fr.x_m(fr.nx - 1), z0 = fr.z0_m(), z1 = fr.z_m(fr.nz - 1);
  std::vector<Candidate> cand(std::size_t(p.attempts));
  detail::parallel_rows(p.attempts, [&](int a) {
    Candidate& c = cand[std::size_t(a)];
    const std::uint64_t hk = hash64(seed, 0x70726f70ull, std::uint64_t(a));
    c.x = unit_double(hk) * fr.world_width_m;
    c.z = unit_double(mix64(hk)) * fr.world_depth_m;
    if (c.x < x0 || c.x > x1 || c.z < z0 || c.z > z1) return;
    c.e = detail::sample_bilinear(fr, h, c.x, c.z);
    if (c.e <= fr.sea_level) return;
    if (volcano && detail::sample_nearest(fr, *volcano, c.x, c.z) > 0.0f) return;
    if (p.max_slope_deg < 90.0) {
      const int i = int(std::clamp<std::int64_t>(std::llround(c.x / fr.cell_m()) - fr.ix0, 0, fr.nx - 1));
      const int j = int(std::clamp<std::int64_t>(std::llround(c.z / fr.cell_m()) - fr.iz0, 0, fr.nz - 1));
      const detail::Gradient g = detail::gradient_at(fr, h, i, j);
      if (std::hypot(g.dx, g.dz) > max_tan) return;
    }
    const int b = biome ? int(std::lround(detail::sample_nearest(fr, *biome, c.x, c.z))) : -1;
    int pass[64];
    int np = 0;
    for (std::size_t k = 0; k < nt && np < 64; ++k) {
      if (!allowed[k].empty() && (b < 0 || std::size_t(b) >= allowed[k].size() || !allowed[k][std::size_t(b)])) continue;
      const double n = std::clamp(0.5 + double(noises[k].at(c.x, c.z)), 0.0, 1.0);
      if (n >= p.types[k].tolerance) pass[np++] = int(k);
    }
    if (np == 0) return;
    const std::uint64_t hc = hash64(seed, 0x63686f6full, std::uint64_t(a));
    c.type = pass[std::min<std::uint64_t>(std::uint64_t(unit_double(hc) * np), std::uint64_t(np - 1))];
    const PropType& pt = p.types[std::size_t(c.type)];
    c.rot = p.rotation_deg * unit_double(mix64(hc));
    c.scale = pt.scale_min + (pt.scale_max - pt.scale_min) * unit_double(mix64(mix64(hc)));
  }, 256);
  // Matérn II thinning: a candidate survives unless an earlier candidate lies within the larger of
  // their spacings. A hash grid of cells of the largest spacing; each candidate looks at the 3 × 3
  // cells around its own.
  double cell = 1e-3;
  for (auto& pt : p.types) cell = std::max(cell, pt.spacing_m);
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> grid;
  auto key = [](std::int64_t a, std::int64_t b) { return (std::uint64_t(a) << 32) ^ std::uint64_t(std::uint32_t(b)); };
  for (std::size_t a = 0; a < cand.size(); ++a) {
    const Candidate& c = cand[a];
    if (c.type < 0) continue;
    grid[key(std::int64_t(std::floor(c.x / cell)), std::int64_t(std::floor(c.z / cell)))].push_back(a);
  }
  std::vector<char> keep(cand.size(), 0);
  detail::parallel_rows(p.attempts, [&](int ai) {
    const std::size_t a = std::size_t(ai);
    const Candidate& c = cand[a];
    if (c.type < 0) return;
    const double sp = p.types[std::size_t(c.type)].spacing_m;
    const auto gx = std::int64_t(std::floor(c.x / cell)), gz = std::int64_t(std::floor(c.z / cell));
    bool ok = true;
    for (std::int64_t dz = -1; dz <= 1 && ok; ++dz)
      for (std::int64_t dx = -1; dx <= 1 && ok; ++dx) {
        auto it = grid.find(key(gx + dx, gz + dz));
        if (it == grid.end()) continue;
        for (std::size_t q : it->second) {
          if (q >= a) break;  // each cell's list is in attempt order
          const Candidate& o = cand[q];
          const double need = std::max(sp, p.types[std::size_t(o.type)].spacing_m);
          if ((o.x - c.x) * (o.x - c.x) + (o.z - c.z) * (o.z - c.z) < need * need) {
            ok = false;
            break;
          }
        }
      }
    keep[a] = ok;
  }, 256);
  // Emitted in world row-major order of position (z, then x; attempt order for equal positions), an
  // order every window agrees on (world_points.hpp merges tiles' props by the same key).
  std::vector<std::size_t> placed;
  for (std::size_t a = 0; a < cand.size(); ++a)
    if (keep[a]) placed.push_back(a);
  std::stable_sort(placed.begin(), placed.end(), [&](std::size_t a, std::size_t b) {
    return cand[a].z != cand[b].z ? cand[a].z < cand[b].z : cand[a].x < cand[b].x;
  });
  for (std::size_t a : placed) {
    const Candidate& c = cand[a];
    Point pt;
    pt.kind = "prop";
    pt.type = p.types[std::size_t(c.type)].name;
    pt.x_m = c.x;
    pt.y_m = fr.y_m(c.e);
    pt.z_m = c.z;
    pt.rotation_deg = c.rot;
    pt.scale = c.scale;
    t.points.push_back(pt);
  }
}

// The largest spacing in samples, rounded up, plus the 2 samples a candidate's own tests read.
Reach props_reach(const PropsParams& p, const Frame& f) {
  double s = 0;
  for (auto& t : p.types) s = std::max(s, t.spacing_m);
  return neighbourhood(int(std::min(double(1 << 28), std::ceil(s / f.cell_m()))) + 2);
}

void validate_props(const PropsParams& p, const std::string& path) {
  for (std::size_t k = 0; k < p.types.size(); ++k) {
    const PropType& t = p.types[k];
    const std::string tp = path + ".types[" + std::to_string(k) + "]";
    if (t.name.empty()) throw Error(tp + ".name", "expected a non-empty name");
    for (std::size_t q = 0; q < k; ++q)
      if (p.types[q].name == t.name) throw Error(tp + ".name", "duplicate prop type \"" + t.name + "\"");
    if (t.scale_max < t.scale_min)
      throw Error(tp + ".scale_max", "expected at least scale_min (" + std::to_string(t.scale_min) + "), got " +
                                         std::to_string(t.scale_max));
  }
}

Table<PropType> prop_table() {
  using T = PropType;
  return {{
      text(&T::name, "name", "Prop type (written to props.json / props.csv)"),
      names(&T::biomes, "biomes", "Biomes (names in the biome legend) where it may grow; [] = every land biome"),
      param(&T::wavelength_m, "wavelength_m", 1.0, 1e6, "m", "Wavelength of its clustering noise (cluster size)"),
      param(&T::tolerance, "tolerance", 0.0, 1.0, "", "Placed only where its noise n (0..1) ≥ tolerance: higher = sparser clusters"),
      param(&T::spacing_m, "spacing_m", 0.0, 1e5, "m", "No prop closer than the larger of the two spacings"),
      param(&T::scale_min, "scale_min", 0.0, 1e3, "", "Smallest random scale"),
      param(&T::scale_max, "scale_max", 0.0, 1e3, "", "Largest random scale"),
  }};
}

}  // namespace

StageDef props() {
  using P = PropsParams;
  Table<P> table{{
      param(&P::attempts, "attempts", 0, 10000000, "", "Placement attempts over the whole world (fewer props are placed)"),
      records(&P::types, "types", prop_table(), 0, 64, "Prop types and their rules"),
      param(&P::rotation_deg, "rotation_deg", 0.0, 360.0, "deg", "Random rotation about +y in 0..rotation_deg"),
      param(&P::max_slope_deg, "max_slope_deg", 0.0, 90.0, "deg", "No props on steeper ground (90 = anywhere)"),
  }};
  return make_stage<P>("props",
                       "Props (seed 003): seeded attempts, rejected in the sea, on the volcano or too close; clustered by "
                       "per-type noise; appended to the terrain's points",
                       neighbourhood(props_reach(P{}, Frame{}).halo), std::move(table), apply_props, validate_props,
                       props_reach, "ceil(largest spacing_m / cell) + 2 samples");
}

}  // namespace relief::stages
