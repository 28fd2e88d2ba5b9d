// Recipe parsing, the parameter table, overrides and presets.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>

#include "relief/noise.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "support.hpp"

using namespace relief;

namespace {

// The Error parse_recipe throws for doc, if any.
std::optional<Error> parse_error(const json& doc) {
  try {
    parse_recipe(doc);
  } catch (const Error& e) {
    return e;
  }
  return std::nullopt;
}

std::string error_of(const json& doc) {
  const auto e = parse_error(doc);
  return e ? e->what() : "";
}

json minimal() {
  return json::parse(R"({"world": {"size": 33}, "stages": [{"stage": "noise", "octaves": 4}]})");
}

// The error of minimal() with its stage's `key` set to `value` ("" when it parses).
std::string stage_error(const std::string& key, const json& value) {
  json doc = minimal();
  doc["stages"][0][key] = value;
  return error_of(doc);
}

}  // namespace

TEST(Recipe, DefaultsAreFilledIn) {
  Recipe r = parse_recipe(minimal());
  ASSERT_EQ(r.stages.size(), 1u);
  json j = r.to_json();
  EXPECT_EQ(j["stages"][0]["octaves"], 4);
  EXPECT_EQ(j["stages"][0]["lacunarity"], 2.0);  // default from the table
  EXPECT_EQ(j["world"]["size"], json::array({33, 33}));
  EXPECT_FALSE(j.contains("seed"));
}

TEST(Recipe, ResolvedRecipeRoundTrips) {
  json doc = minimal();
  doc["seed"] = 99;
  Recipe a = parse_recipe(doc);
  Recipe b = parse_recipe(a.to_json());
  EXPECT_EQ(a.to_json().dump(), b.to_json().dump());
  EXPECT_EQ(*b.seed, 99u);
}

TEST(Recipe, OutOfRangeIntegerNamesFieldExpectedAndGot) {
  EXPECT_EQ(stage_error("octaves", 40), "stages[0].octaves: expected an integer in 1..16, got 40");
}

TEST(Recipe, WrongTypeNamesField) {
  EXPECT_EQ(stage_error("octaves", "six"), "stages[0].octaves: expected an integer in 1..16, got \"six\"");
  EXPECT_EQ(stage_error("octaves", 4.5), "stages[0].octaves: expected an integer in 1..16, got 4.5");
}

TEST(Recipe, NonFiniteFloatIsRejected) {
  // JSON has no NaN literal; nlohmann stores NaN from code, which is how a caller could pass it.
  EXPECT_NE(stage_error("lacunarity", std::nan(""))
                .find("stages[0].lacunarity: expected a number in 1..4, got a non-finite value"),
            std::string::npos);
}

TEST(Recipe, UnknownStageSuggestsNearest) {
  const std::string e = stage_error("stage", "noize");
  EXPECT_NE(e.find("stages[0].stage: unknown stage \"noize\" (did you mean 'noise'?)"), std::string::npos) << e;
}

TEST(Recipe, UnknownParameterSuggestsNearest) {
  EXPECT_EQ(stage_error("octave", 3), "stages[0].octave: unknown parameter (did you mean 'octaves'?)");
}

TEST(Recipe, SeedRange) {
  json doc = minimal();
  doc["seed"] = -1;
  EXPECT_EQ(error_of(doc), "seed: expected an integer in 0..9007199254740991, got -1");
  doc["seed"] = 9007199254740992ull;
  EXPECT_EQ(error_of(doc), "seed: expected an integer in 0..9007199254740991, got 9007199254740992");
  doc["seed"] = 9007199254740991ull;
  EXPECT_EQ(error_of(doc), "");
}

