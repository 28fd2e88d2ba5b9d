#pragma once
// relief::generate: one call from a recipe to files. Every front end (the CLI's `relief generate`,
// the studio's /api/export, `relief bench`'s preset cases, and the Python, Blender and world
// front ends to come) fills GenerateSettings and calls it; none re-implements the writing policy:
//
//   1. plan      — which writers run (select_writers: the default set, "all" or a list, plus the
//                  writers a chosen one implies, WriterDef::implies), the writer options validated,
//                  engine legality (check_engine_size), the memory policy (check_memory);
//                  every refusal is a relief::Error naming the field, before any work is done;
//   2. run       — the recipe's stages (relief::run), or a terrain the caller already has;
//   3. encode    — the writers, concurrently (one task each), into the Output;
//   4. report    — report.json (when planned) with per-stage and per-writer timings, peak memory
//                  and "files", the manifest of every file the run writes into `out`;
//   5. commit    — the Output's files become visible together, and only if every writer succeeded
//                  (Output::prepare then Output::publish, with any `also_commit` outputs in the same
//                  two phases): a failed or cancelled run changes no file.
//
// Threading: the stages and the writers run on `threads` threads (0 = all). Determinism: the
// bytes of every file depend only on the recipe, its seed and the writer options — never on the
// thread count, the Output kind or the order in which the writers finish.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "relief/export.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

