// Erosion and water stages: hydraulic, thermal, fill, flow (rivers and lakes), stream_power.
//
// Four of the five are Locality::Global: droplets start anywhere on the map and carry sediment
// along their whole path, and drainage depends on every cell between a sample and the sea, so they
// cannot run on a window with a finite halo. Thermal erosion is a Jacobi step over the four
// neighbours (each iteration reads two samples away: the neighbours' outflow reads theirs), so it
// is a neighbourhood stage with a halo of 2 · iterations samples. They read and write the "height" layer (normalised), do their physics in metres through the
// frame (height_m vertically, cell_m horizontally) and take every parameter in world units, so a
// 513² preview and a 2049² build of the same recipe erode alike. The algorithms and their sources
// are in erosion_hydraulic.cpp, erosion_thermal.cpp, stream_power.cpp and hydrology.cpp.
//
// The "flow" stage (this file) adds:
//   * D8 flow directions and flow accumulation on the ε-filled surface (layer "flow": drainage
//     area in m² of every sample);
//   * rivers where the drainage area passes river_area_km2, with discharge Q = A · runoff and
//     width w = width_coeff · Q^width_exponent (Leopold & Maddock, "The hydraulic geometry of
//     stream channels", USGS Prof. Paper 252, 1953), optionally carved to depth
//     carve_depth_coeff · Q^0.4 (same source); traced into Terrain::rivers as segments between
//     heads and confluences with their Strahler order (Strahler 1957);
//   * lakes: depressions at least lake_min_depth_m deep and lake_min_area_m2 large keep their
//     floor under a flat water surface at the spill level (Terrain::lakes); the others are filled;
//   * layer "water": surface-water cover 0..1 of each sample (lakes 1, rivers their width over the
//     cell size, anti-aliased), which the "color" stage paints with its water_color.
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "relief/erosion.hpp"
#include "relief/hydrology.hpp"
#include "relief/world_bounded.hpp"
#include "stream_power_detail.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

constexpr double kSecondsPerYear = 365.25 * 24 * 3600;

// The context's progress callback for this stage as a function of the fraction done (empty when
// nobody listens): the long stages below report after each step, phase or iteration.
std::function<void(double)> stage_progress(const Context& ctx, const char* name) {
  if (!ctx.progress) return {};
  return [&ctx, name](double f) { ctx.progress(name, f); };
}

Layer& height_layer(Terrain& t) {
  Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != t.frame.count())
    throw Error("", "layer 'height' does not match the frame's sample count");
  return h;
}

// ================================================================================== hydraulic

using HydraulicParams = erosion::HydraulicSettings;

void apply_hydraulic(Terrain& t, const HydraulicParams& p, const Context& ctx) {
  Layer& h = height_layer(t);
  erosion::hydraulic_erosion(h.data.data(), t.frame, p, ctx.stage_seed(kHydraulicSeedSalt), stage_progress(ctx, "hydraulic"));
}

// Global: a droplet moves at most lifetime · step_m from its start and erodes within
// brush_radius_m of its path, but each droplet runs over what the droplets before it left, so the
// stage's result at a sample depends on the whole map through its 16 passes. run() refuses the stage
// on a window (one run on a window grown by this halo is not the whole map's bits); world_hydraulic
// (relief/world_bounded.hpp) is exact by running the passes one after another over the whole world,
// each on groups of world blocks grown by the reach (erosion::hydraulic_erosion_part).
constexpr const char* kHydraulicWhy =
    "droplets start anywhere on the map, one after another, each changing the map the next one runs over";
Reach hydraulic_reach(const HydraulicParams& p, const Frame& f) {
  Reach r = global(kHydraulicWhy);
  r.halo = int(std::ceil((double(p.lifetime) * p.step_m + p.brush_radius_m) / f.cell_m()));
  return r;
}

void validate_hydraulic(const HydraulicParams& p, const std::string& path) {
  if (p.step_m > 2 * p.brush_radius_m)
    throw Error(path + ".step_m", "expected at most 2 × brush_radius_m (" + std::to_string(2 * p.brush_radius_m) +
                                      " m) so that the brush covers the path, got " + std::to_string(p.step_m));
}

// ==================================================================================== thermal

struct ThermalParams {
  double talus_deg = 33.0;
  double rate = 0.5;
  double distance_m = 60.0;
};