TEST(Recipe, WorldSizeValidation) {
  json doc = minimal();
  doc["world"]["size"] = 1;
  EXPECT_EQ(error_of(doc), "world.size: expected an integer in 2..32769, got 1");
  doc["world"]["size"] = json::array({65, 0});
  EXPECT_EQ(error_of(doc), "world.size[1]: expected an integer in 2..32769, got 0");
  doc["world"]["size"] = json::array({65, 33});
  Recipe r = parse_recipe(doc);
  Frame f = r.world.frame();
  EXPECT_EQ(f.nx, 65);
  EXPECT_EQ(f.nz, 33);
  EXPECT_DOUBLE_EQ(f.depth_m(), r.world.width_m / 2);  // square cells, depth follows the aspect
}

TEST(Recipe, UnknownTopLevelKey) {
  json doc = minimal();
  doc["stagse"] = json::array();
  EXPECT_EQ(error_of(doc), "stagse: unknown recipe key (did you mean 'stages'?)");
}

TEST(Recipe, MalformedJsonText) {
  try {
    parse_recipe_text("{\"stages\": [", "my.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("my.json is not valid JSON"), std::string::npos);
  }
}

TEST(Override, SetsNestedFieldWithJsonValue) {
  json doc = minimal();
  apply_override(doc, "stages[0].octaves=8");
  EXPECT_EQ(doc["stages"][0]["octaves"], 8);
  apply_override(doc, "world.sea_level=0.25");
  EXPECT_EQ(doc["world"]["sea_level"], 0.25);
  apply_override(doc, "stages[0].basis=simplex");  // not JSON: taken as a string
  EXPECT_EQ(doc["stages"][0]["basis"], "simplex");
  apply_override(doc, "seed=12");
  EXPECT_EQ(doc["seed"], 12);
}

TEST(Override, BadPathsAreErrors) {
  json doc = minimal();
  EXPECT_THROW(apply_override(doc, "stages[5].octaves=8"), Error);
  EXPECT_THROW(apply_override(doc, "stages[x].octaves=8"), Error);
  EXPECT_THROW(apply_override(doc, "octaves"), Error);
  try {
    apply_override(doc, "stages[3].octaves=1");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "stages[3]: index out of range (there are 1)");
  }
}

TEST(Override, ValueIsValidatedByTheTable) {
  json doc = minimal();
  apply_override(doc, "stages[0].octaves=40");
  EXPECT_EQ(error_of(doc), "stages[0].octaves: expected an integer in 1..16, got 40");
}

TEST(ParamTable, ExplainJsonHasEveryField) {
  const StageDef* d = find_stage("noise");
  ASSERT_NE(d, nullptr);
  json j = d->to_json();
  bool found = false;
  for (auto& p : j["params"])
    if (p["name"] == "octaves") {
      found = true;
      EXPECT_EQ(p["type"], "int");
      EXPECT_EQ(p["default"], 6);
      EXPECT_EQ(p["min"], 1);
      EXPECT_EQ(p["max"], 16);
      EXPECT_FALSE(p["description"].get<std::string>().empty());
    }
  EXPECT_TRUE(found);
}

TEST(ParamTable, EveryStageParamHasDescriptionAndValidDefault) {
  for (auto& d : stage_registry()) {
    EXPECT_FALSE(d.summary.empty()) << d.name;
    json obj = json::object();
    for (auto& p : d.params) {
      EXPECT_FALSE(p.description.empty()) << d.name << "." << p.name;
      obj[p.name] = p.default_value;
    }
    // The defaults themselves must pass validation.
    EXPECT_NO_THROW(d.parse(obj, "stages[0]")) << d.name;
  }
}

TEST(Colors, HexAndArrayForms) {
  Rgb a = read_color(json("#ff8000"), "c");
  EXPECT_FLOAT_EQ(a.r, 1.0f);
  EXPECT_FLOAT_EQ(a.g, 128 / 255.0f);
  EXPECT_FLOAT_EQ(a.b, 0.0f);
  EXPECT_EQ(write_color(a), "#ff8000");
  Rgb b = read_color(json::array({0, 255, 10}), "c");
  EXPECT_EQ(write_color(b), "#00ff0a");
  EXPECT_THROW(read_color(json("#ff80"), "c"), Error);
  EXPECT_THROW(read_color(json::array({0, 256, 0}), "c"), Error);
}

