// The "noise" stage: fractal noise written into a layer (default "height"), combined with what the
// layer holds by set / add / multiply / max / min. A pointwise stage: every sample is a pure
// function of its world position, the recipe seed and the parameters.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "relief/noise.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

struct NoiseParams {
  std::string layer = "height";
  std::string basis = "gradient";
  std::string fractal = "fbm";
  int octaves = 6;
  double frequency = 4.0;  // cycles across the world width (first octave)
  double lacunarity = 2.0;
  double persistence = 0.5;
  double amplitude = 1.0;
  double offset = 0.0;
  std::string blend = "set";
  double scale_x = 1.0, scale_z = 1.0;
  std::string cellular = "f1";
  double jitter = 1.0;
  bool periodic = false;
  double warp = 0.0;             // in wavelengths of the first octave
  double warp_frequency = 1.0;   // relative to the first octave
  int salt = 0;
};

Table<NoiseParams> table() {
  using P = NoiseParams;
  return {{
      text(&P::layer, "layer", "Layer to write (height, moisture, temperature, …)"),
      choice(&P::basis, "basis", {"gradient", "perlin", "simplex", "value", "cellular"},
             "Noise basis: gradient (Perlin-equivalent, hashed, fastest), improved Perlin (seeded permutation), "
             "OpenSimplex2, value or cellular (Worley)"),
      choice(&P::fractal, "fractal", {"none", "fbm", "ridged", "billow"},
             "How octaves combine: none (one octave), fBm, ridged (sharp crests), billow (puffy)"),
      param(&P::octaves, "octaves", 1, 16, "", "Number of octaves summed"),
      param(&P::frequency, "frequency", 0.01, 1000, "cycles/world", "Cycles of the first octave across the world width"),
      param(&P::lacunarity, "lacunarity", 1, 4, "", "Frequency ratio between successive octaves"),
      param(&P::persistence, "persistence", 0, 1, "", "Amplitude ratio between successive octaves (gain)"),
      param(&P::amplitude, "amplitude", 0, 4, "", "Scale of the noise around its mid value"),
      param(&P::offset, "offset", -1, 1, "", "Added to the result (set: 0 puts the mid value at 0.5)"),
      choice(&P::blend, "blend", {"set", "add", "multiply", "max", "min"},
             "How the noise combines with the layer's current values"),
      param(&P::scale_x, "scale_x", 0.05, 20, "", "Anisotropy: frequency multiplier along x"),
      param(&P::scale_z, "scale_z", 0.05, 20, "", "Anisotropy: frequency multiplier along z"),
      choice(&P::cellular, "cellular", {"f1", "f2", "f2_minus_f1", "cell_value"},
             "Cellular basis output: distance to nearest (F1), second nearest (F2), F2−F1 or cell value"),
      param(&P::jitter, "jitter", 0, 1, "", "Cellular feature point jitter within its cell"),
      param(&P::periodic, "periodic", 0, 1, "", "Make the noise tile across the world extent (gradient, perlin, value, cellular)"),
      param(&P::warp, "warp", 0, 4, "wavelengths", "Domain warp strength in first-octave wavelengths (0 = off)"),
      param(&P::warp_frequency, "warp_frequency", 0.1, 16, "", "Warp noise frequency relative to the first octave"),
      param(&P::salt, "salt", 0, 1000000, "", "Varies this stage's noise without changing the recipe seed"),
  }};
}

