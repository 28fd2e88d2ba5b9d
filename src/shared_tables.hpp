#pragma once
// Internal: parameter sub-tables that several stages share (params.hpp: embed), so that a field
// such as `octaves` or `sea_deep` has one name, one range, one meaning and one description.
//
//   * NoiseFields: the fractal of the `noise` stage and of each `biomes` type.
//   * SeaColors:   the sea and beach colouring of `biomes` and `climate`.
//   * Sea-relative thresholds: the `color` levels and the `tilemap` types are written for a
//     reference sea level (0.4) and follow the world's sea level.
#include <algorithm>
#include <string>

#include "relief/noise.hpp"
#include "relief/params.hpp"

namespace relief::detail {

// ---- noise ------------------------------------------------------------------------------------

inline const ChoiceNames<NoiseBasis>& noise_basis_names() {
  static const ChoiceNames<NoiseBasis> n{{NoiseBasis::Gradient, "gradient"}, {NoiseBasis::Perlin, "perlin"},
                                         {NoiseBasis::Simplex, "simplex"},   {NoiseBasis::Value, "value"},
                                         {NoiseBasis::Cellular, "cellular"}};
  return n;
}
inline const ChoiceNames<Fractal>& fractal_names() {
  static const ChoiceNames<Fractal> n{{Fractal::None, "none"}, {Fractal::Fbm, "fbm"}, {Fractal::Ridged, "ridged"},
                                      {Fractal::Billow, "billow"}};
  return n;
}

// The first octave's frequency has one meaning everywhere: `frequency` cycles across the world
// width. `wavelength_m` is the stated alternative: when > 0 it replaces `frequency` (the first
// octave repeats every wavelength_m metres, whatever the world's width).
struct NoiseFields {
  NoiseBasis basis = NoiseBasis::Gradient;
  Fractal fractal = Fractal::Fbm;
  int octaves = 6;
  double frequency = 4.0;     // cycles across the world width (first octave)
  double wavelength_m = 0.0;  // > 0: first-octave wavelength in metres, instead of frequency
  double lacunarity = 2.0;
  double persistence = 0.5;
  double scale_x = 1.0, scale_z = 1.0;

  double frequency_per_m(double world_width_m) const {
    return wavelength_m > 0.0 ? 1.0 / wavelength_m : frequency / world_width_m;
  }
  // The fractal part of NoiseSettings (basis … scale); the caller sets the rest (seed, cellular,
  // period, warp).
  NoiseSettings settings(double world_width_m, std::uint64_t seed) const {
    NoiseSettings s;
    s.basis = basis;
    s.fractal = fractal;
    s.octaves = octaves;
    s.frequency = frequency_per_m(world_width_m);
    s.lacunarity = lacunarity;
    s.persistence = persistence;
    s.scale_x = scale_x;
    s.scale_z = scale_z;
    s.seed = seed;
    return s;
  }
};

inline Table<NoiseFields> noise_fields_table() {
  using N = NoiseFields;
  return {{
      choice(&N::basis, "basis", noise_basis_names(),
             "Noise basis: gradient (Perlin-equivalent, hashed, fastest), improved Perlin (seeded permutation), "
             "classic simplex, value or cellular (Worley)"),
      choice(&N::fractal, "fractal", fractal_names(),
             "How octaves combine: none (one octave), fBm, ridged (sharp crests), billow (puffy)"),
      param(&N::octaves, "octaves", 1, kMaxOctaves, "", "Number of octaves summed"),
      param(&N::frequency, "frequency", 0.01, 1000, "cycles/world",
            "Cycles of the first octave across the world width (unless wavelength_m is set)"),
      param(&N::wavelength_m, "wavelength_m", 0, 1e7, "m",
            "Alternative to frequency: the first octave's wavelength in metres (0 = use frequency)"),
      param(&N::lacunarity, "lacunarity", 1, 4, "", "Frequency ratio between successive octaves"),
      param(&N::persistence, "persistence", 0, 1, "", "Amplitude ratio between successive octaves (gain)"),
      param(&N::scale_x, "scale_x", 0.05, 20, "", "Anisotropy: frequency multiplier along x"),
      param(&N::scale_z, "scale_z", 0.05, 20, "", "Anisotropy: frequency multiplier along z"),
  }};
}

// ---- sea and beach colours ----------------------------------------------------------------------

struct SeaColors {
  Rgb sea_shallow{0.25f, 0.55f, 0.72f}, sea_deep{0.07f, 0.22f, 0.42f};
  double sea_deep_depth = 0.25;  // fraction of sea_level
  Rgb beach_color{0.87f, 0.80f, 0.58f};

  // Colour of a sea sample at elevation e ≤ sea: shallow at the surface, deep from
  // sea_deep_depth · sea below it (smoothstep in between).
  Rgb sea_at(double e, double sea) const {
    const double depth = sea > 0 ? (sea - e) / sea : 0.0;
    double s = std::clamp(depth / sea_deep_depth, 0.0, 1.0);
    const double w = s * s * (3.0 - 2.0 * s);
    return Rgb{float(sea_shallow.r + (sea_deep.r - sea_shallow.r) * w), float(sea_shallow.g + (sea_deep.g - sea_shallow.g) * w),
               float(sea_shallow.b + (sea_deep.b - sea_shallow.b) * w)};
  }
};

inline Table<SeaColors> sea_colors_table() {
  using S = SeaColors;
  return {{
      color(&S::sea_shallow, "sea_shallow", "Colour of shallow sea"),
      color(&S::sea_deep, "sea_deep", "Colour of deep sea"),
      param(&S::sea_deep_depth, "sea_deep_depth", 0.01, 1.0, "", "Depth (fraction of sea_level) where the sea is deep",
            Effect::Recolour),
      color(&S::beach_color, "beach_color", "Colour of the coast"),
  }};
}

// ---- thresholds relative to the sea level ---------------------------------------------------------

// The sea level that sea-relative thresholds (color levels, tilemap types) are written for.
constexpr double kReferenceSea = 0.4;

// Elevation e of a world with sea level `sea` as the thresholds see it: piecewise linear so that
// `sea` lands on kReferenceSea and 0 and 1 stay put (identity when sea == kReferenceSea).
inline double to_reference_elevation(double e, double sea) {
  if (sea == kReferenceSea) return e;
  if (e <= sea) return sea > 0 ? e * (kReferenceSea / sea) : kReferenceSea;
  return sea < 1 ? kReferenceSea + (e - sea) * ((1.0 - kReferenceSea) / (1.0 - sea)) : 1.0;
}
// The inverse: a threshold written for kReferenceSea, placed in a world with sea level `sea`
// (identity when sea == kReferenceSea).
inline double from_reference_elevation(double at, double sea) {
  if (sea == kReferenceSea) return at;
  if (at <= kReferenceSea) return at * (sea / kReferenceSea);
  return sea + (at - kReferenceSea) * ((1.0 - sea) / (1.0 - kReferenceSea));
}

// Gradient fBm of `octaves` octaves whose first octave has wavelength `wavelength_m` (gain 0.5,
// lacunarity 2): the slow climate fields of `biomes` (aridity, ruggedness) and `climate`
// (temperature, moisture).
inline NoiseSettings gradient_fbm(double wavelength_m, int octaves, std::uint64_t seed) {
  NoiseSettings s;
  s.basis = NoiseBasis::Gradient;
  s.fractal = Fractal::Fbm;
  s.octaves = octaves;
  s.frequency = 1.0 / wavelength_m;
  s.seed = seed;
  return s;
}

}  // namespace relief::detail
