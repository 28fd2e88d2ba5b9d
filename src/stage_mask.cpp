// The "mask" and "mix" stages: masks from the terrain, and two layers combined through a mask.
//
// mask: a one-channel layer in 0..1 from one `source`, in that source's units:
//   elevation  normalised elevation (pointwise)
//   slope      slope in degrees from central differences in metres, one-sided at the border (halo 1)
//   curvature  Laplacian of the height in metres, 1/m (five-point, clamped border; > 0 in hollows)
//   flow       drainage area in km² from a flow stage's 'flow' layer (which must exist)
//   coast      distance in metres from a land sample to the nearest sea sample (elevation below
//              sea_level); 0 in the sea. Exact Euclidean distance transform (Felzenszwalb and
//              Huttenlocher 2012, "Distance transforms of sampled functions"); global.
//   biome      1 where the 'biome' layer's id is one of `ids`, else 0 (hard edges)
// Band with soft edges: 1 inside [from, to], falling to 0 over `soft` beyond each end
// (smoothstep; soft 0 = a hard step); `invert` gives 1 − that.
// mix: into = a + mask·(b − a), mask clamped to 0..1 (pointwise).
#include <algorithm>
#include <cmath>
#include <limits>

#include "parallel.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

enum class Source { Elevation, Slope, Curvature, Flow, Coast, Biome };

struct MaskParams {
  std::string layer = "mask";
  Source source = Source::Elevation;
  double from = 0.5, to = 1e9;
  double soft = 0;
  bool invert = false;
  std::vector<int> ids;
};

Table<MaskParams> mask_table() {
  using P = MaskParams;
  return Table<P>{{
      text(&P::layer, "layer", "Mask layer to write (0..1)"),
      choice(&P::source, "source",
             {{Source::Elevation, "elevation"}, {Source::Slope, "slope"}, {Source::Curvature, "curvature"}, {Source::Flow, "flow"},
              {Source::Coast, "coast"}, {Source::Biome, "biome"}},
             "What the mask measures: elevation (0..1), slope (deg), curvature (1/m), flow (drainage km²), coast (distance to the sea, m), biome (ids)"),
      param(&P::from, "from", -1e9, 1e9, "", "Lower end of the band, in the source's units"),
      param(&P::to, "to", -1e9, 1e9, "", "Upper end of the band, in the source's units"),
      param(&P::soft, "soft", 0, 1e9, "", "Width of the soft edge beyond each end of the band, in the source's units (0 = hard)"),
      param(&P::invert, "invert", 0, 1, "", "1 − the mask"),
      int_list(&P::ids, "ids", 0, 1000000, "biome: the biome ids that are 1"),
  }};
}

void mask_validate(const MaskParams& p, const std::string& path) {
  if (p.layer.empty()) throw Error(path + ".layer", "expected a layer name, got \"\"");
  if (p.to < p.from) throw Error(path + ".to", "expected to ≥ from (" + std::to_string(p.from) + "), got " + std::to_string(p.to));
}

Reach mask_reach(const MaskParams& p, const Frame&) {
  switch (p.source) {
    case Source::Slope:
    case Source::Curvature: return neighbourhood(1);
    case Source::Coast: return global("the distance to the coast depends on where the sea is, anywhere on the map");
    default: return pointwise();
  }
}

