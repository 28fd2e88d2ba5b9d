#pragma once
// Running a recipe: the one function behind the CLI, the studio and the tests.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "relief/recipe.hpp"
#include "relief/terrain.hpp"

namespace relief {

struct StageTiming {
  std::string name, label;
  double ms = 0;
  // The stage ran in one pass over the rows together with the stages before it (see
  // RunOptions::fuse). A fused chain's whole wall time is reported on its first stage; the later
  // stages of the chain report 0 ms and fused = true.
  bool fused = false;
};

struct RunOptions {
  int threads = 0;  // 0 = all hardware threads; results are identical for any count
  // Optional window of the world (default: the whole world of the recipe). Pointwise stages
  // give identical samples wherever a window falls, so windows tile seamlessly.
  std::optional<Frame> window;
  std::function<void(std::string_view stage, double fraction)> progress;
  // Called after each stage with a read-only view (the studio's and `--steps` stage strips).
  // Setting it turns fusion off, so that every stage's own output can be seen.
  std::function<void(const Terrain&, const RecipeStage&, int index)> after_stage;
  // Fusion: consecutive fusable stages (Stage::fusable — noise, island, redistribute, terrace,
  // curve) run in one pass over the rows, each row going through the whole chain while it is in
  // cache. The bytes are identical with and without fusion; off when after_stage is set.
  bool fuse = true;
  // Optional: a previous result's terrain whose buffers the new run may reuse (its layers are moved
  // into the new terrain's spare buffers; it is left without layers). Saves the page faults of
  // fresh allocations when regenerating, as the studio does on every change. Results are the same.
  Terrain* recycle = nullptr;
};

struct RunResult {
  Terrain terrain;
  std::uint64_t seed = 0;  // the seed used (drawn at random if the recipe had none)
  std::vector<StageTiming> timings;
  double total_ms = 0;
};

// Estimated peak bytes for running `r` at its size, used to refuse sizes the machine cannot hold.
std::uint64_t estimate_memory_bytes(const Recipe& r, bool with_mesh);
// Physical memory of this machine in bytes (0 if unknown).
std::uint64_t physical_memory_bytes();
// A fresh random seed in 0..2^53−1 (from std::random_device; printed by the CLI).
std::uint64_t random_seed();

// Runs every stage in order. If the recipe has no seed, one is drawn and returned in the result.
// Throws relief::Error on bad input; never prints, never exits.
RunResult run(const Recipe& r, const RunOptions& opt = {});

}  // namespace relief