// Iterations read two samples away each (see the top of this file).
int thermal_iterations(double distance_m, double cell_m) { return int(std::ceil(distance_m / cell_m - 1e-9)); }
int thermal_halo(double distance_m, double cell_m) { return 2 * std::max(0, thermal_iterations(distance_m, cell_m)); }
Reach thermal_reach(const ThermalParams& p, const Frame& f) { return neighbourhood(thermal_halo(p.distance_m, f.cell_m())); }

void apply_thermal(Terrain& t, const ThermalParams& p, const Context& ctx) {
  Layer& h = height_layer(t);
  const int iterations = thermal_iterations(p.distance_m, t.frame.cell_m());
  std::vector<float> next(h.data.size());
  const auto progress = stage_progress(ctx, "thermal");
  for (int it = 0; it < iterations; ++it) {
    erosion::thermal_iteration(h.data.data(), next.data(), t.frame, p.talus_deg, p.rate);
    h.data.swap(next);
    if (progress) progress(double(it + 1) / iterations);
  }
  for (float& v : h.data) v = std::clamp(v, 0.0f, 1.0f);
}

// ======================================================================================= fill

struct FillParams {
  double epsilon_m = 0.0;
};

void apply_fill(Terrain& t, const FillParams& p, const Context&) {
  Layer& h = height_layer(t);
  const Frame& f = t.frame;
  const float sea = float(f.sea_level), eps = float(p.epsilon_m / f.height_m);
  if (!hydro::already_drains<float>(h.data.data(), f.nx, f.nz, sea))
    hydro::fill_depressions<float>(h.data.data(), f.nx, f.nz, sea, eps);
}

// ======================================================================================= flow

enum class Depressions { Lakes, Fill };

struct FlowParams {
  Depressions depressions = Depressions::Lakes;
  double epsilon_m = 0.0;
  double lake_min_depth_m = 1.0;
  double lake_min_area_m2 = 5000.0;
  double river_area_km2 = 0.2;
  double runoff_mm_per_year = 1000.0;
  double width_coeff = 5.0;
  double width_exponent = 0.5;
  double min_width_m = 0.0;
  double carve_depth_coeff = 0.0;
};

