// Shaping stages: redistribute, terrace, island, curve.
//
// All four are pointwise: the new elevation of a sample is a pure function of its old elevation,
// its world position (frame.x_m(i), frame.z_m(j)), the world extent (world_width_m/world_depth_m),
// sea_level and the stage's params — never of the window, the sample count or the map's min/max.
// A 257² preview therefore equals every other sample of the 513² build, and neighbouring tiles
// agree on their shared border. Every stage reads and writes the "height" layer and clamps its
// output to [0, 1] (input heights are clamped to [0, 1] before use too).
//
// Sources:
//   * Amit Patel, "Making maps with noise functions", Red Blob Games (2015–2022): redistribution
//     e^exponent, terraces round(e·n)/n, island distance functions (square bump, Euclidean²,
//     hyperboloid, trig product, squircle) and the linear shaping e' = lerp(e, 1 − d, mix).
//   * A. Saparov, "A Maya Terrain Generator Based on Perlin Noise" (2021, seed 000): the height
//     modifier and exponent, "round levels", the island modifier.
//   * O. Feldmann, "Island Generator" (2022, seed 003): smooth terraces with sloped walls, the
//     circular gradient with a falloff rate (0 → plain, negative → crater), animation-curve remap.
//   * F. N. Fritsch, R. E. Carlson, "Monotone Piecewise Cubic Interpolation",
//     SIAM J. Numer. Anal. 17(2), 1980: the monotone tangents used by `curve`.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "curve.hpp"
#include "parallel.hpp"
#include "pointwise.hpp"
#include "relief/error.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

// The shaping stages are row stages (stage.hpp: RowKernel): preparing one hoists everything that
// does not change per sample — choices as enums, thresholds as float constants, functions of x as
// a per-column vector — and the rows then run the vectorised kernels of pointwise.hpp. Arithmetic
// is single precision, the precision of the layer (pointwise.hpp states the exactness rules).

// The "height" layer as the row stages need it: present, one channel, one value per sample.
void require_height(Terrain& t) {
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != t.frame.count())
    throw Error("", "layer 'height' must have one channel and one value per sample");
}

// A pointwise kernel on t's height layer (checked): Fn applies the row parameters `k` to each row.
template <class Row, void (*Fn)(const Row&, float*, int)>
struct HeightKernel : RowKernel {
  Row k;
  int nx = 0;
  explicit HeightKernel(Terrain& t) : RowKernel("height"), nx(t.frame.nx) { require_height(t); }
  void apply_row(int, float* row) const override { Fn(k, row, nx); }
};

// ================================================================================ redistribute

struct RedistributeParams {
  double exponent = 1.0;
  double modifier = 1.0;
  bool land_only = false;
};

// e' = clamp(modifier · e^exponent); land_only applies it to u = (e − sea)/(1 − sea) above the sea
// (pointwise.hpp: LandOnly). Heights are clamped to [0, 1] first, so negative heights become 0 and
// stay 0. pow is our own exp2(exponent · log2 e) in single precision (pointwise.hpp:
// RedistributeRow; relative error ≤ 1.5e-6, the same bits on every SIMD target); exponent 1 is exact.
using RedistributeKernel = HeightKernel<detail::RedistributeRow, detail::redistribute_row>;

std::unique_ptr<RowKernel> prepare_redistribute(Terrain& t, const RedistributeParams& p, const Context&) {
  auto r = std::make_unique<RedistributeKernel>(t);
  r->k.land = detail::LandOnly::make(p.land_only, t.frame.sea_level);
  r->k.set_exponent(p.exponent);
  r->k.modifier = float(p.modifier);
  return r;
}

// ===================================================================================== terrace

enum class TerraceMode { Round, Smooth };

struct TerraceParams {
  int levels = 8;
  TerraceMode mode = TerraceMode::Round;
  double wall = 0.3;
  bool land_only = false;
  double filter_samples = 0.0;
};