NoiseSettings settings_for(const NoiseParams& p, const Frame& f, std::uint64_t seed) {
  NoiseSettings s;
  s.basis = noise_basis_named(p.basis, "basis");
  s.fractal = fractal_named(p.fractal, "fractal");
  s.octaves = p.octaves;
  s.frequency = p.frequency / f.world_width_m;
  s.lacunarity = p.lacunarity;
  s.persistence = p.persistence;
  s.scale_x = p.scale_x;
  s.scale_z = p.scale_z;
  s.cellular = p.cellular == "f1" ? CellularReturn::F1 : p.cellular == "f2" ? CellularReturn::F2
               : p.cellular == "f2_minus_f1" ? CellularReturn::F2MinusF1 : CellularReturn::CellValue;
  s.jitter = p.jitter;
  if (p.periodic) {
    s.period_x_m = f.world_width_m;
    s.period_z_m = f.world_depth_m;
  }
  s.warp_m = p.warp / s.frequency;
  s.warp_frequency = s.frequency * p.warp_frequency;
  s.seed = seed;
  return s;
}

void validate(const NoiseParams& p, const std::string& path) {
  if (p.layer.empty()) throw Error(path + ".layer", "expected a layer name, got \"\"");
  if (p.periodic && p.basis == "simplex")
    throw Error(path + ".periodic", "periodic noise needs basis gradient, perlin, value or cellular, got simplex");
}

// A row stage (stage.hpp: RowKernel): Noise::row evaluates a whole row, then the blend folds it
// into the layer's row while both are in cache. The x-only terms of the frame's columns are
// computed once in prepare() and reused by every row (NoiseColumns; same values as plain rows).
struct NoiseKernel final : RowKernel {
  Noise noise;
  NoiseColumns columns;
  Frame frame;
  float amp = 1.0f, off = 0.0f;
  int mode = 0;  // set, add, multiply, max, min
  NoiseKernel(std::string layer, Noise n) : RowKernel(std::move(layer)), noise(std::move(n)) {}
  void apply_row(int j, float* row) const override {
    const int nx = frame.nx;
    thread_local std::vector<float> buf;
    buf.resize(std::size_t(nx));
    noise.row(frame.z_m(j), columns, buf.data());
    for (int i = 0; i < nx; ++i) {
      const float v = buf[std::size_t(i)];
      const float u = off + amp * (0.5f + 0.5f * v);  // [-1,1] → [0,1], scaled and offset
      float h;
      switch (mode) {
        case 0: h = u; break;
        case 1: h = row[i] + off + 0.5f * amp * v; break;
        case 2: h = row[i] * u; break;
        case 3: h = std::max(row[i], u); break;
        default: h = std::min(row[i], u); break;
      }
      row[i] = std::clamp(h, 0.0f, 1.0f);
    }
  }
};

std::unique_ptr<RowKernel> prepare(Terrain& t, const NoiseParams& p, const Context& ctx) {
  const Frame& f = t.frame;
  Noise noise = [&] {
    try {
      return Noise(settings_for(p, f, ctx.stage_seed(std::uint64_t(p.salt))));
    } catch (const Error& e) {
      // Settings derived from the world (frequency per metre, period) are checked here.
      throw Error("stages[" + std::to_string(ctx.stage_index) + "]", e.what());
    }
  }();
  const bool existed = t.has(p.layer) && t.layers[p.layer].channels == 1;
  t.layer(p.layer, 1);  // created zero-filled (or reshaped) if needed
  auto k = std::make_unique<NoiseKernel>(p.layer, std::move(noise));
  k->frame = f;
  k->columns = k->noise.columns(f.ix0, f.cell_m(), f.nx);
  k->amp = float(p.amplitude);
  k->off = float(p.offset);
  k->mode = p.blend == "set" ? 0 : p.blend == "add" ? 1 : p.blend == "multiply" ? 2 : p.blend == "max" ? 3 : 4;
  // Multiplying a layer that did not exist multiplies by 1: that is `set` (same bits).
  if (!existed && k->mode == 2) k->mode = 0;
  return k;
}

}  // namespace

StageDef noise() {
  StageDef d = make_row_stage<NoiseParams>("noise", "Fractal noise (gradient, Perlin, simplex, value, cellular) into a layer",
                                           table(), prepare, validate);
  d.memory.layer_param = "layer";  // writes the layer its `layer` parameter names
  return d;
}

}  // namespace relief::stages
