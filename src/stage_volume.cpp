// The volume stages: "volume" (the band's voxel size, chunks and closing), "overhangs" (a 3D warp
// of the surface on steep ground) and "caves" (cheese chambers, spaghetti and noodle tunnels).
// They change no layer: each leaves (a copy of) the terrain's VolumeSpec with its part added, and the
// volume writers (caves.glb, caves.obj, caves.vdb) evaluate the density chunk by chunk
// (relief/volume.hpp, which defines the density these parameters enter).
#include <algorithm>

#include "relief/volume.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

const ChoiceNames<NoiseBasis>& basis3_names() {
  static const ChoiceNames<NoiseBasis> n = {{NoiseBasis::Gradient, "gradient"}, {NoiseBasis::Simplex, "simplex"}};
  return n;
}

// The terrain's spec to extend: a copy of the current one, or the defaults.
VolumeSpec current(const Terrain& t) { return t.volume ? *t.volume : VolumeSpec{}; }

NoiseSettings noise3(NoiseBasis basis, int octaves, double wavelength_m, std::uint64_t seed) {
  NoiseSettings s;
  s.basis = basis;
  s.fractal = octaves > 1 ? Fractal::Fbm : Fractal::None;
  s.octaves = octaves;
  s.frequency = 1.0 / wavelength_m;
  s.seed = seed;
  return s;
}

// ---- volume -------------------------------------------------------------------------------------

struct VolumeParams {
  double voxel_m = 0;
  int chunk = 32;
  double base_m = 20;
  bool closed = true;
  Rgb rock_color = rgb_hex(0x6b6157);
};

Table<VolumeParams> volume_table() {
  using P = VolumeParams;
  return {{
      param(&P::voxel_m, "voxel_m", 0, 1000, "m", "Voxel size of the density band (0 = the height samples' spacing)"),
      param(&P::chunk, "chunk", 8, 128, "cells", "Cells per chunk edge (one mesh node per chunk)"),
      param(&P::base_m, "base_m", 0, 10000, "m", "Rock kept below the lowest surface point when the volume is closed"),
      param(&P::closed, "closed", 0, 1, "", "Close the volume with walls at the world's edge and a flat base (watertight)"),
      color(&P::rock_color, "rock_color", "Colour of cliffs, undersides and cave walls", Effect::Regenerate),
  }};
}

void volume_apply(Terrain& t, const VolumeParams& p, const Context& ctx) {
  VolumeSpec s = current(t);
  s.path = "stages[" + std::to_string(ctx.stage_index) + "]";
  s.voxel_m = p.voxel_m;
  s.chunk = p.chunk;
  s.base_m = p.base_m;
  s.closed = p.closed;
  s.rock_color[0] = p.rock_color.r;
  s.rock_color[1] = p.rock_color.g;
  s.rock_color[2] = p.rock_color.b;
  t.volume = std::make_shared<const VolumeSpec>(std::move(s));
}

// ---- overhangs ----------------------------------------------------------------------------------

struct OverhangParams {
  double strength_m = 12;
  double wavelength_m = 60;
  int octaves = 2;
  NoiseBasis basis = NoiseBasis::Gradient;
  double min_slope_deg = 35;
  double vertical = 1.0;
  std::string mask;
  int salt = 0;
};

Table<OverhangParams> overhang_table() {
  using P = OverhangParams;
  return {{
      param(&P::strength_m, "strength_m", 0, 1000, "m", "Largest horizontal displacement of the surface (how far cliffs lean out)"),
      param(&P::wavelength_m, "wavelength_m", 1, 100000, "m", "Wavelength of the warp noise's first octave"),
      param(&P::octaves, "octaves", 1, 8, "", "Octaves of the warp noise"),
      choice(&P::basis, "basis", basis3_names(), "3D noise basis: gradient (fastest) or simplex"),
      param(&P::min_slope_deg, "min_slope_deg", 0, 89, "deg", "Slope where the warp starts; full strength 20° steeper"),
      param(&P::vertical, "vertical", 0.05, 20, "", "Vertical frequency factor of the warp (< 1: taller columns and arches)"),
      text(&P::mask, "mask", "Optional one-channel layer (0..1) multiplying the warp (\"\" = none), e.g. a biome mask"),
      param(&P::salt, "salt", 0, 1000000, "", "Varies this stage's noise without changing the recipe seed"),
  }};
}

void overhang_apply(Terrain& t, const OverhangParams& p, const Context& ctx) {
  if (!p.mask.empty()) {
    const std::string path = "stages[" + std::to_string(ctx.stage_index) + "].mask";
    auto it = t.layers.find(p.mask);
    if (it == t.layers.end()) throw Error(path, "expected an existing one-channel layer, got '" + p.mask + "' (no such layer)");
    if (it->second.channels != 1)
      throw Error(path, "expected a one-channel layer, got '" + p.mask + "' with " + std::to_string(it->second.channels) + " channels");
  }
  VolumeSpec s = current(t);
  OverhangSpec o;
  o.noise = noise3(p.basis, p.octaves, p.wavelength_m, ctx.stage_seed(std::uint64_t(p.salt)));
  o.strength_m = p.strength_m;
  o.min_slope_deg = p.min_slope_deg;
  o.vertical = p.vertical;
  o.mask = p.mask;
  s.overhangs.push_back(std::move(o));
  t.volume = std::make_shared<const VolumeSpec>(std::move(s));
}