void apply_flow(Terrain& t, const FlowParams& p, const Context& ctx) {
  Layer& hl = height_layer(t);
  const Frame& f = t.frame;
  const int nx = f.nx, nz = f.nz;
  const std::size_t n = f.count();
  const float sea = float(f.sea_level);
  const double H = f.height_m, cell = f.cell_m(), cell2 = cell * cell;
  std::vector<float>& e = hl.data;

  // Filled surface, receivers, topological order and drainage area (in cells).
  std::vector<float> filled(e);
  const auto progress = stage_progress(ctx, "flow");
  // A height that already drains (a `fill` stage before this one) is not filled again: the
  // fill would change nothing (hydrology.hpp, already_drains), and the check is one cheap pass.
  if (!hydro::already_drains<float>(filled.data(), nx, nz, sea))
    hydro::fill_depressions<float>(filled.data(), nx, nz, sea, float(p.epsilon_m / H));
  if (progress) progress(0.7);  // the fill is most of the stage's time (bench: fill + d8 + accumulation)
  std::vector<std::uint32_t> rec(n), order, count(n);
  hydro::d8_receivers<float>(filled.data(), nx, nz, sea, rec.data());
  hydro::flow_order(rec.data(), n, order, count.data());
  if (progress) progress(0.85);

  // Depressions: connected cells raised by the fill. Keep the big, deep ones as lakes.
  t.lakes.clear();
  std::vector<std::int32_t> lake_id(n, -1);
  if (p.depressions == Depressions::Lakes) {
    std::vector<std::uint8_t> seen(n, 0);
    std::vector<std::uint32_t> cells, stack;
    for (std::size_t s = 0; s < n; ++s) {
      if (seen[s] || !(filled[s] > e[s])) continue;
      cells.clear();
      stack.assign(1, std::uint32_t(s));
      seen[s] = 1;
      while (!stack.empty()) {
        const std::uint32_t c = stack.back();
        stack.pop_back();
        cells.push_back(c);
        const int i = int(c % std::uint32_t(nx)), j = int(c / std::uint32_t(nx));
        for (int k = 0; k < 8; ++k) {
          const int a = i + hydro::kDi[k], b = j + hydro::kDj[k];
          if (a < 0 || b < 0 || a >= nx || b >= nz) continue;
          const std::size_t m = std::size_t(b) * nx + a;
          if (!seen[m] && filled[m] > e[m]) {
            seen[m] = 1;
            stack.push_back(std::uint32_t(m));
          }
        }
      }
      Lake lake;
      float level = 0;
      double max_depth = 0, volume = 0, sx = 0, sz = 0;
      for (std::uint32_t c : cells) {
        level = std::max(level, filled[c]);
        const double depth = (double(filled[c]) - e[c]) * H;
        max_depth = std::max(max_depth, depth);
        volume += depth * cell2;
      }
      lake.area_m2 = double(cells.size()) * cell2;
      if (max_depth < p.lake_min_depth_m || lake.area_m2 < p.lake_min_area_m2) continue;
      const std::int32_t id = std::int32_t(t.lakes.size());
      lake.level_m = f.y_m(level);
      lake.volume_m3 = volume;
      lake.max_depth_m = max_depth;
      lake.samples = cells.size();
      lake.x0_m = lake.z0_m = 1e300;
      lake.x1_m = lake.z1_m = -1e300;
      std::uint32_t outlet = cells[0], outlet_count = 0;
      for (std::uint32_t c : cells) lake_id[c] = id;
      for (std::uint32_t c : cells) {
        const int i = int(c % std::uint32_t(nx)), j = int(c / std::uint32_t(nx));
        const double x = f.x_m(i), z = f.z_m(j);
        sx += x, sz += z;
        lake.x0_m = std::min(lake.x0_m, x), lake.x1_m = std::max(lake.x1_m, x);
        lake.z0_m = std::min(lake.z0_m, z), lake.z1_m = std::max(lake.z1_m, z);
        if (lake_id[rec[c]] != id && count[c] > outlet_count) outlet = c, outlet_count = count[c];
      }
      lake.x_m = sx / double(cells.size());
      lake.z_m = sz / double(cells.size());
      lake.outlet_x_m = f.x_m(int(outlet % std::uint32_t(nx)));
      lake.outlet_z_m = f.z_m(int(outlet / std::uint32_t(nx)));
      t.lakes.push_back(lake);
    }
  }

  // Heights: the filled surface, except lake floors that stay under their water.
  for (std::size_t c = 0; c < n; ++c)
    if (lake_id[c] < 0) e[c] = filled[c];

  // Drainage area and rivers.
  Layer& flow = t.layer("flow", 1);
  for (std::size_t c = 0; c < n; ++c) flow.data[c] = float(double(count[c]) * cell2);
  const double runoff_m_s = p.runoff_mm_per_year * 1e-3 / kSecondsPerYear;
  auto discharge = [&](std::uint32_t c) { return double(count[c]) * cell2 * runoff_m_s; };
  auto width = [&](std::uint32_t c) {
    return std::max(p.min_width_m, p.width_coeff * std::pow(discharge(c), p.width_exponent));
  };
  const double threshold_cells = p.river_area_km2 * 1e6 / cell2;
  std::vector<std::uint8_t> channel(n, 0), channel_donors(n, 0), strahler(n, 0), top_donors(n, 0);
  for (std::size_t c = 0; c < n; ++c) channel[c] = double(count[c]) >= threshold_cells && e[c] >= sea;
  for (std::uint32_t c : order) {  // donors first: Strahler order and channel donor counts
    if (!channel[c]) continue;
    if (strahler[c] == 0) strahler[c] = 1;
    else if (top_donors[c] >= 2) ++strahler[c];
    const std::uint32_t r = rec[c];
    if (r == c || !channel[r]) continue;
    ++channel_donors[r];
    if (strahler[c] > strahler[r]) strahler[r] = strahler[c], top_donors[r] = 1;
    else if (strahler[c] == strahler[r]) ++top_donors[r];
  }

  // Carving, receivers first so that each channel cell stays above the one it drains to.
  if (p.carve_depth_coeff > 0) {
    for (std::size_t q = n; q-- > 0;) {
      const std::uint32_t c = order[q], r = rec[c];
      if (!channel[c] || lake_id[c] >= 0 || r == c) continue;
      const double depth = p.carve_depth_coeff * std::pow(discharge(c), 0.4);
      const float below = lake_id[r] >= 0 ? filled[r] : e[r];  // a lake's surface, else the carved receiver
      const float carved = std::max(float(double(e[c]) - depth / H), std::nextafter(below, 2.0f));
      e[c] = std::min(e[c], carved);
    }
  }

  // Water cover: lakes 1, rivers their width (anti-aliased disc where wider than a cell).
  Layer& water = t.layer("water", 1);
  std::fill(water.data.begin(), water.data.end(), 0.0f);
  for (std::size_t c = 0; c < n; ++c)
    if (lake_id[c] >= 0) water.data[c] = 1.0f;
  for (std::size_t c = 0; c < n; ++c) {
    if (!channel[c] || lake_id[c] >= 0) continue;
    const double w = width(std::uint32_t(c));
    if (w <= cell) {
      water.data[c] = std::max(water.data[c], float(w / cell));
      continue;
    }
    const int i = int(c % std::size_t(nx)), j = int(c / std::size_t(nx));
    const double r_cells = 0.5 * w / cell;
    const int R = int(std::ceil(r_cells + 0.5));
    for (int b = std::max(0, j - R); b <= std::min(nz - 1, j + R); ++b)
      for (int a = std::max(0, i - R); a <= std::min(nx - 1, i + R); ++a) {
        const std::size_t m = std::size_t(b) * nx + a;
        if (e[m] < sea) continue;
        const double cover = std::clamp(r_cells - std::hypot(double(a - i), double(b - j)) + 0.5, 0.0, 1.0);
        water.data[m] = std::max(water.data[m], float(cover));
      }
  }

  // River polylines: one per segment from a head or a confluence down to the next confluence, the
  // sea or the map edge.
  t.rivers.clear();
  auto vertex = [&](std::uint32_t c) {
    const int i = int(c % std::uint32_t(nx)), j = int(c / std::uint32_t(nx));
    RiverVertex v;
    v.x_m = f.x_m(i);
    v.z_m = f.z_m(j);
    v.y_m = std::max(0.0, f.y_m(lake_id[c] >= 0 ? filled[c] : e[c]));  // in a lake: its surface
    v.discharge_m3s = discharge(c);
    v.width_m = width(c);
    return v;
  };
  for (std::size_t s = 0; s < n; ++s) {
    if (!channel[s] || channel_donors[s] == 1) continue;
    River river;
    river.order = strahler[s];
    std::uint32_t c = std::uint32_t(s);
    for (;;) {
      river.vertices.push_back(vertex(c));
      const std::uint32_t r = rec[c];
      if (r == c) {
        river.end = "edge";
        break;
      }
      if (!channel[r]) {  // only the sea ends a channel: drainage area grows downstream
        RiverVertex mouth = vertex(r);
        mouth.y_m = 0.0;
        mouth.discharge_m3s = river.vertices.back().discharge_m3s;
        mouth.width_m = river.vertices.back().width_m;
        river.vertices.push_back(mouth);
        river.end = "sea";
        break;
      }
      if (channel_donors[r] >= 2) {
        river.vertices.push_back(vertex(r));
        river.end = "river";
        break;
      }
      c = r;
    }
    if (river.vertices.size() >= 2) t.rivers.push_back(std::move(river));
  }
}