TEST(Presets, BuiltInsAreListedWithDescriptions) {
  auto list = list_presets();
  for (const char* name : {"island", "hills", "mountains", "desert"}) {
    bool found = false;
    for (auto& p : list)
      if (p.name == name) {
        found = true;
        EXPECT_FALSE(p.description.empty()) << name;
      }
    EXPECT_TRUE(found) << name;
  }
  EXPECT_GE(list.size(), 5u);
}

TEST(Presets, EveryBuiltInParses) {
  for (auto& p : list_presets()) {
    if (p.origin != "built-in") continue;
    EXPECT_NO_THROW(parse_recipe(load_preset(p.name))) << p.name;
  }
}

TEST(Presets, UnknownPresetSuggestsNearest) {
  try {
    load_preset("islnd");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'island'?"), std::string::npos) << e.what();
  }
}

TEST(Presets, UserFolderIsListedAndLoaded) {
  const relief::test::TempDir tmp("relief-presets");
  const std::filesystem::path& dir = tmp.path;
  {
    std::ofstream(dir / "my-valley.json") << R"({"description": "my own valley", "stages": [{"stage": "noise"}]})";
  }
  const std::vector<std::string> dirs{dir.string()};
  bool found = false;
  for (auto& p : list_presets(dirs))
    if (p.name == "my-valley") {
      found = true;
      EXPECT_EQ(p.description, "my own valley");
      EXPECT_EQ(p.origin, (dir / "my-valley.json").string());
    }
  EXPECT_TRUE(found);
  EXPECT_EQ(load_preset("my-valley", dirs)["description"], "my own valley");
  // The library reads no environment: without the folder the preset is unknown, whatever is set.
  ::setenv("RELIEF_PRESETS", dir.c_str(), 1);
  EXPECT_THROW(load_preset("my-valley"), Error);
  ::unsetenv("RELIEF_PRESETS");
}

TEST(Presets, UserFoldersFollowTheEnvironmentConvention) {
  using V = std::vector<std::string>;
  EXPECT_EQ(user_preset_dirs("a::b:", "/x", "/h"), (V{"a", "b", "/x/relief/presets"}));
  EXPECT_EQ(user_preset_dirs(nullptr, "", "/h"), (V{"/h/.config/relief/presets"}));  // empty XDG: HOME
  EXPECT_EQ(user_preset_dirs(nullptr, nullptr, nullptr), V{});
}

TEST(RecipeFiles, RelativeFileNamesResolveAgainstTheRecipeFolder) {
  const relief::test::TempDir tmp("relief-recipe-files");
  const std::filesystem::path dir = std::filesystem::absolute(tmp.path);
  relief::test::write_text(dir / "r.json", R"({"stages": [
    {"stage": "color", "levels": [{"at": 1, "color": "#000000", "texture": "tex/../moss.png"}]},
    {"stage": "biomes", "types": [{"name": "a", "texture": "/abs/a.png", "colors": [{"at": 1, "color": "#000000", "texture": "b.png"}]}]},
    {"stage": "tilemap", "texture": 0.5}]})");
  const json doc = read_recipe_file((dir / "r.json").string());
  EXPECT_EQ(doc["stages"][0]["levels"][0]["texture"], (dir / "moss.png").string());
  EXPECT_EQ(doc["stages"][1]["types"][0]["texture"], "/abs/a.png");  // absolute: as written
  EXPECT_EQ(doc["stages"][1]["types"][0]["colors"][0]["texture"], (dir / "b.png").string());
  EXPECT_EQ(doc["stages"][2]["texture"], 0.5);  // the tilemap's strength is no file name
  EXPECT_THROW((void)read_recipe_file((dir / "none.json").string()), Error);
}

// ---- the "export" block ------------------------------------------------------------------------

TEST(RecipeExport, AbsentBlockStaysAbsent) {
  Recipe r = parse_recipe(minimal());
  EXPECT_FALSE(r.export_settings.has_value());
  EXPECT_FALSE(r.to_json().contains("export"));
}

