#pragma once
// Recipes: JSON documents naming the world and an ordered list of stages.
//
//   {
//     "name": "island", "description": "…", "seed": 7,          // seed optional
//     "world": {"size": [1025, 1025], "width_m": 4000, "height_m": 600, "sea_level": 0.4},
//     "stages": [ {"stage": "noise", "octaves": 6, …}, {"stage": "island", …}, … ],
//     "export": {"formats": "glb,fbx", "engine": "unity", "chunk_quads": 64, …}   // optional
//   }
//
// Field paths (`world.width_m`, `stages[1].octaves`, `seed`) are the same in error messages and
// in `--set PATH=VALUE` overrides.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "relief/export.hpp"
#include "relief/params.hpp"
#include "relief/stage.hpp"
#include "relief/terrain.hpp"

namespace relief {

constexpr std::uint64_t kMaxSeed = (std::uint64_t(1) << 53) - 1;  // exact in a JavaScript number
constexpr int kMinSize = 2;      // samples per axis, corners included (world.size, --size)
constexpr int kMaxSize = 32769;  // 2^15 + 1

// The "world" block, read and written by world_table() like a stage's parameters.
struct World {
  int nx = 513, nz = 513;   // samples per axis (corners included), kMinSize..kMaxSize
  double width_m = 4000;    // x extent; depth follows the aspect so that cells stay square
  double height_m = 600;    // metres between elevation 0 and 1
  double sea_level = 0.4;   // normalised
  Frame frame() const;      // the whole world as one window
};

// The optional "export" block: what `relief generate` writes when its command line does not say
// (its --formats and writer-option flags override it; --save-recipe writes the block in full, so a
// saved recipe reproduces the run's files byte for byte).
struct ExportSettings {
  std::string formats;    // as --formats: "" (written "default") = the default set, "all", or "a,b,c"
  ExportOptions options;  // writer options: export_options_table(), the CLI's --NAME flags
};
// Reads an "export" block; errors name `path`.NAME (unknown keys, bad values, unknown formats).
ExportSettings parse_export_settings(const json& block, const std::string& path = "export");
json export_settings_json(const ExportSettings& e);  // every option, and "formats"

struct RecipeStage {
  const StageDef* def = nullptr;
  std::string label;  // caption ("" = the stage's name)
  std::shared_ptr<const Stage> stage;
};

struct Recipe {
  std::string name = "custom";
  std::string description;
  std::optional<std::uint64_t> seed;
  World world;
  std::vector<RecipeStage> stages;
  std::optional<ExportSettings> export_settings;  // "export" (absent: default formats and options)

  // The fully resolved recipe: every parameter with its value, defaults filled in.
  json to_json() const;
};

// Parses and validates; throws relief::Error naming the field.
Recipe parse_recipe(const json& doc);
// Parses text (JSON syntax errors become Error("", "recipe is not valid JSON: …")).
Recipe parse_recipe_text(const std::string& text, const std::string& origin = "recipe");

// Applies `PATH=VALUE` to a recipe document. VALUE is read as JSON when it parses as JSON,
// otherwise as a string. PATH uses `a.b[2].c`; the parent must exist. Throws Error on a bad path.
void apply_override(json& doc, const std::string& assignment);

// The world's parameter table: size (N or [nx, nz]; written [nx, nz]), width_m, height_m,
// sea_level. Errors name `world.FIELD` (`world.size[1]`).
const Table<World>& world_table();
// Its ParamInfos, for explain and the studio.
std::vector<ParamInfo> world_params();

// ---- presets --------------------------------------------------------------------------------
struct PresetInfo {
  std::string name, description, origin;  // origin: "built-in" or the file path
};
// Built-in presets, then user presets from $RELIEF_PRESETS (':'-separated folders) and
// ~/.config/relief/presets (or $XDG_CONFIG_HOME/relief/presets). A user preset with a built-in's
// name replaces it. Unreadable files are skipped in the listing but reported when loaded.
std::vector<PresetInfo> list_presets();
// The recipe document of a preset; throws Error("preset", …) with the nearest name.
json load_preset(const std::string& name);

}  // namespace relief
