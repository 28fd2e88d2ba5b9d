#pragma once
// Internal: shared pieces of the feature stages (stage_features.cpp), exposed for tests.
#include <cstdint>
#include <string>
#include <vector>

#include "relief/terrain.hpp"

namespace relief::detail {

// A lifted disk: amplitude · (1 − (d/r)²)² inside radius r (a smooth bump, so that stacking many
// does not leave the stair steps a flat disk would).
struct Circle {
  double x_m = 0, z_m = 0, r_m = 1, amp = 0;
};
double circles_at(const std::vector<Circle>& cs, double x_m, double z_m);
// Adds Σ circles to `acc` (one value per sample of the frame), row-parallel; each sample sums its
// circles in list order, so the result does not depend on the thread count.
void add_circles(const Frame& fr, const std::vector<Circle>& cs, std::vector<double>& acc);

// Bilinear elevation of a one-channel layer at world position (clamped to the window). Window
// independent: the position is taken to world-grid units (x_m / cell) before the window's offset is
// subtracted, so any window holding the 2 × 2 samples around the position gives the whole map's bits.
double sample_bilinear(const Frame& fr, const Layer& l, double x_m, double z_m);
// Nearest-sample value of a layer (channel c) at world position (clamped to the window): the world
// sample llround(x_m / cell), llround(z_m / cell), window independent as sample_bilinear.
float sample_nearest(const Frame& fr, const Layer& l, double x_m, double z_m, int c = 0);

// Index of the legend entry named `name` in t.biomes, appended with the given colour if missing.
int legend_id(Terrain& t, const std::string& name, float r, float g, float b);

}  // namespace relief::detail