namespace relief {

// ---- memory policy (one for every front end) ------------------------------------------------
// A run is refused when estimate_memory_bytes(recipe, with_mesh) exceeds this many bytes:
// kMemoryBudgetPercent % of this machine's physical memory (no limit when that is unknown).
constexpr int kMemoryBudgetPercent = 80;
std::uint64_t memory_budget_bytes();
// Throws Error("world.size", …) when a run of `r` (with meshes when `with_mesh`) would need more than
// `budget_bytes` (0 = memory_budget_bytes()). The message gives both figures and what to change.
void check_memory(const Recipe& r, bool with_mesh, std::uint64_t budget_bytes = 0);

// ---- writer selection --------------------------------------------------------------------------
struct WriterPlan {
  std::vector<const WriterDef*> writers;  // registry order, implied writers included, no duplicates
  // Writers asked for by name (or implied by one): each runs, and one whose input the terrain lacks
  // (WriterDef::applies false, WriterDef::needs set) is an Error naming it and what it needs.
  // Writers that came from "default" or "all" are skipped for a terrain they do not apply to.
  std::vector<const WriterDef*> named;
  bool is_named(const WriterDef* w) const;
  bool with_mesh() const;  // any writer that builds a terrain mesh (memory estimate)
  bool has(std::string_view writer) const;
};
// `formats`: comma-separated items, each a writer name, "default" (the default set), "all" (every
// writer; "engine" only when an engine is chosen) or "-NAME" (leave that writer out, e.g.
// "default,-obj"); "" alone is the default set. Adds
// WriterDef::implies of every chosen writer, and the engine writer when options.engine is not
// "none". Errors name `path` (the CLI: "--formats"), with the nearest known name for a typo; an
// empty item list (",") is an error.
WriterPlan select_writers(const std::string& formats, const ExportOptions& options, const std::string& path = "export.formats");

// ---- generate ---------------------------------------------------------------------------------
struct GenerateSettings {
  Recipe recipe;  // parsed and validated (parse_recipe); without a seed one is drawn (report.seed)
  // Writers, as select_writers takes them; std::nullopt: the recipe's export.formats, else the
  // default set. `formats_path` names it in errors.
  std::optional<std::string> formats;
  std::string formats_path = "export.formats";
  // Writer options; std::nullopt: the recipe's export block's options, else the defaults.
  // `option_path(name)` names an option in errors (the CLI: "--stl-size-mm"); empty: "export.NAME".
  std::optional<ExportOptions> options;
  std::function<std::string(const std::string&)> option_path;
  std::string size_path = "world.size";  // what engine-size errors tell the user to change (CLI: "--size")
  int threads = 0;  // 0 = all hardware threads; the bytes are the same for any count
  // Progress of the whole call: (what, fraction 0..1): stages up to 0.7, then the writers. Called
  // from one thread at a time.
  std::function<void(std::string_view what, double fraction)> progress;
  // Checked where run() checks RunOptions::cancelled (before each stage, between row blocks, inside
  // long stages) and before each writer; true stops the call with relief::Cancelled (no file
  // changed). Called from one thread at a time.
  std::function<bool()> cancelled;
  // Called after each stage with a read-only view (e.g. the CLI's --steps pictures); turns fusion off.
  std::function<void(const Terrain&, const RecipeStage&, int index)> after_stage;
  // A terrain of exactly this recipe, seed and frame that the caller already has (the studio's
  // stage cache): the stages are not run; `timings` are reported as the run's. Needs recipe.seed.
  const Terrain* terrain = nullptr;
  std::vector<StageTiming> timings;
  // Memory policy (check_memory): 0 = memory_budget_bytes().
  std::uint64_t memory_budget_bytes = 0;
  // Called after the writers and the report, before the commit: the place to put further files
  // into `also_commit` outputs (step pictures, a saved recipe) so they are part of the one commit.
  // `recipe` is the resolved recipe as run (seed and export settings filled in).
  std::function<void(const Terrain&, const Recipe& recipe)> before_commit;
  // Outputs committed together with the main one (prepared first, all of them, then published).
  std::vector<Output*> also_commit;
};

struct GeneratedFile {
  std::string name;    // file name within the Output, e.g. "terrain.obj"
  std::string writer;  // the writer that wrote it
  std::uint64_t bytes = 0;
};

struct GenerateReport {
  std::uint64_t seed = 0;
  Recipe recipe;  // as run: seed set, export settings = the writers that ran and every option
  std::vector<GeneratedFile> files;      // in name order
  std::vector<StageTiming> timings;      // per stage (from the run, or GenerateSettings::timings)
  double generate_ms = 0;                // the stages
  std::vector<std::pair<std::string, double>> encode_ms;  // per writer that ran, in plan order
  double total_ms = 0;
  std::uint64_t peak_memory_bytes = 0;   // this process's peak resident set so far
  std::vector<std::string> skipped;      // writers of the default set or "all" that did not apply
};

// Step 1 alone: what generate(settings, …) would write, without running anything. Throws the
// errors generate() throws while planning (formats, writer options, engine size, memory), naming
// the same fields. Front ends use it to check their own files against the run's (the CLI refuses a
// --save-recipe name the run writes).
struct GeneratePlan {
  ExportOptions options;     // the writer options in force, validated
  OptionPath option_path;    // how errors name an option (settings.option_path, else "export.NAME")
  std::string formats_path;  // how errors name the format list (settings.formats_path or "export.formats")
  WriterPlan writers;        // select_writers' plan
  // The files the planned writers declare (WriterDef::files, in plan order; bytes 0). Chunked and
  // LOD writers may add numbered names; writers that do not apply to the terrain write none.
  std::vector<GeneratedFile> files;
};
GeneratePlan plan(const GenerateSettings& settings);

// Plans, runs, encodes and commits as described at the top of this file. Throws relief::Error for
// bad input (naming the field; nothing is written), relief::Cancelled when settings.cancelled
// says so, and lets std::bad_alloc through. `out` receives every file; when it is a FileOutput in
// OnCommit mode nothing becomes visible before the commit at the end.
GenerateReport generate(GenerateSettings settings, Output& out);

// The terrain as run, alongside the report (front ends that also show the terrain: the Python
// module, the studio). Same as generate() otherwise.
struct Generated {
  GenerateReport report;
  Terrain terrain;
};
Generated generate_keep(GenerateSettings settings, Output& out);

// A byte count for people: "812 B", "3.4 KiB", "1.5 MiB", "2.25 GiB" (the memory-policy errors,
// the CLI's summary).
std::string human_bytes(std::uint64_t bytes);
// This process's peak resident set so far, in bytes (getrusage; GenerateReport::peak_memory_bytes).
std::uint64_t peak_rss_bytes();

}  // namespace relief
