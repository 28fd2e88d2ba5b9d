// The "amplify" stage: fractal detail added to a coarse input (a sketch, a 30 m elevation model)
// while keeping its large forms. The detail is zero-mean fBm whose first octave has the wavelength
// `wavelength_m` (about the input's own resolution, so what the sketch says stays) and whose
// amplitude in metres follows the input's local slope: `amplitude_m` on ground as steep as
// `slope_ref` (rise over run) or steeper, `flat` times that on level ground (Houdini's terrain
// up-sampling keeps flats flat and roughens slopes the same way). Ridges and valleys stay where the
// input put them: the detail is shorter than the forms and averages out over them.
//   h' = h + amp(slope) · n(x, z) / height_m,   amp = amplitude_m · (flat + (1 − flat) · min(1, s / slope_ref))
// The slope is the central difference in metres of the input (one-sided at the border): halo 1.
#include <algorithm>
#include <cmath>

#include "parallel.hpp"
#include "relief/noise.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

struct AmplifyParams {
  std::string layer = "height";
  double wavelength_m = 250;
  int octaves = 6;
  double persistence = 0.5;
  double amplitude_m = 30;
  double slope_ref = 0.5;
  double flat = 0.25;
  int salt = 0;
};

Table<AmplifyParams> table() {
  using P = AmplifyParams;
  return Table<P>{{
      text(&P::layer, "layer", "Layer to amplify (normalised elevation)"),
      param(&P::wavelength_m, "wavelength_m", 1, 100000, "m", "Wavelength of the first detail octave (about the input's resolution)"),
      param(&P::octaves, "octaves", 1, 16, "", "Detail octaves, each half the wavelength of the one before"),
      param(&P::persistence, "persistence", 0, 1, "", "Amplitude ratio between octaves"),
      param(&P::amplitude_m, "amplitude_m", 0, 10000, "m", "Detail amplitude on slopes of slope_ref or steeper"),
      param(&P::slope_ref, "slope_ref", 0.001, 100, "", "Slope (rise over run) from which the detail has its full amplitude"),
      param(&P::flat, "flat", 0, 1, "", "Share of the amplitude kept on level ground"),
      param(&P::salt, "salt", 0, 1000000, "", "Varies this stage's noise without changing the recipe seed"),
  }};
}

void apply(Terrain& t, const AmplifyParams& p, const Context& ctx) {
  const std::string stage = "stages[" + std::to_string(ctx.stage_index) + "]";
  const Frame& f = t.frame;
  auto it = t.layers.find(p.layer);
  if (it == t.layers.end() || it->second.channels != 1)
    throw Error(stage + ".layer", "no one-channel layer '" + p.layer + "' to amplify (a stage before this one must write it)");
  const std::vector<float> in = it->second.data;
  std::vector<float>& out = it->second.data;
  NoiseSettings s;
  s.basis = NoiseBasis::Gradient;
  s.octaves = p.octaves;
  s.frequency = 1.0 / p.wavelength_m;
  s.persistence = p.persistence;
  s.seed = ctx.stage_seed(std::uint64_t(p.salt));
  const Noise noise(s);
  const NoiseColumns columns = noise.columns(f.ix0, f.cell_m(), f.nx);  // x-only terms, once per run
  const int nx = f.nx, nz = f.nz;
  const double cell = f.cell_m(), hm = f.height_m;
  detail::parallel_rows(nz, [&](int j) {
    thread_local std::vector<float> n;
    n.resize(std::size_t(nx));
    noise.row(f.z_m(j), columns, n.data());
    const int jt = std::max(j - 1, 0), jb = std::min(j + 1, nz - 1);
    for (int i = 0; i < nx; ++i) {
      const int il = std::max(i - 1, 0), ir = std::min(i + 1, nx - 1);
      auto H = [&](int a, int b) { return double(in[std::size_t(b) * nx + a]); };
      const double dx = (H(ir, j) - H(il, j)) * hm / ((ir - il) * cell), dz = (H(i, jb) - H(i, jt)) * hm / ((jb - jt) * cell);
      const double slope = std::sqrt(dx * dx + dz * dz);
      const double amp = p.amplitude_m * (p.flat + (1 - p.flat) * std::min(1.0, slope / p.slope_ref));
      out[std::size_t(j) * nx + i] = float(std::clamp(H(i, j) + amp * double(n[std::size_t(i)]) / hm, 0.0, 1.0));
    }
  });
}

}  // namespace

StageDef amplify() {
  StageDef d = make_stage<AmplifyParams>("amplify", "Fractal detail on a coarse input, following its slopes, keeping its large forms",
                                         neighbourhood(1), table(), apply);
  d.memory.scratch_per_sample = 4;
  return d;
}

}  // namespace relief::stages