TEST(RecipeExport, BlockIsReadAndWrittenInFull) {
  json doc = minimal();
  doc["export"] = {{"formats", "glb,stl"}, {"engine", "godot"}, {"chunk_quads", 32}, {"lod_levels", 2}};
  Recipe r = parse_recipe(doc);
  ASSERT_TRUE(r.export_settings.has_value());
  EXPECT_EQ(r.export_settings->formats, "glb,stl");
  EXPECT_EQ(r.export_settings->options.engine, Engine::Godot);
  EXPECT_EQ(r.export_settings->options.chunk_quads, 32);
  EXPECT_EQ(r.export_settings->options.lod_levels, 2);
  const json out = r.to_json()["export"];
  EXPECT_EQ(out["formats"], "glb,stl");
  EXPECT_EQ(out["stl_size_mm"], 150.0);  // defaults filled in
  EXPECT_EQ(out.size(), export_options_table().fields.size() + 1);
  EXPECT_EQ(parse_recipe(r.to_json()).to_json(), r.to_json());
}

TEST(RecipeExport, DefaultFormatsAreWrittenAsDefault) {
  json doc = minimal();
  doc["export"] = json::object();
  Recipe r = parse_recipe(doc);
  EXPECT_EQ(r.export_settings->formats, "");
  EXPECT_EQ(r.to_json()["export"]["formats"], "default");
  doc["export"]["formats"] = "default";
  EXPECT_EQ(parse_recipe(doc).export_settings->formats, "");
}

TEST(RecipeExport, ErrorsNameTheField) {
  auto with = [](json block) {
    json doc = minimal();
    doc["export"] = std::move(block);
    return error_of(doc);
  };
  EXPECT_EQ(with({{"chunk_quads", 0}}).rfind("export.chunk_quads: ", 0), 0u) << with({{"chunk_quads", 0}});
  EXPECT_NE(with({{"chunk_quad", 4}}).find("export.chunk_quad: unknown parameter (did you mean 'chunk_quads'?)"), std::string::npos);
  EXPECT_NE(with({{"formats", "obj,glbb"}}).find("export.formats: unknown format \"glbb\" (did you mean 'glb'?)"), std::string::npos);
  EXPECT_NE(with({{"formats", ","}}).find("export.formats: expected at least one format"), std::string::npos);
  EXPECT_NE(with({{"formats", 3}}).find("export.formats: expected"), std::string::npos);
  EXPECT_NE(with({{"split", "2x2"}}).find("export.split: splitting writes engine tiles"), std::string::npos);
  EXPECT_NE(with(json::array()).find("export: expected an object"), std::string::npos);
}

TEST(RecipeExport, OverridesReachTheBlock) {
  json doc = minimal();
  apply_override(doc, "export.engine=unity");
  apply_override(doc, "export.formats=engine");
  Recipe r = parse_recipe(doc);
  EXPECT_EQ(r.export_settings->options.engine, Engine::Unity);
  EXPECT_EQ(r.export_settings->formats, "engine");
}

TEST(RecipeOverride, HugeIndexIsAnErrorNotACrash) {
  json doc = minimal();
  for (const char* a : {"stages[99999999999999999999].octaves=3", "stages[0].x[99999999999999999999999]=1",
                        "world[18446744073709551616]=1"}) {
    try {
      apply_override(doc, a);
      ADD_FAILURE() << a << " was accepted";
    } catch (const Error& e) {
      EXPECT_FALSE(std::string(e.what()).empty());
    }
  }
}

// ---- resolved recipes reproduce their terrain --------------------------------------------------

TEST(RecipeColours, WrittenExactlyHexWhenPossible) {
  const Rgb on_grid{64 / 255.0f, 128 / 255.0f, 1.0f}, off_grid{0.25f, 0.55f, 0.72f};
  EXPECT_EQ(write_color(on_grid), "#4080ff");
  const json w = write_color(off_grid);
  ASSERT_TRUE(w.is_array()) << w;
  EXPECT_EQ(read_color(w, "c"), off_grid);  // every bit
  EXPECT_EQ(read_color(write_color(on_grid), "c"), on_grid);
}