// =============================================================================== stream power

enum class UpliftPattern { Height, Uniform };

struct StreamPowerParams {
  double uplift_mm_per_year = 2.0;
  UpliftPattern uplift_pattern = UpliftPattern::Height;
  double k = 1e-5;
  double m = 0.45;
  double n = 1.0;
  double duration_years = 1e6;
  int steps = 100;
  double rainfall = 1.0;
  double max_slope_deg = 40.0;
};

erosion::StreamPowerSettings settings_of(const StreamPowerParams& p) {
  erosion::StreamPowerSettings s;
  s.uplift_mm_per_year = p.uplift_mm_per_year;
  s.uplift_follows_height = p.uplift_pattern == UpliftPattern::Height;
  s.k = p.k;
  s.m = p.m;
  s.n = p.n;
  s.duration_years = p.duration_years;
  s.steps = p.steps;
  s.rainfall = p.rainfall;
  s.max_slope_deg = p.max_slope_deg;
  return s;
}

void apply_stream_power(Terrain& t, const StreamPowerParams& p, const Context& ctx) {
  Layer& h = height_layer(t);
  erosion::stream_power(h.data.data(), t.frame, settings_of(p), stage_progress(ctx, "stream_power"));
}

Table<StreamPowerParams> stream_power_table() {
  using P = StreamPowerParams;
  return Table<P>{{
      param(&P::uplift_mm_per_year, "uplift_mm_per_year", 0, 100, "mm/yr", "Tectonic uplift rate U"),
      choice(&P::uplift_pattern, "uplift_pattern", {{UpliftPattern::Height, "height"}, {UpliftPattern::Uniform, "uniform"}},
             "height: U scaled by the input land height (the input relief is the uplift map); uniform: U everywhere on land"),
      param(&P::k, "k", 0, 0.01, "m^(1-2m)/yr", "Erodibility K in dh/dt = U − K·A^m·S^n"),
      param(&P::m, "m", 0.1, 1.5, "", "Drainage-area exponent m (channel concavity θ = m/n)"),
      param(&P::n, "n", 0.5, 2.0, "", "Slope exponent n"),
      param(&P::duration_years, "duration_years", 0, 1e9, "yr", "Simulated time"),
      param(&P::steps, "steps", 1, 100000, "", "Implicit time steps over the duration"),
      param(&P::rainfall, "rainfall", 0.01, 100, "", "Uniform precipitation factor on the drainage area"),
      param(&P::max_slope_deg, "max_slope_deg", 1, 89, "deg",
            "Critical hillslope angle: steeper ground fails down to it (bounds the relief uplift can build)"),
  }};
}

}  // namespace