// round:  round(e·n)/n (seed 000) — n+1 distinct levels 0, 1/n, …, 1 (ties round up).
// smooth: with t = e·n, k = floor(t), f = t − k, w = wall:
//           e' = (k + smoothstep(clamp((f − (1 − w)/2) / w, 0, 1))) / n.
//         Plateaus keep the round levels k/n; the wall between level k/n and (k+1)/n rises over
//         the central fraction w of the step, centred on (k + ½)/n, with zero slope where it meets
//         the plateaus. Continuous and non-decreasing in e; w = 0 is exactly `round`.
// t = e·n is rounded to float, so a sample within half an ulp of a step edge may land on the
// other side of it (the same on every target and at every resolution).
using TerraceKernel = HeightKernel<detail::TerraceRow, detail::terrace_row>;

// filter_samples > 0: band-limited terraces. A terrace is a periodic function of elevation; on a
// slope it becomes a periodic function of position whose period is (1/n) / |∇e| samples. Where
// that period nears the sample spacing, point samples of it alias: the even rings on a cone beat
// against the grid into moiré (the volcanic-island volcano at 513², 40 levels). The filtered
// terrace is the mean of the terrace function T over the elevations one footprint covers,
//     T̄(e) = (G(e + Δ/2) − G(e − Δ/2)) / Δ,  Δ = filter_samples · |∇e|·(one sample),
// with G the antiderivative of T (closed form below) and ∇e the input's central differences
// (one-sided at the window border): a box filter along the gradient, exact for a locally planar
// input. Steps many samples wide keep their shape (Δ ≪ 1/n); steps narrower than the footprint
// fade into the slope they sit on (T̄ → e as Δ grows, since T averages to e over a period), as a
// mip-mapped texture would. Flat ground (Δ = 0) gets T itself. Continuous in e and Δ. The stage
// then looks one sample around each sample (a neighbourhood stage, not fused); 0 keeps it
// pointwise and byte-identical to the unfiltered terraces.
namespace {
// ∫₀ᶠ step(φ) dφ over one period f ∈ [0, 1]: the step rises over [lo, lo + w] by smoothstep
// (s = (φ − lo)/w, ∫ 3s² − 2s³ ds = s³ − s⁴/2), or at ½ for round terraces (w = 0).
double step_integral(double f, double w, double lo) {
  if (w <= 0.0) return std::max(0.0, f - 0.5);
  if (f <= lo) return 0.0;
  if (f >= lo + w) return 0.5 * w + (f - lo - w);
  const double x = (f - lo) / w;
  return w * (x * x * x - 0.5 * x * x * x * x);
}
// G(t) = ∫₀ᵗ (floor τ + step(frac τ)) dτ = k²/2 + k·f + step_integral(f), t = k + f (any sign:
// each whole period contributes its mean m + ½).
double terrace_antiderivative(double t, double w, double lo) {
  const double k = std::floor(t), f = t - k;
  return 0.5 * k * k + k * f + step_integral(f, w, lo);
}
double terrace_point(double t, double w, double lo) {
  const double k = std::floor(t), f = t - k;
  if (w <= 0.0) return k + (f >= 0.5 ? 1.0 : 0.0);
  const double s = std::clamp((f - lo) / w, 0.0, 1.0);
  return k + s * s * (3.0 - 2.0 * s);
}
}  // namespace