double smooth(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

float band(const MaskParams& p, double v) {
  double m;
  if (p.soft <= 0) {
    m = v >= p.from && v <= p.to ? 1.0 : 0.0;
  } else {
    m = smooth(p.from - p.soft, p.from, v) * (1.0 - smooth(p.to, p.to + p.soft, v));
  }
  return float(p.invert ? 1.0 - m : m);
}

// Squared distance transform of one line (Felzenszwalb & Huttenlocher): f in, d out, n samples.
// "No sea" is a large finite value (kFar), so the parabola intersections stay finite.
constexpr double kFar = 1e20;
void edt_1d(const double* f, double* d, int n, std::vector<int>& v, std::vector<double>& z) {
  v.assign(std::size_t(n), 0);
  z.assign(std::size_t(n) + 1, 0.0);
  int k = 0;
  z[0] = -std::numeric_limits<double>::infinity();
  z[1] = std::numeric_limits<double>::infinity();
  for (int q = 1; q < n; ++q) {
    double s;
    while (true) {
      const int r = v[std::size_t(k)];
      s = ((f[q] + double(q) * q) - (f[r] + double(r) * r)) / (2.0 * (q - r));
      if (s <= z[std::size_t(k)]) --k;
      else break;
    }
    ++k;
    v[std::size_t(k)] = q;
    z[std::size_t(k)] = s;
    z[std::size_t(k) + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[std::size_t(k) + 1] < q) ++k;
    const int r = v[std::size_t(k)];
    d[q] = std::min(kFar, double(q - r) * (q - r) + f[r]);
  }
}

void mask_apply(Terrain& t, const MaskParams& p, const Context& ctx) {
  const std::string stage = "stages[" + std::to_string(ctx.stage_index) + "]";
  const Frame& f = t.frame;
  const int nx = f.nx, nz = f.nz;
  auto need = [&](const char* name, const char* what) -> const Layer& {
    auto it = t.layers.find(name);
    if (it == t.layers.end() || it->second.channels != 1)
      throw Error(stage + ".source", std::string("needs a '") + name + "' layer: " + what);
    return it->second;
  };
  std::vector<float> out(f.count());
  const double cell = f.cell_m();
  if (p.source == Source::Biome) {
    const Layer& b = need("biome", "add a biomes or climate stage before this one");
    for (std::size_t k = 0; k < out.size(); ++k) {
      const long id = std::lround(b.data[k]);
      const bool in = std::find(p.ids.begin(), p.ids.end(), int(id)) != p.ids.end();
      out[k] = (in != p.invert) ? 1.0f : 0.0f;
    }
  } else if (p.source == Source::Flow) {
    const Layer& fl = need("flow", "add a flow stage before this one");
    for (std::size_t k = 0; k < out.size(); ++k) out[k] = band(p, double(fl.data[k]) / 1e6);
  } else {
    const Layer& h = need("height", "add an elevation stage before this one");
    auto H = [&](int i, int j) { return double(h.data[std::size_t(std::clamp(j, 0, nz - 1)) * nx + std::clamp(i, 0, nx - 1)]); };
    if (p.source == Source::Coast) {
      // Squared distances in samples: 0 in the sea, ∞ on land; columns then rows.
      std::vector<double> g(f.count());
      for (std::size_t k = 0; k < g.size(); ++k) g[k] = h.data[k] < float(f.sea_level) ? 0.0 : kFar;
      detail::parallel_rows(nx, [&](int i) {
        std::vector<double> col(static_cast<std::size_t>(nz)), d(static_cast<std::size_t>(nz));
        std::vector<int> v;
        std::vector<double> z;
        for (int j = 0; j < nz; ++j) col[std::size_t(j)] = g[std::size_t(j) * nx + i];
        edt_1d(col.data(), d.data(), nz, v, z);
        for (int j = 0; j < nz; ++j) g[std::size_t(j) * nx + i] = d[std::size_t(j)];
      });
      detail::parallel_rows(nz, [&](int j) {
        std::vector<double> d(static_cast<std::size_t>(nx));
        std::vector<int> v;
        std::vector<double> z;
        edt_1d(g.data() + std::size_t(j) * nx, d.data(), nx, v, z);
        for (int i = 0; i < nx; ++i) {
          const double dist = d[std::size_t(i)] >= kFar ? 1e30 : std::sqrt(d[std::size_t(i)]) * cell;  // no sea: far
          out[std::size_t(j) * nx + i] = band(p, dist);
        }
      });
    } else {
      const double hm = f.height_m;
      detail::parallel_rows(nz, [&](int j) {
        for (int i = 0; i < nx; ++i) {
          double v;
          if (p.source == Source::Elevation) {
            v = H(i, j);
          } else if (p.source == Source::Slope) {
            const int il = std::max(i - 1, 0), ir = std::min(i + 1, nx - 1), jt = std::max(j - 1, 0), jb = std::min(j + 1, nz - 1);
            const double dx = (H(ir, j) - H(il, j)) * hm / ((ir - il) * cell), dz = (H(i, jb) - H(i, jt)) * hm / ((jb - jt) * cell);
            v = std::atan(std::sqrt(dx * dx + dz * dz)) * 180.0 / M_PI;
          } else {  // curvature
            v = (H(i + 1, j) + H(i - 1, j) + H(i, j + 1) + H(i, j - 1) - 4 * H(i, j)) * hm / (cell * cell);
          }
          out[std::size_t(j) * nx + i] = band(p, v);
        }
      });
    }
  }
  t.layer(p.layer, 1).data = std::move(out);
}

// ---- mix --------------------------------------------------------------------------------------

struct MixParams {
  std::string a = "height", b = "height", mask = "mask", into = "height";
};

Table<MixParams> mix_table() {
  using P = MixParams;
  return Table<P>{{
      text(&P::a, "a", "Layer where the mask is 0"),
      text(&P::b, "b", "Layer where the mask is 1"),
      text(&P::mask, "mask", "Mask layer (0..1, clamped)"),
      text(&P::into, "into", "Layer to write: a + mask · (b − a)"),
  }};
}

void mix_validate(const MixParams& p, const std::string& path) {
  for (auto [v, n] : {std::pair{&p.a, "a"}, {&p.b, "b"}, {&p.mask, "mask"}, {&p.into, "into"}})
    if (v->empty()) throw Error(path + "." + n, "expected a layer name, got \"\"");
}

void mix_apply(Terrain& t, const MixParams& p, const Context& ctx) {
  const std::string stage = "stages[" + std::to_string(ctx.stage_index) + "]";
  auto need = [&](const std::string& name, const char* field) -> const std::vector<float>& {
    auto it = t.layers.find(name);
    if (it == t.layers.end() || it->second.channels != 1)
      throw Error(stage + "." + field, "no one-channel layer '" + name + "' (a stage before this one must write it)");
    return it->second.data;
  };
  std::vector<float> out(t.frame.count());
  const auto& a = need(p.a, "a");
  const auto& b = need(p.b, "b");
  const auto& m = need(p.mask, "mask");
  for (std::size_t k = 0; k < out.size(); ++k) out[k] = a[k] + std::clamp(m[k], 0.0f, 1.0f) * (b[k] - a[k]);
  t.layer(p.into, 1).data = std::move(out);
}

}  // namespace

StageDef mask() {
  StageDef d = make_stage<MaskParams>("mask", "A 0..1 mask layer from elevation, slope, curvature, drainage, distance to the coast or biome ids, with soft edges",
                                      pointwise(), mask_table(), mask_apply, mask_validate, mask_reach,
                                      "slope, curvature: 1 sample; coast: global; otherwise pointwise");
  d.memory.layer_param = "layer";
  d.memory.scratch_per_sample = 12;
  return d;
}

StageDef mix() {
  StageDef d = make_stage<MixParams>("mix", "Two layers combined through a mask: into = a + mask · (b − a)", pointwise(), mix_table(),
                                     mix_apply, mix_validate);
  d.memory.layer_param = "into";
  d.memory.scratch_per_sample = 4;
  return d;
}

}  // namespace relief::stages