// ---- caves --------------------------------------------------------------------------------------

struct CaveParams {
  bool cheese = true;
  double cheese_threshold = 0.45;
  double cheese_wavelength_m = 90;
  double cheese_stretch = 2.0;
  bool spaghetti = true;
  double spaghetti_radius = 0.07;
  double spaghetti_wavelength_m = 160;
  bool noodle = true;
  double noodle_radius = 0.035;
  double noodle_wavelength_m = 48;
  NoiseBasis basis = NoiseBasis::Gradient;
  double cover_m = 6;
  double max_depth_m = 60;
  double entrances = 0.15;
  double entrance_wavelength_m = 300;
  bool flooded = false;
  int salt = 0;
};

Table<CaveParams> cave_table() {
  using P = CaveParams;
  return {{
      param(&P::cheese, "cheese", 0, 1, "", "Large chambers where one 3D noise exceeds the threshold"),
      param(&P::cheese_threshold, "cheese_threshold", -1, 1, "", "Chamber threshold (lower: more and larger chambers)"),
      param(&P::cheese_wavelength_m, "cheese_wavelength_m", 1, 100000, "m", "Wavelength of the chamber noise"),
      param(&P::cheese_stretch, "cheese_stretch", 0.1, 10, "", "Vertical frequency factor of the chambers (> 1: flatter)"),
      param(&P::spaghetti, "spaghetti", 0, 1, "", "Long tunnels where two 3D noises are both near zero"),
      param(&P::spaghetti_radius, "spaghetti_radius", 0, 1, "", "Tunnel radius in noise units (about radius × wavelength / 2π metres)"),
      param(&P::spaghetti_wavelength_m, "spaghetti_wavelength_m", 1, 100000, "m", "Wavelength of the tunnel noises"),
      param(&P::noodle, "noodle", 0, 1, "", "Thin winding passages (like spaghetti, thinner and at a higher frequency)"),
      param(&P::noodle_radius, "noodle_radius", 0, 1, "", "Passage radius in noise units"),
      param(&P::noodle_wavelength_m, "noodle_wavelength_m", 1, 100000, "m", "Wavelength of the passage noises"),
      choice(&P::basis, "basis", basis3_names(), "3D noise basis: gradient (fastest) or simplex"),
      param(&P::cover_m, "cover_m", 0, 10000, "m", "Rock kept between caves and the surface (except at entrances)"),
      param(&P::max_depth_m, "max_depth_m", 0, 10000, "m", "Nothing is carved deeper than this below the local surface"),
      param(&P::entrances, "entrances", 0, 1, "", "How much of the surface lets tunnels break through (0 = sealed caves)"),
      param(&P::entrance_wavelength_m, "entrance_wavelength_m", 1, 100000, "m", "Wavelength of the noise that places entrances"),
      param(&P::flooded, "flooded", 0, 1, "", "Carve below the sea surface too (flooded caves)"),
      param(&P::salt, "salt", 0, 1000000, "", "Varies this stage's noise without changing the recipe seed"),
  }};
}

void cave_validate(const CaveParams& p, const std::string& path) {
  if (!p.cheese && !p.spaghetti && !p.noodle)
    throw Error(path + ".cheese", "expected at least one of cheese, spaghetti, noodle to be true, got all false");
}

void cave_apply(Terrain& t, const CaveParams& p, const Context& ctx) {
  VolumeSpec s = current(t);
  CaveSpec c;
  const std::uint64_t base = ctx.stage_seed(std::uint64_t(p.salt));
  c.has_cheese = p.cheese;
  c.has_spaghetti = p.spaghetti;
  c.has_noodle = p.noodle;
  c.cheese = noise3(p.basis, 2, p.cheese_wavelength_m, base);
  c.spaghetti = noise3(p.basis, 1, p.spaghetti_wavelength_m, base + 16);
  c.noodle = noise3(p.basis, 1, p.noodle_wavelength_m, base + 32);
  c.cheese_threshold = p.cheese_threshold;
  c.cheese_stretch = p.cheese_stretch;
  c.spaghetti_radius = p.spaghetti_radius;
  c.noodle_radius = p.noodle_radius;
  c.cover_m = p.cover_m;
  c.max_depth_m = p.max_depth_m;
  c.entrances = p.entrances;
  NoiseSettings e;
  e.basis = NoiseBasis::Gradient;
  e.fractal = Fractal::Fbm;
  e.octaves = 2;
  e.frequency = 1.0 / p.entrance_wavelength_m;
  e.seed = base + 48;
  c.entrance = e;
  c.flooded = p.flooded;
  s.caves.push_back(std::move(c));
  t.volume = std::make_shared<const VolumeSpec>(std::move(s));
}

}  // namespace

StageDef volume() {
  return make_stage<VolumeParams>("volume", "Density band for caves and overhangs: voxel size, chunks, closed walls",
                                  pointwise(), volume_table(), volume_apply);
}
StageDef overhangs() {
  return make_stage<OverhangParams>("overhangs", "3D warp of steep ground: leaning cliffs, undercuts, arches (volume)",
                                    pointwise(), overhang_table(), overhang_apply);
}
StageDef caves() {
  return make_stage<CaveParams>("caves", "Cheese chambers, spaghetti and noodle tunnels carved into the volume",
                                pointwise(), cave_table(), cave_apply, cave_validate);
}

}  // namespace relief::stages