StageDef hydraulic() {
  using P = HydraulicParams;
  Table<P> table{{
      param(&P::droplets_per_km2, "droplets_per_km2", 0, 1e7, "1/km²",
            "Droplets per km² of the map (so previews and builds get the same rain); starts over the sea are skipped"),
      param(&P::lifetime, "lifetime", 1, 1000, "steps", "Maximum steps of one droplet"),
      param(&P::step_m, "step_m", 0.01, 1000, "m", "Distance a droplet moves per step (at most 2 × brush_radius_m)"),
      param(&P::brush_radius_m, "brush_radius_m", 0.01, 1000, "m", "Radius over which a droplet erodes (it deposits on the four cells around it)"),
      param(&P::inertia, "inertia", 0, 1, "", "0: droplets follow the slope; 1: they keep their direction"),
      param(&P::capacity, "capacity", 0, 1000, "s/m",
            "Sediment capacity factor: capacity = max(−drop · speed · water · capacity, min_capacity) · brush area"),
      param(&P::min_capacity, "min_capacity", 0, 100, "m",
            "Capacity floor on flat ground, as metres of mean height over the brush"),
      param(&P::erode, "erode", 0, 1, "", "Fraction of the free capacity eroded per step"),
      param(&P::deposit, "deposit", 0, 1, "", "Fraction of the excess sediment deposited per step"),
      param(&P::evaporate, "evaporate", 0, 1, "", "Fraction of the water evaporating per step"),
      param(&P::gravity, "gravity", 0, 100, "m/s²", "Speed² gained per metre of descent"),
  }};
  StageDef d = make_stage<P>("hydraulic",
                       "Droplet hydraulic erosion (Beyer 2015, Lague's parameters): carves gullies and fills hollows",
                       global(kHydraulicWhy), std::move(table), apply_hydraulic, validate_hydraulic, hydraulic_reach,
                       "bounded: lifetime · step_m + brush_radius_m (a droplet's longest reach), not exact on a window");
  d.halo = hydraulic_reach(P{}, Frame{}).halo;  // with the default params on the default world
  d.memory = {{}, {}, 12, {}};
  return d;
}

StageDef thermal() {
  using P = ThermalParams;
  Table<P> table{{
      param(&P::talus_deg, "talus_deg", 0, 89.9, "deg", "Talus angle: steeper slopes shed material downhill"),
      param(&P::rate, "rate", 0.01, 0.5, "", "Fraction of the excess height difference moved per iteration"),
      param(&P::distance_m, "distance_m", 0, 100000, "m",
            "How far material may slide: runs ceil(distance_m / cell size) iterations, so previews and builds settle alike"),
  }};
  StageDef d = make_stage<P>("thermal", "Thermal erosion (Musgrave 1989, Olsen 2004): slopes relax to the talus angle",
                       neighbourhood(thermal_halo(P{}.distance_m, Frame{}.cell_m())), std::move(table), apply_thermal,
                       nullptr, thermal_reach, "2 · ceil(distance_m / cell size) samples (two per iteration)");
  d.memory = {{}, {}, 8, {}};
  return d;
}