void apply_terrace_filtered(Terrain& t, const TerraceParams& p) {
  require_height(t);
  Layer& h = t.get("height");
  const Frame& fr = t.frame;
  const int nx = fr.nx, nz = fr.nz;
  const std::vector<float> in = h.data;
  const double n = p.levels;
  const double w = p.mode == TerraceMode::Smooth ? p.wall : 0.0, lo = 0.5 * (1.0 - w);
  const detail::LandOnly land = detail::LandOnly::make(p.land_only, fr.sea_level);
  detail::parallel_rows(nz, [&](int j) {
    const float* up = in.data() + std::size_t(std::max(j - 1, 0)) * nx;
    const float* mid = in.data() + std::size_t(j) * nx;
    const float* down = in.data() + std::size_t(std::min(j + 1, nz - 1)) * nx;
    const double kz = (j > 0 && j < nz - 1) ? 0.5 : 1.0;
    float* out = h.row(j, nx);
    auto c01 = [](float v) { return std::clamp(double(v), 0.0, 1.0); };
    for (int i = 0; i < nx; ++i) {
      const double e = c01(mid[i]);
      if (land.enabled && !(float(e) > land.sea_floor_max)) {
        out[i] = float(e);  // the sea floor keeps its (clamped) elevation, as in the row kernel
        continue;
      }
      const double gx = nx < 2 ? 0.0
                        : i == 0 ? c01(mid[1]) - c01(mid[0])
                        : i == nx - 1 ? c01(mid[nx - 1]) - c01(mid[nx - 2])
                                      : 0.5 * (c01(mid[i + 1]) - c01(mid[i - 1]));
      const double gz = kz * (c01(down[i]) - c01(up[i]));
      // In terrace units t = u·n, u = e, or (e − sea)/(1 − sea) above the sea when land_only.
      const double scale = land.enabled ? n / double(land.land) : n;
      const double u = land.enabled ? (e - double(land.sea)) / double(land.land) : e;
      const double tt = u * n, dt = p.filter_samples * std::hypot(gx, gz) * scale;
      const double v = dt > 1e-9 ? (terrace_antiderivative(tt + 0.5 * dt, w, lo) - terrace_antiderivative(tt - 0.5 * dt, w, lo)) / dt
                                 : terrace_point(tt, w, lo);
      const double r = land.enabled ? double(land.sea) + double(land.land) * std::clamp(v / n, 0.0, 1.0) : v / n;
      out[i] = float(std::clamp(r, 0.0, 1.0));
    }
  });
}

std::unique_ptr<RowKernel> prepare_terrace(Terrain& t, const TerraceParams& p, const Context&) {
  auto r = std::make_unique<TerraceKernel>(t);
  r->k.levels = float(p.levels);
  r->k.smooth = p.mode == TerraceMode::Smooth && p.wall > 0.0;
  r->k.wall = float(p.wall);
  r->k.wall_lo = float(0.5 * (1.0 - p.wall));
  r->k.land = detail::LandOnly::make(p.land_only, t.frame.sea_level);
  return r;
}

// ====================================================================================== island

enum class Distance { SquareBump, Euclidean2, Hyperboloid, TrigProduct, Squircle, Circular };

struct IslandParams {
  Distance distance = Distance::SquareBump;
  detail::IslandShaping shaping = detail::IslandShaping::Lerp;
  double mix = 0.5;
  double falloff_rate = 1.0;
  double radius = 1.0;
  double hyperboloid_a = 0.2;
};

// Distance d ∈ [0, 1]: 0 at the world centre, 1 at the border (and clamped to 1 beyond it).
// nx = 2x/W − 1, nz = 2z/D − 1 are world coordinates normalised to [−1, 1] over the whole world
// (not the window), so the rectangle-fitted functions follow the world's aspect ratio:
//   square_bump   1 − (1 − nx²)(1 − nz²)
//   euclidean2    (nx² + nz²)/√2                 (1/√2 at edge midpoints, 1 at the corners)
//   hyperboloid   (√(nx² + nz² + a²) − a)/(√(1 + a²) − a)   (1 at edge midpoints)
//   trig_product  1 − cos(nx·π/2)·cos(nz·π/2)
//   squircle      √(nx⁴ + nz⁴)
//   circular      |(x, z) − centre| / (radius · ½ · min(W, D))   (a true circle in metres)
// Each is computed as a per-column term of x (once per frame, in double, stored as float), a
// per-row term of z (once per row) and one multiply or add (plus a square root) per sample.
//
// e' = clamp(lerp(e, target, mix)) with
//   lerp     target = 1 − d        (Red Blob Games: the noise fades into a cone/dome shape)
//   multiply target = e · (1 − d)  (keeps the noise's detail, scaled down towards the border)
//   subtract target = e − rate · d (seed 003's falloff: rate 0 → no change; negative → crater)
// Sea-floor guarantee: with mix = 1, `lerp` and `multiply` give exactly 0 wherever d = 1, below any
// sea_level > 0; `subtract` gives e − rate there, below sea level for every e ≤ 1 when
// rate > 1 − sea_level.
struct IslandKernel final : RowKernel {
  detail::IslandRow k;
  std::vector<float> col;  // per-column term, padded
  Distance distance = Distance::SquareBump;
  Frame frame;
  double a = 0.0, radius_m = 1.0;
  IslandKernel() : RowKernel("height") {}

