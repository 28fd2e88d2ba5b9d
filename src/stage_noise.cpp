// The "noise" stage: fractal noise written into a layer (default "height"), combined with what the
// layer holds by set / add / multiply / max / min. A pointwise stage: every sample is a pure
// function of its world position, the recipe seed and the parameters.
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "relief/noise.hpp"
#include "shared_tables.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

enum class Blend { Set, Add, Multiply, Max, Min };

struct NoiseParams {
  std::string layer = "height";
  detail::NoiseFields noise;  // basis, fractal, octaves, frequency (or wavelength_m), lacunarity, …
  double amplitude = 1.0;
  double offset = 0.0;
  Blend blend = Blend::Set;
  CellularReturn cellular = CellularReturn::F1;
  double jitter = 1.0;
  bool periodic = false;
  double warp = 0.0;             // in wavelengths of the first octave
  double warp_frequency = 1.0;   // relative to the first octave
  int salt = 0;
};

Table<NoiseParams> table() {
  using P = NoiseParams;
  Table<P> t{{text(&P::layer, "layer", "Layer to write (height, moisture, temperature, …)")}};
  embed(t.fields, &P::noise, detail::noise_fields_table());
  for (auto& f : std::vector<Field<P>>{
           param(&P::amplitude, "amplitude", 0, 4, "", "Scale of the noise around its mid value"),
           param(&P::offset, "offset", -1, 1, "", "Added to the result (set: 0 puts the mid value at 0.5)"),
           choice(&P::blend, "blend",
                  {{Blend::Set, "set"}, {Blend::Add, "add"}, {Blend::Multiply, "multiply"}, {Blend::Max, "max"}, {Blend::Min, "min"}},
                  "How the noise combines with the layer's current values"),
           choice(&P::cellular, "cellular",
                  {{CellularReturn::F1, "f1"}, {CellularReturn::F2, "f2"}, {CellularReturn::F2MinusF1, "f2_minus_f1"},
                   {CellularReturn::CellValue, "cell_value"}},
                  "Cellular basis output: distance to nearest (F1), second nearest (F2), F2−F1 or cell value"),
           param(&P::jitter, "jitter", 0, 1, "", "Cellular feature point jitter within its cell"),
           param(&P::periodic, "periodic", 0, 1, "", "Make the noise tile across the world extent (gradient, perlin, value, cellular)"),
           param(&P::warp, "warp", 0, 4, "wavelengths", "Domain warp strength in first-octave wavelengths (0 = off)"),
           param(&P::warp_frequency, "warp_frequency", 0.1, 16, "", "Warp noise frequency relative to the first octave"),
           param(&P::salt, "salt", 0, 1000000, "", "Varies this stage's noise without changing the recipe seed"),
       })
    t.fields.push_back(std::move(f));
  return t;
}

NoiseSettings settings_for(const NoiseParams& p, const Frame& f, std::uint64_t seed) {
  NoiseSettings s = p.noise.settings(f.world_width_m, seed);
  s.cellular = p.cellular;
  s.jitter = p.jitter;
  if (p.periodic) {
    s.period_x_m = f.world_width_m;
    s.period_z_m = f.world_depth_m;
  }
  s.warp_m = p.warp / s.frequency;
  s.warp_frequency = s.frequency * p.warp_frequency;
  return s;
}

void validate(const NoiseParams& p, const std::string& path) {
  if (p.layer.empty()) throw Error(path + ".layer", "expected a layer name, got \"\"");
  if (p.periodic && p.noise.basis == NoiseBasis::Simplex)
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
  Blend mode = Blend::Set;
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
        case Blend::Set: h = u; break;
        case Blend::Add: h = row[i] + off + 0.5f * amp * v; break;
        case Blend::Multiply: h = row[i] * u; break;
        case Blend::Max: h = std::max(row[i], u); break;
        case Blend::Min: default: h = std::min(row[i], u); break;
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
      // Settings derived from the world (frequency per metre, period) are checked here. The error
      // names the stage's field when the library's field is one (`stages[0].lacunarity`); the
      // others (period_x_m, warp_m: derived from the world) name the stage and keep the field
      // in the message.
      static const std::vector<ParamInfo> fields = table().infos();
      const std::string stage = "stages[" + std::to_string(ctx.stage_index) + "]";
      const bool ours = std::any_of(fields.begin(), fields.end(), [&](const ParamInfo& i) { return i.name == e.path(); });
      if (ours) throw Error(stage + "." + e.path(), e.message());
      throw Error(stage, e.what());
    }
  }();
  const bool existed = t.has(p.layer) && t.layers[p.layer].channels == 1;
  t.layer(p.layer, 1);  // created zero-filled (or reshaped) if needed
  auto k = std::make_unique<NoiseKernel>(p.layer, std::move(noise));
  k->frame = f;
  k->columns = k->noise.columns(f.ix0, f.cell_m(), f.nx);
  k->amp = float(p.amplitude);
  k->off = float(p.offset);
  k->mode = p.blend;
  // Multiplying a layer that did not exist multiplies by 1: that is `set` (same bits).
  if (!existed && k->mode == Blend::Multiply) k->mode = Blend::Set;
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
