#pragma once
// Running a recipe: the one function behind the CLI, the studio and the tests.
#include <cstdint>
#include <exception>
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

// Thrown by run() when RunOptions::cancelled returned true (not an Error: nothing was wrong with
// the input; the caller asked to stop, e.g. the studio superseding a generation by a newer one).
class Cancelled : public std::exception {
 public:
  const char* what() const noexcept override { return "cancelled"; }
};

// Where a resumed run starts: `terrain` is the state after stages [0, first_stage) of the same
// recipe, seed and window (e.g. a snapshot taken in after_stage by an earlier run). It is copied,
// never modified, and must stay alive for the duration of run(). Because stages depend only on
// their input terrain, params, seed and index, the result is byte-identical to a full run.
struct Resume {
  const Terrain* terrain = nullptr;
  int first_stage = 0;  // 0..stages.size(); stages.size() returns the snapshot itself
};

// A thread count as the machine can run it: 0 stays 0 (all), more than the hardware threads
// becomes their number (TBB would otherwise print a warning on the terminal). Results are
// identical for any count, so capping changes nothing but the chatter.
int capped_threads(int requested);

struct RunOptions {
  int threads = 0;  // 0 = all hardware threads; results are identical for any count (capped_threads)
  // Optional window of the world (default: the whole world of the recipe). Locality is enforced
  // (Stage::reach, stage.hpp): a window that is not the whole world on its grid (the world's
  // samples are world_width_m / spacing_m + 1 by world_depth_m / spacing_m + 1) is refused if a
  // stage is global (relief::Error naming `stages[i]` and why), and is computed on the window grown
  // by the sum of the stages' halos — each side grows while inside the world and stops at its edge
  // — then cropped. So every layer of a windowed run holds exactly the bits of the same samples of
  // a whole-map run, and windows tile seamlessly. after_stage and resume snapshots of a windowed
  // run cover the grown window (the result alone is cropped).
  std::optional<Frame> window;
  std::function<void(std::string_view stage, double fraction)> progress;
  // Called after each stage with a read-only view (the studio's and `--steps` stage strips).
  // Setting it turns fusion off, so that every stage's own output can be seen — unless
  // after_stage_keeps_fusion is set: then it is called only where a fused chain ends (after the
  // chain's last stage, with that stage's index) and after every stage outside a chain, and fusion
  // stays on (the studio's stage cache, which keeps snapshots at those boundaries).
  std::function<void(const Terrain&, const RecipeStage&, int index)> after_stage;
  bool after_stage_keeps_fusion = false;
  // Fusion: consecutive fusable stages (Stage::fusable — noise, island, redistribute, terrace,
  // curve) run in one pass over the rows, each row going through the whole chain while it is in
  // cache. The bytes are identical with and without fusion; off when after_stage is set (unless
  // after_stage_keeps_fusion).
  bool fuse = true;
  // Optional: a previous result's terrain whose buffers the new run may reuse (its layers are moved
  // into the new terrain's spare buffers; it is left without layers). Saves the page faults of
  // fresh allocations when regenerating, as the studio does on every change. Results are the same.
  Terrain* recycle = nullptr;
  // Start from a snapshot instead of an empty terrain (the studio's stage cache). The recipe
  // must have a seed (the snapshot was made with one); its frame must equal the run's frame.
  std::optional<Resume> resume;
  // Returning true stops the run by throwing relief::Cancelled. Checked before each stage, between
  // the row blocks of a row pass (at most 16 a pass: noise, island, redistribute, terrace and curve
  // stages, alone or fused), and inside long stages wherever they report progress (erosion steps,
  // droplet phases, thermal iterations, flow phases). Always called from the thread that called
  // run(), never concurrently; it should be cheap (an atomic flag, a clock).
  std::function<bool()> cancelled;
};

struct RunResult {
  Terrain terrain;
  std::uint64_t seed = 0;  // the seed used (drawn at random if the recipe had none)
  std::vector<StageTiming> timings;  // the stages that ran (from resume->first_stage on)
  double total_ms = 0;
};

// Estimated peak bytes for running `r` at its size and encoding its files in memory (as the CLI
// does), used to refuse sizes the machine cannot hold: the layers its stages leave (height, biome,
// climate, offset, water, colour, …), the largest stage scratch or encoder buffers (heightmap,
// colour PNGs, the OBJ text when with_mesh, the tilemap render), and the program itself.
// The per-stage part comes from each stage's declaration (StageDef::memory, stage.hpp).
// tests/test_memory.cpp holds it within a factor of 2 of the measured peak for several presets.
std::uint64_t estimate_memory_bytes(const Recipe& r, bool with_mesh);
// Physical memory of this machine in bytes (0 if unknown).
std::uint64_t physical_memory_bytes();
// A fresh random seed in 0..2^53−1 (from std::random_device; printed by the CLI).
std::uint64_t random_seed();

// Runs every stage in order (or from opt.resume->first_stage). If the recipe has no seed, one is
// drawn and returned in the result. Throws relief::Error on bad input (a resume with a different
// frame, an out-of-range first_stage or no seed names `resume` / `seed`) and relief::Cancelled
// when opt.cancelled says so; never prints, never exits.
RunResult run(const Recipe& r, const RunOptions& opt = {});

}  // namespace relief