  // The term of a normalised coordinate v = 2x/W − 1 (columns) or 2z/D − 1 (rows); `row` adds a²
  // for the hyperboloid. Circular works on the distance from the centre in metres instead.
  double term(double v, double offset_m, bool row) const {
    switch (distance) {
      case Distance::SquareBump: return 1.0 - v * v;
      case Distance::Euclidean2: return v * v / std::numbers::sqrt2;
      case Distance::Hyperboloid: return v * v + (row ? a * a : 0.0);
      case Distance::TrigProduct: return std::cos(v * std::numbers::pi / 2);
      case Distance::Squircle: return v * v * v * v;
      case Distance::Circular: {
        const double r = offset_m / radius_m;
        return r * r;
      }
    }
    return 0.0;
  }
  void apply_row(int j, float* row) const override {
    const double z = frame.z_m(j), D = frame.world_depth_m;
    detail::island_row(k, float(term(2.0 * z / D - 1.0, z - 0.5 * D, true)), row, frame.nx);
  }
};

std::unique_ptr<RowKernel> prepare_island(Terrain& t, const IslandParams& p, const Context&) {
  require_height(t);
  auto r = std::make_unique<IslandKernel>();
  const Frame& f = t.frame;
  const double W = f.world_width_m, D = f.world_depth_m;
  r->frame = f;
  r->a = p.hyperboloid_a;
  r->radius_m = p.radius * 0.5 * std::min(W, D);
  using detail::IslandForm;
  r->distance = p.distance;
  switch (p.distance) {
    case Distance::SquareBump: case Distance::TrigProduct: r->k.form = IslandForm::Product; break;
    case Distance::Euclidean2: r->k.form = IslandForm::Sum; break;
    case Distance::Hyperboloid: r->k.form = IslandForm::RootAffine; break;
    case Distance::Squircle: case Distance::Circular: r->k.form = IslandForm::Root; break;
  }
  r->k.shaping = p.shaping;
  r->k.mix = float(p.mix);
  r->k.rate = float(p.falloff_rate);
  r->k.a = float(p.hyperboloid_a);
  r->k.norm = float(std::sqrt(1.0 + p.hyperboloid_a * p.hyperboloid_a) - p.hyperboloid_a);
  r->col.assign(std::size_t(f.nx) + detail::kRowPad, 0.0f);
  for (int i = 0; i < f.nx; ++i) {
    const double x = f.x_m(i);
    r->col[std::size_t(i)] = float(r->term(2.0 * x / W - 1.0, x - 0.5 * W, false));
  }
  r->k.col = r->col.data();
  return r;
}

// ======================================================================================= curve

struct CurveParams {
  std::vector<CurvePoint> points{{0.0, 0.0}, {1.0, 1.0}};
};


// Each segment [x_k, x_k+1] is the cubic Hermite interpolant of (y_k, m_k), (y_k+1, m_k+1),
// rewritten once as a polynomial in s = (x − x_k)/h (coefficients in double, stored as float):
//   y = y_k + s·(h·m_k + s·(3Δy − 2h·m_k − h·m_k+1 + s·(−2Δy + h·m_k + h·m_k+1))),  Δy = y_k+1 − y_k,
// then clamped to [min, max] of y_k, y_k+1 — an exact no-overshoot guarantee (the tangents make it
// hold mathematically; the clamp removes rounding). Knots are compared in float exactly as the
// double comparison would decide (pointwise.hpp: float_at_least / float_at_most), so a control
// point's own x maps to its own y. Up to one vector's lanes of segments (8 on AVX2, 16 on
// AVX-512), the segment's coefficients are looked up by lane permutation (one compare and one add
// per interior point, eight permutations); beyond that, one compare and eight selects per interior
// point. AVX2, 4096², 1 thread: 7 points 76 → 52 ms, 4 points 49 → 44 ms.
struct CurveKernel final : HeightKernel<detail::CurveRow, detail::curve_row> {
  using HeightKernel::HeightKernel;
  std::vector<float> x0, h, c0, c1, c2, c3, lo, hi;  // the tables k points into
};

