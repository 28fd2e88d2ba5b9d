#pragma once
// Internal: the vectorised row kernels of the pointwise and colour stages (Google Highway with
// runtime dispatch: AVX-512, AVX2, SSE4, SSSE3 or scalar, chosen once per process by the CPU).
//
// Shape of the work. Everything a stage knows before it sees a sample is hoisted out of the
// loops: choices become enums, thresholds and ratios become float constants in the structs below
// (built once per stage run), functions of x become per-column vectors (built once per frame) and
// functions of z become per-row scalars. What is left per sample is a few branch-free vector
// operations, so a stage costs about one read and one write of its layer.
//
// Position independence. Full vectors are loaded straight from the row; the last partial vector
// is copied into a zero-padded buffer and run through the very same vector code. A sample's
// result therefore never depends on where it falls in a vector: a 257² preview equals every other
// sample of the 513² build, neighbouring windows agree on their shared samples, and results are
// identical for any thread count.
//
// Precision. Single precision, the layers' own. The kernels use Highway's exactly rounded
// operations (add, mul, div, sqrt, floor, min/max, integer and bit operations) and never a fused
// multiply-add (the build uses -ffp-contract=off), so every target gives bit-identical results —
// including redistribute's pow, which is our own polynomial exp2/log2 (pointwise.cpp: Pow01) —
// except the colour stage's rock blend, whose atan is Highway's (evaluated with MulAdd: an FMA on
// AVX2/AVX-512, a multiply and an add elsewhere), so it may differ between targets in the last
// bits (tests/test_pointwise.cpp holds every compiled target to 1e-5 of the scalar target and the
// others to bit identity). Within one process the target is fixed, so files are byte-identical for
// any thread count.
//
// Thresholds taken from double parameters are converted so that float comparisons decide exactly
// as the double comparison would (see float_at_most / float_at_least).
#include <cstdint>
#include <vector>

