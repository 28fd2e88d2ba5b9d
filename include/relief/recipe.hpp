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
// Built-in presets, then user presets: the recipe files (NAME.json) in `user_dirs`, searched in
// order (earlier folders win). A user preset with a built-in's name replaces it. Unreadable files
// are skipped in the listing but reported when loaded. The library reads no environment variable:
// front ends pass the folders (the CLI and the studio pass user_preset_dirs() of their environment).
std::vector<PresetInfo> list_presets(const std::vector<std::string>& user_dirs = {});
// The recipe document of a preset (searched as list_presets does); throws Error("preset", …) with
// the nearest name. Presets are not files a recipe path is relative to: a texture a user preset
// names resolves against the working directory, as does one in a recipe given as a document.
json load_preset(const std::string& name, const std::vector<std::string>& user_dirs = {});
// The user preset folders of the usual convention, from the values of the environment variables of
// the same names (nullptr = unset): every folder of $RELIEF_PRESETS (':'-separated, empty items
// skipped), then $XDG_CONFIG_HOME/relief/presets when XDG_CONFIG_HOME is set and not empty, else
// $HOME/.config/relief/presets (nothing when HOME is unset or empty too).
std::vector<std::string> user_preset_dirs(const char* relief_presets, const char* xdg_config_home, const char* home);

// ---- recipe files ---------------------------------------------------------------------------
// File names in a recipe (every "texture" of colour levels, biome types and their colours, and
// climate table entries; the "path" of an image stage) are relative to the recipe file's folder,
// not to the working directory.
//
// Reads a recipe file: its JSON (parse_json, depth-limited) with every relative file name resolved
// by resolve_recipe_files against the file's folder. Throws Error("recipe", …) when the file
// cannot be read or is not valid JSON. The returned document holds absolute file names, so a
// resolved recipe written from it (Recipe::to_json, --save-recipe) finds the same files from any
// folder. Values put into the document afterwards (the CLI's --set) are not touched: a file name
// typed on the command line is relative to the working directory.
json read_recipe_file(const std::string& path);
// Rewrites every relative, non-empty string named "texture" under doc["stages"], and the "path"
// of every {"stage": "image", …}, to
// base_dir / NAME, made absolute (against the working directory) and lexically normal. Absolute
// names, empty strings and non-string values (the tilemap's numeric `texture`) stay as they are.
void resolve_recipe_files(json& doc, const std::string& base_dir);

}  // namespace relief