TEST(RecipeRoundTrip, EveryPresetResolvedGivesTheSameTerrain) {
  for (const auto& p : list_presets()) {
    if (p.origin != "built-in") continue;
    json doc = load_preset(p.name);
    doc["world"]["size"] = 33;
    doc["seed"] = 5;
    const Recipe original = parse_recipe(doc);
    const Recipe resolved = parse_recipe(original.to_json());
    const Terrain a = run(original, {}).terrain, b = run(resolved, {}).terrain;
    ASSERT_EQ(a.layers.size(), b.layers.size()) << p.name;
    for (auto& [name, layer] : a.layers) EXPECT_TRUE(layer.data == b.get(name).data) << p.name << ": layer " << name;
    EXPECT_EQ(a.points.size(), b.points.size()) << p.name;
  }
}

// ---- typed tables (issue 15 §2) -------------------------------------------------------------------

namespace {
enum class Shade { Light, Dark };
struct Shaded {
  Shade shade = Shade::Dark;
};
Table<Shaded> shaded_table() {
  return {{choice(&Shaded::shade, "shade", {{Shade::Light, "light"}, {Shade::Dark, "dark"}}, "A choice")}};
}
std::string error_path(const json& doc) {
  const auto e = parse_error(doc);
  return e ? e->path() : "no error";
}
}  // namespace

TEST(Tables, ChoiceIsReadIntoItsEnumAndWrittenBackAsItsString) {
  const Table<Shaded> t = shaded_table();
  EXPECT_EQ(t.read(json{{"shade", "light"}}, "x").shade, Shade::Light);
  EXPECT_EQ(t.read(json::object(), "x").shade, Shade::Dark);  // the default
  EXPECT_EQ(t.write(t.read(json{{"shade", "light"}}, "x")), (json{{"shade", "light"}}));
  const auto infos = t.infos();
  EXPECT_EQ(infos[0].choices, (std::vector<std::string>{"light", "dark"}));
  EXPECT_EQ(infos[0].default_value, "dark");
  // A stage's choice through a recipe: resolved JSON keeps the recipe's string.
  const Recipe r = parse_recipe(json{{"stages", {{{"stage", "noise"}, {"basis", "simplex"}, {"blend", "max"}}}}});
  EXPECT_EQ(r.stages[0].stage->params()["basis"], "simplex");
  EXPECT_EQ(r.stages[0].stage->params()["blend"], "max");
  EXPECT_EQ(r.stages[0].stage->params()["fractal"], "fbm");
}

TEST(Tables, UnknownChoiceIsRefusedWithItsFullPath) {
  try {
    shaded_table().read(json{{"shade", "drak"}}, "stages[3]");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[3].shade");
    EXPECT_EQ(e.message(), "expected one of light, dark, got \"drak\" (did you mean 'dark'?)");
  }
  EXPECT_EQ(error_path(json{{"stages", {{{"stage", "noise"}, {"basis", "simplx"}}}}}), "stages[0].basis");
  json types = json::array({json::object(), {{"name", "b"}, {"fractal", "ridge"}}});
  EXPECT_EQ(error_path(json{{"stages", {{{"stage", "biomes"}, {"types", types}}}}}), "stages[0].types[1].fractal");
  EXPECT_EQ(error_path(json{{"export", {{"engine", "cryengine"}}}}), "export.engine");
}