namespace relief::detail {

// Pad per-column arrays handed to the kernels with this many readable elements after the last
// column (the tail vector reads them; their values do not matter).
constexpr int kRowPad = 64;

// The largest float ≤ v, and the smallest float ≥ v. For a float e:
//   double(e) ≤ v  ⟺  e ≤ float_at_most(v),   double(e) < v  ⟺  e < float_at_least(v).
float float_at_most(double v);
float float_at_least(double v);

// Land-only remapping shared by redistribute and terrace: samples with e ≤ sea_level keep their
// elevation; above it the stage works on u = (e − sea)/land, land = 1 − sea, and the result g(u) ∈ [0, 1]
// maps back to sea + land·g(u). With sea_level ≥ 1 nothing is land (identity).
struct LandOnly {
  bool enabled = false;
  float sea_floor_max = 0.0f;  // e ≤ this is sea floor (float_at_most(sea_level); 1 when sea_level ≥ 1)
  float sea = 0.0f, land = 1.0f;
  static LandOnly make(bool enabled, double sea_level);
};

// ---- height kernels: transform row[0, n) in place; inputs are clamped to [0, 1] first and the
// ---- result is clamped to [0, 1].

// e' = clamp(modifier · e^exponent); e^1 is exact (no pow), 0^y = 0, 1^y = 1 exactly.
// e^y is our own exp2(y·log2 e) (pointwise.cpp: Pow01): relative error ≤ 1.5e-6 against the double
// pow for results ≥ 2^−125 (inputs ≥ x_min), 0 below that; exactly rounded operations only, so every
// target gives the same bits. Monotone up to that error (tests/test_pointwise.cpp).
// log2 m = t·P(t²), t = (m − 1)/(m + 1), m ∈ [√½, √2) (|t| ≤ 3 − 2√2), P(s) = c0 + s·(c1 + s·c2):
// the minimax fit of P's relative error (1.5e-7; Remez exchange in double) among those exact at the
// interval's ends (t·P = ±½ at m = √2, √½), so that the two sides of a binade's √½ split meet.
constexpr double kPowLog2[3] = {2.885390504279436, 0.9615568535732026, 0.5971566328734291};
struct RedistributeRow {
  float exponent = 1.0f, modifier = 1.0f;
  float exponent_hi = 1.0f, exponent_lo = 0.0f;  // exponent = hi + lo exactly, hi with 12 significant bits
  float log2_y[3] = {};  // exponent·kPowLog2, rounded to float
  float x_min = 0.0f;       // e^exponent is 0 below this (where it would fall under 2^−125)
  float land_x_min = 0.0f;  // land_only: e − sea is lifted to this (u^y ≥ 2^−100, see pointwise.cpp)
  bool power = false;  // exponent ≠ 1
  LandOnly land;
  // Sets exponent, exponent_hi/lo, power and the x_min thresholds from a positive exponent; call
  // after setting `land`.
  void set_exponent(double y);
};
void redistribute_row(const RedistributeRow& k, float* row, int n);

// round: round(e·n)/n (halves round up); smooth: (k + smoothstep(clamp((f − (1 − w)/2)/w)))/n with
// k = floor(e·n), f = e·n − k.
struct TerraceRow {
  float levels = 8.0f;
  bool smooth = false;    // false also when wall ≤ 0 (then smooth equals round)
  float wall = 0.0f;      // w
  float wall_lo = 0.0f;   // (1 − w)/2
  LandOnly land;
};
void terrace_row(const TerraceRow& k, float* row, int n);

// Island distance d ∈ [0, 1] from a per-column term c (col[i]) and a per-row term r:
//   Product     d = 1 − c·r                 (square_bump: 1 − x², 1 − z²; trig_product: cos terms)
//   Sum         d = c + r                   (euclidean2: x²/√2, z²/√2)
//   Root        d = √(c + r)                (squircle: x⁴, z⁴; circular: (Δx/R)², (Δz/R)²)
//   RootAffine  d = (√(c + r) − a)/norm     (hyperboloid: x², z² + a²)
// then clamped to [0, 1], and e' = clamp(e + (target − e)·mix) with target 1 − d (Lerp),
// e·(1 − d) (Multiply) or e − rate·d (Subtract).
enum class IslandForm { Product, Sum, Root, RootAffine };
enum class IslandShaping { Lerp, Multiply, Subtract };
struct IslandRow {
  IslandForm form = IslandForm::Product;
  IslandShaping shaping = IslandShaping::Lerp;
  float mix = 0.5f, rate = 1.0f;
  float a = 0.0f, norm = 1.0f;  // RootAffine
  const float* col = nullptr;   // n + kRowPad readable values
};
void island_row(const IslandRow& k, float row_term, float* row, int n);

// Piecewise cubic y = c0 + s(c1 + s(c2 + s·c3)), s = (x − x0)/h, clamped to [lo, hi], on the
// segment k = number of interior knots ≤ x; x ≤ first_x gives first_y, x ≥ last_x gives last_y.
// Arrays have `segments` entries (≥ 1); knot[m] (m = 1 .. segments − 1) is the left end of segment m.
struct CurveRow {
  int segments = 1;
  int readable = 1;  // entries readable in each array (≥ segments; padding beyond is never selected)
  const float *x0 = nullptr, *h = nullptr, *c0 = nullptr, *c1 = nullptr, *c2 = nullptr, *c3 = nullptr, *lo = nullptr,
              *hi = nullptr;
  float first_x = 0.0f, first_y = 0.0f, last_x = 1.0f, last_y = 1.0f;
};
void curve_row(const CurveRow& k, float* row, int n);

// ---- colour kernels (3-channel interleaved outputs)

// The surface gradient of row j from the rows above and below it, as the neighbourhood stages use
// it (surface.hpp: gradient_at, in single precision): interior columns
// gx = (mid[i+1] − mid[i−1])·central, the border columns one-sided (mid[1] − mid[0])·edge and
// (mid[n−1] − mid[n−2])·edge; gz = (down[i] − up[i])·kz (kz = central inside, edge on the first and
// last row, where up or down is the row itself). central = s·height_m/(2·cell_m), edge = 2·central
// (computed in double, rounded to float), s the vertical scale (1, or the hillshade's z factor).
struct GradientRows {
  const float *up = nullptr, *mid = nullptr, *down = nullptr;
  float central = 0.0f, edge = 0.0f, kz = 0.0f;
};

// Colour by elevation levels with the rock rule, the brightness speckle and surface water:
//   e      = height (divided by max_height when relative)
//   colour = bands: the first level with e ≤ at (the last level above all);
//            gradient: the first colour up to at[0], the last from at[K−1], linear in between
//   rock   where rock_min < e < rock_max and slope > rock_gate: colour → rock colour with weight
//          w = smoothstep((slope° − rock_slope°)/rock_blend°); w = 1 when rock_blend = 0 or
//          slope ≥ rock_full_gate (the angle, an atan for |∇y|² input, is only evaluated for
//          vectors with a sample inside the blend band)
//   speckle colour · (1 + variation·(2v − 1)), v = a0 + (a1 − a0)·tz, then clamped to [0, 1]
//   water  where cover w > 0: colour + (water colour − colour)·w
// The level search is branch-free: a chain of selects, or, when the levels are sorted and fit in a
// vector, a count of the levels below e and a lane permutation (color_level_tables). Both give
// the same colours.
struct ColorRow {
  int levels = 1;
  const float *at = nullptr, *r = nullptr, *g = nullptr, *b = nullptr;  // `levels` entries
  const float* tables = nullptr;  // color_level_tables(*this), or null for the select chain
  bool gradient = false;
  bool relative = false;
  float max_height = 1.0f;
  bool rock = false;
  bool slope_is_gradient2 = true;  // slope input: |∇y|² (m/m)² when true, degrees when false
  float rock_min = 0.0f, rock_max = 1.0f;  // float thresholds, compared strictly
  float rock_gate = 0.0f;       // rock where slope > this: tan²(rock_slope) or float_at_most(rock_slope°)
  float rock_full_gate = 0.0f;  // w = 1 where slope ≥ this: tan²(rock_slope + blend) or its degrees
  float rock_slope_deg = 35.0f, rock_blend_deg = 0.0f;
  float rock_r = 0, rock_g = 0, rock_b = 0;
  bool speckle = false;
  float variation = 0.0f;
  float water_r = 0, water_g = 0, water_b = 0;
};

// Lanes in one row of the lookup tables: levels beyond this use the select chain.
constexpr int kLevelLanes = 16;
// The level lookup tables of k (8 rows of kLevelLanes floats, indexed by the number of levels
// below e), or an empty vector when the levels are not sorted (at non-decreasing) or more than
// kLevelLanes. Reads k.levels, at, r, g, b, gradient.
std::vector<float> color_level_tables(const ColorRow& k);

// One row of the colour stage: heights rows.mid (n values; rows.up/down and the gradient factors
// only used for the rock rule without a slope layer), slope: n values of a slope layer in degrees
// or null (then |∇y|² from rows), a0, a1: the speckle noise of this row interpolated along x on
// the lattice rows below and above it (n + kRowPad readable; ignored without speckle), tz the
// weight between them; water: n cover values or null; rgb: 3n floats written.
void color_row(const ColorRow& k, const GradientRows& rows, const float* slope, const float* a0, const float* a1,
               float tz, const float* water, float* rgb, int n);

// Value-noise lattice row interpolated along x: out[i] = lat[ix[i]] + (lat[ix[i] + 1] − lat[ix[i]])·tx[i]
// for i in [0, n); ix and tx have n + kRowPad readable entries (padding: ix 0), lat ix + 2 entries.
void lattice_row(const float* lat, const std::int32_t* ix, const float* tx, float* out, int n);

// shade = ambient + (1 − ambient)·max(0, n·l), n ∝ (−fx, 1, −fz) with (fx, fz) the gradient of
// the rows (GradientRows, z factor included); under the sea (e < sea) shade = flat +
// water_relief·(shade − flat); colour = albedo·shade (white without albedo).
struct HillshadeRow {
  float lx = 0, ly = 1, lz = 0;
  float ambient = 0.2f, diffuse = 0.8f, flat = 1.0f, water_relief = 0.3f;
  float sea_below = 0.4f;  // e < this is under water (float_at_least(sea_level))
  // Non-temporal stores for rgb (surface.cpp: hillshade sets it for layers far beyond the caches): the
  // colour is written without first reading its cache lines. The same values either way.
  bool stream = false;
};
// rows: the height rows (n ≥ 1 values each); albedo: 3n or null; shade: n written (or null: not
// written); rgb: 3n written. One read of the three rows and the albedo, one write.
void hillshade_row(const HillshadeRow& k, const GradientRows& rows, const float* albedo, float* shade, float* rgb,
                   int n);

// The Highway target the kernels dispatch to in this process ("AVX3", "AVX2", "SSE4", …).
const char* pointwise_target();

}  // namespace relief::detail