StageDef fill() {
  using P = FillParams;
  Table<P> table{{
      param(&P::epsilon_m, "epsilon_m", 0, 10, "m",
            "Gradient given to filled flats, metres per sample towards the spill point (0: the smallest float step)"),
  }};
  StageDef d = make_stage<P>("fill",
                       "Depression filling (Priority-Flood+ε, Barnes 2014 / Zhou 2016): every land sample drains to the "
                       "sea or the map edge",
                       global("every sample must drain to the sea or the map's edge, through the whole map"),
                       std::move(table), apply_fill);
  d.memory = {{}, {}, 16, {}};
  return d;
}

StageDef flow() {
  using P = FlowParams;
  Table<P> table{{
      choice(&P::depressions, "depressions", {{Depressions::Lakes, "lakes"}, {Depressions::Fill, "fill"}},
             "lakes: keep deep, large depressions as lakes at their spill level (fill the rest); fill: fill all"),
      param(&P::epsilon_m, "epsilon_m", 0, 10, "m", "Gradient given to filled flats, metres per sample (0: smallest float step)"),
      param(&P::lake_min_depth_m, "lake_min_depth_m", 0, 10000, "m", "A depression becomes a lake if at least this deep"),
      param(&P::lake_min_area_m2, "lake_min_area_m2", 0, 1e12, "m²", "… and at least this large"),
      param(&P::river_area_km2, "river_area_km2", 0.0001, 1e6, "km²", "Drainage area where a river begins"),
      param(&P::runoff_mm_per_year, "runoff_mm_per_year", 0, 100000, "mm/yr",
            "Water reaching the rivers per year: discharge = drainage area · runoff"),
      param(&P::width_coeff, "width_coeff", 0, 1000, "m", "River width = width_coeff · discharge^width_exponent (Leopold & Maddock)"),
      param(&P::width_exponent, "width_exponent", 0, 1, "", "Exponent of discharge in the river width (0.5 typical)"),
      param(&P::min_width_m, "min_width_m", 0, 10000, "m", "Rivers are at least this wide (map legibility)"),
      param(&P::carve_depth_coeff, "carve_depth_coeff", 0, 1000, "m",
            "Carve rivers to depth carve_depth_coeff · discharge^0.4 (0: no carving); channels keep draining downhill"),
  }};
  StageDef d = make_stage<P>("flow",
                       "D8 flow and accumulation: layers 'flow' (drainage m²) and 'water', rivers (rivers.json) and "
                       "lakes (lakes.json)",
                       global("drainage area accumulates over every sample upstream, and depressions fill "
                              "through the whole map"),
                       std::move(table), apply_flow);
  // receivers, order, donor counts, lake ids (u32), visit and channel flags, the flood queue
  d.memory = {{{"flow", 1}, {"water", 1}}, {}, 16 + 2 + 5 + 16, {}};
  return d;
}

StageDef stream_power() {
  using P = StreamPowerParams;
  Table<P> table = stream_power_table();
  StageDef d = make_stage<P>("stream_power",
                       "Stream-power uplift and incision (Braun & Willett 2013, Cordonnier 2016): drainage networks "
                       "and ranges, lakes resolved each step",
                       global("incision depends on the drainage area, which accumulates over the whole map"),
                       std::move(table), apply_stream_power);
  // h and uplift (double), receivers, stack and donor counts (u32), Priority-Flood's queue
  d.memory = {{}, {}, 16 + 12 + 16, {}};
  return d;
}

}  // namespace relief::stages

namespace relief::erosion::detail {
StreamPowerSettings stream_power_settings(const json& params) {
  const Table<stages::StreamPowerParams> table = stages::stream_power_table();
  json own = json::object();
  for (const auto& f : table.fields)
    if (params.contains(f.info.name)) own[f.info.name] = params.at(f.info.name);
  return stages::settings_of(table.read(own, "stream_power"));
}
}  // namespace relief::erosion::detail