std::unique_ptr<RowKernel> prepare_curve(Terrain& t, const CurveParams& p, const Context&) {
  auto r = std::make_unique<CurveKernel>(t);
  const std::vector<CurvePoint>& c = p.points;
  const std::vector<double> m = detail::monotone_tangents(c);
  for (std::size_t k = 0; k + 1 < c.size(); ++k) {
    const double h = c[k + 1].x - c[k].x, dy = c[k + 1].y - c[k].y;
    const double hm0 = h * m[k], hm1 = h * m[k + 1];
    r->x0.push_back(detail::float_at_least(c[k].x));
    r->h.push_back(float(h));
    r->c0.push_back(float(c[k].y));
    r->c1.push_back(float(hm0));
    r->c2.push_back(float(3.0 * dy - 2.0 * hm0 - hm1));
    r->c3.push_back(float(-2.0 * dy + hm0 + hm1));
    r->lo.push_back(float(std::min(c[k].y, c[k + 1].y)));
    r->hi.push_back(float(std::max(c[k].y, c[k + 1].y)));
  }
  r->k.segments = int(r->x0.size());
  // Padded to a vector of the widest target, so that up to kLevelLanes segments are looked up by
  // lane permutation (curve_row); the padding is never selected.
  r->k.readable = std::max(r->k.segments, detail::kLevelLanes);
  for (auto* a : {&r->x0, &r->h, &r->c0, &r->c1, &r->c2, &r->c3, &r->lo, &r->hi}) a->resize(std::size_t(r->k.readable), 0.0f);
  r->k.x0 = r->x0.data(), r->k.h = r->h.data(), r->k.c0 = r->c0.data(), r->k.c1 = r->c1.data();
  r->k.c2 = r->c2.data(), r->k.c3 = r->c3.data(), r->k.lo = r->lo.data(), r->k.hi = r->hi.data();
  r->k.first_x = detail::float_at_most(c.front().x);
  r->k.first_y = float(c.front().y);
  r->k.last_x = detail::float_at_least(c.back().x);
  r->k.last_y = float(c.back().y);
  return r;
}

}  // namespace

StageDef redistribute() {
  using P = RedistributeParams;
  Table<P> table{{
      param(&P::exponent, "exponent", 0.1, 8.0, "",
            "Power applied to elevation: > 1 pushes middle elevations down into valleys, < 1 lifts them"),
      param(&P::modifier, "modifier", 0.0, 4.0, "", "Height modifier multiplied after the power (result clamped to 0..1)"),
      param(&P::land_only, "land_only", 0, 1, "",
            "Apply only above sea level, to (e − sea)/(1 − sea); the sea floor and coastline stay put"),
  }};
  return make_row_stage<P>("redistribute", "Redistribute elevation: e' = clamp(modifier · e^exponent)", std::move(table),
                           prepare_redistribute);
}