TEST(Tables, DeepErrorsCarryTheFullPathAndMessageHasNone) {
  const Error plain("stages[0].octaves", "expected an integer in 1..16, got 40");
  EXPECT_STREQ(plain.what(), "stages[0].octaves: expected an integer in 1..16, got 40");
  EXPECT_EQ(plain.message(), "expected an integer in 1..16, got 40");
  EXPECT_EQ(Error("", "no path").message(), "no path");
  // The noise library names its own field; stages prefix their path to it.
  NoiseSettings s;
  s.octaves = kMaxOctaves + 1;
  try {
    Noise n(s);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "octaves");
    EXPECT_EQ(e.message(), "expected an integer in 1.." + std::to_string(kMaxOctaves) + ", got " + std::to_string(kMaxOctaves + 1));
  }
  json types = json::array({json::object(), {{"name", "b"}, {"octaves", 40}}});
  try {
    parse_recipe(json{{"stages", {{{"stage", "noise"}}, {{"stage", "biomes"}, {"types", types}}}}});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[1].types[1].octaves");
    EXPECT_EQ(e.message().find("octaves"), std::string::npos) << e.message();
  }
  types[1] = {{"name", "b"}, {"texture", "no-such.png"}};
  EXPECT_EQ(error_path(json{{"stages", {{{"stage", "biomes"}, {"types", types}}}}}), "stages[0].types[1].texture");
}

TEST(Tables, WorldIsATableWithOneDefaultPerField) {
  const auto infos = world_params();
  ASSERT_EQ(infos.size(), 4u);
  EXPECT_EQ(infos[0].name, "size");
  EXPECT_EQ(infos[0].default_value, json::array({513, 513}));
  EXPECT_EQ(infos[0].max, kMaxSize);
  EXPECT_EQ(infos[3].name, "sea_level");
  EXPECT_EQ(infos[3].default_value, 0.4);
  // Written back in full, defaults filled in, size as [nx, nz].
  const Recipe r = parse_recipe(json{{"world", {{"size", 65}, {"sea_level", 0.3}}}, {"stages", json::array()}});
  EXPECT_EQ(r.to_json()["world"], (json{{"size", {65, 65}}, {"width_m", 4000.0}, {"height_m", 600.0}, {"sea_level", 0.3}}));
  EXPECT_EQ(world_table().read(world_table().write(r.world), "world").nx, 65);
  EXPECT_EQ(error_path(json{{"world", {{"size", {65, kMaxSize + 1}}}}}), "world.size[1]");
  EXPECT_EQ(error_path(json{{"world", {{"sea_levle", 0.3}}}}), "world.sea_levle");
}

TEST(Tables, NoiseFieldsAreSharedWithOneMeaningOfFrequency) {
  const StageDef* noise = find_stage("noise");
  const StageDef* biomes = find_stage("biomes");
  ASSERT_TRUE(noise && biomes);
  auto field = [](const std::vector<ParamInfo>& ps, const std::string& name) {
    for (auto& p : ps)
      if (p.name == name) return p.to_json();
    return json();
  };
  const std::vector<ParamInfo>* type_fields = nullptr;
  for (auto& p : biomes->params)
    if (p.name == "types") type_fields = &p.fields;
  ASSERT_TRUE(type_fields);
  for (const char* n : {"basis", "fractal", "octaves", "frequency", "wavelength_m", "lacunarity", "persistence", "scale_x", "scale_z"}) {
    json a = field(noise->params, n), b = field(*type_fields, n);
    ASSERT_FALSE(a.is_null()) << n;
    a.erase("default"), b.erase("default");
    EXPECT_EQ(a, b) << n;
  }
  for (const char* n : {"sea_shallow", "sea_deep", "sea_deep_depth", "beach_color"})
    EXPECT_EQ(field(biomes->params, n), field(find_stage("climate")->params, n)) << n;
  // wavelength_m is the stated alternative to frequency: 4 cycles across 4000 m = 1000 m.
  auto heights = [](const json& stage) {
    Recipe r = parse_recipe(json{{"seed", 3}, {"world", {{"size", 33}, {"width_m", 4000}}}, {"stages", {stage}}});
    return run(r).terrain.get("height").data;
  };
  const auto by_frequency = heights({{"stage", "noise"}, {"frequency", 4}});
  EXPECT_EQ(heights({{"stage", "noise"}, {"frequency", 9}, {"wavelength_m", 1000}}), by_frequency);
  EXPECT_NE(heights({{"stage", "noise"}, {"frequency", 9}}), by_frequency);
}
