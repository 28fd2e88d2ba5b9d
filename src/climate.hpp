#pragma once
// Internal: the Whittaker-style classification of the `climate` stage (stage_climate.cpp), and the
// distance transform it uses, exposed for tests.
#include <string>
#include <vector>

#include "relief/params.hpp"

namespace relief::detail {

// One row of the table: land whose temperature t and moisture m fall in
// [temperature_min, temperature_max) × [moisture_min, moisture_max) (a maximum of 1 includes 1)
// is this biome. Rows are tried in order; the first match wins. Rows may share a name (a biome
// spanning several rectangles) if they share the colour.
struct ClimateBiome {
  std::string name = "grassland";
  Rgb color{0.53f, 0.67f, 0.33f};
  std::string texture;
  double tile_m = 64;
  double temperature_min = 0, temperature_max = 1, moisture_min = 0, moisture_max = 1;
};

// Thirteen land biomes after Whittaker (1975) as simplified by Amit Patel's "Polygonal Map
// Generation for Games" (Red Blob Games, 2010), with temperature in place of his elevation zones:
// cold (< 0.25): scorched, bare rock, tundra, snow; cool: temperate desert, shrubland, taiga;
// temperate: temperate desert, grassland, temperate forest, temperate rainforest; hot (≥ 0.75):
// subtropical desert, grassland, tropical seasonal forest, tropical rainforest.
std::vector<ClimateBiome> whittaker_table();

// Index of the first row matching (t, m), or −1.
int classify(const std::vector<ClimateBiome>& table, double temperature, double moisture);

// Exact Euclidean distance transform (P. F. Felzenszwalb, D. P. Huttenlocher, "Distance Transforms
// of Sampled Functions", Theory of Computing 8, 2012): for an nx × nz grid where `source` is true,
// returns each sample's distance, in samples, to the nearest source sample (+∞ with no source).
// Two passes of the 1-D lower envelope of parabolas, O(nx · nz); row/column parallel, exact.
std::vector<float> distance_transform(const std::vector<unsigned char>& source, int nx, int nz);

// The same transform, bounded for tiled worlds: each sample's distance (in samples) to the nearest
// source when it is less than `cap` samples, +∞ otherwise (no source nearer). The test is made on
// the exact integer squared distance d² (d² ≤ within_limit(cap), the largest integer below cap²),
// before any rounding, so the answer is a function of the true d² alone. Window independence: a
// source nearer than `cap` lies within within_halo(cap) samples (Chebyshev) of the sample, so on
// any window that holds every sample within that halo of a sample, the result at the sample equals
// the whole map's bit for bit (farther sources can only make the window's d² larger, and it is
// already beyond the limit on the whole map).
double within_limit(double cap);  // ceil(cap²) − 1 (−1 when cap ≤ 0)
int within_halo(double cap);      // floor(√within_limit(cap)): the Chebyshev reach of the test
std::vector<float> distance_transform_within(const std::vector<unsigned char>& source, int nx, int nz, double cap);

}  // namespace relief::detail