StageDef terrace() {
  using P = TerraceParams;
  Table<P> table{{
      param(&P::levels, "levels", 1, 256, "", "Number of terrace steps n: round gives the n + 1 levels 0, 1/n, …, 1"),
      choice(&P::mode, "mode", {{TerraceMode::Round, "round"}, {TerraceMode::Smooth, "smooth"}},
             "round: round(e·n)/n with vertical walls; smooth: the same plateaus joined by sloped walls"),
      param(&P::wall, "wall", 0.0, 1.0, "",
            "Smooth mode: fraction of each step taken by the sloped wall (0 = vertical, 1 = no flat plateau)"),
      param(&P::land_only, "land_only", 0, 1, "",
            "Terrace only above sea level, in steps of (1 − sea)/n; the sea floor is unchanged"),
      param(&P::filter_samples, "filter_samples", 0.0, 8.0, "",
            "Band-limit: average the terraces over this many samples of the local slope, so steps narrower than "
            "that fade into the slope instead of aliasing into moiré rings (2 suits most); 0 = off (pointwise)"),
  }};
  // A row stage (fused, pointwise) unless filter_samples > 0, which reads the input's gradient.
  auto typed = std::make_shared<const Table<P>>(table);  // the filtered form reads the same typed params
  StageDef d = make_row_stage<P>("terrace", "Terraces: round(e·n)/n, or smooth terraces with sloped walls",
                                 std::move(table), prepare_terrace);
  auto row_parse = d.parse;
  struct Filtered final : Stage {
    std::unique_ptr<Stage> row;  // the row stage, for params()
    P p;
    void apply(Terrain& t, const Context&) const override { apply_terrace_filtered(t, p); }
    json params() const override { return row->params(); }
    Reach reach(const Frame&) const override { return neighbourhood(1); }
  };
  d.halo_rule = "1 sample when filter_samples > 0 (the input's gradient), else pointwise";
  d.memory.scratch_per_sample = 4;  // filter_samples > 0: a copy of the input heights
  d.parse = [row_parse, typed](const json& obj, const std::string& path) -> std::unique_ptr<Stage> {
    std::unique_ptr<Stage> s = row_parse(obj, path);  // validates, and serves params()
    P p = typed->read(obj, path, {"stage", "label"});
    if (!(p.filter_samples > 0.0)) return s;
    auto f = std::make_unique<Filtered>();
    f->p = std::move(p);
    f->row = std::move(s);
    return f;
  };
  return d;
}

StageDef island() {
  using P = IslandParams;
  Table<P> table{{
      choice(&P::distance, "distance",
             {{Distance::SquareBump, "square_bump"}, {Distance::Euclidean2, "euclidean2"},
              {Distance::Hyperboloid, "hyperboloid"}, {Distance::TrigProduct, "trig_product"},
              {Distance::Squircle, "squircle"}, {Distance::Circular, "circular"}},
             "Distance d from the world centre (0) to the border (1); circular uses `radius`"),
      choice(&P::shaping, "shaping",
             {{detail::IslandShaping::Lerp, "lerp"}, {detail::IslandShaping::Multiply, "multiply"},
              {detail::IslandShaping::Subtract, "subtract"}},
             "Target elevation: lerp 1 − d; multiply e·(1 − d); subtract e − falloff_rate·d (seed 003)"),
      param(&P::mix, "mix", 0.0, 1.0, "", "Island modifier: e' = lerp(e, target, mix); 0 leaves the terrain unchanged"),
      param(&P::falloff_rate, "falloff_rate", -4.0, 4.0, "",
            "Subtract shaping: elevation removed at d = 1; 0 gives a plain, negative raises the border (crater)"),
      param(&P::radius, "radius", 0.05, 4.0, "",
            "Circular distance: radius where d reaches 1, relative to half the shorter world side"),
      param(&P::hyperboloid_a, "hyperboloid_a", 0.01, 4.0, "",
            "Hyperboloid distance: rounding of the centre, d = (√(nx²+nz²+a²) − a)/(√(1+a²) − a)"),
  }};
  return make_row_stage<P>("island", "Island shaping: a distance from the world centre pulls the border down",
                           std::move(table), prepare_island);
}

StageDef curve() {
  using P = CurveParams;
  Table<P> table{{
      relief::curve(&P::points, "points", 0.0, 1.0,
                    "Control points [[e, e'], …] with increasing e; monotone cubic (Fritsch–Carlson), no overshoot; "
                    "elevations outside the first/last x take the first/last y"),
  }};
  return make_row_stage<P>("curve", "Remap elevation through a monotone curve (an animation-curve remap)",
                           std::move(table), prepare_curve);
}

}  // namespace relief::stages
