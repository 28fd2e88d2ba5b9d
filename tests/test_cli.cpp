// The `relief` binary end to end: exit codes, messages naming the field, byte-identical output
// for any thread count, recipes saved and replayed, and files never left half-written.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "relief/output.hpp"
#include "support.hpp"

namespace fs = std::filesystem;

namespace {

using Result = relief::test::Shell;
using relief::test::slurp;

Result cli(const std::string& args) { return relief::test::relief_cli(args); }

using relief::test::TempDir;

constexpr auto expect_bad_input = relief::test::expect_cli_error;

// height.r16 of `relief generate ARGS --size 33 --formats heightmap -q` in a fresh folder (a failed
// run is a test failure and gives "").
std::string heights_of(const std::string& args) {
  TempDir d;
  const Result r = cli("generate " + args + " --size 33 --formats heightmap -q -o " + d.path.string());
  EXPECT_EQ(r.code, 0) << args << "\n" << r.out;
  return slurp(d.path / "height.r16");
}

}  // namespace

TEST(Cli, HelpDocumentsEveryCommandAndOption) {
  Result top = cli("--help");
  EXPECT_EQ(top.code, 0);
  for (const char* c : {"generate", "presets", "explain"}) EXPECT_NE(top.out.find(c), std::string::npos) << c;
  Result gen = cli("generate --help");
  EXPECT_EQ(gen.code, 0);
  for (const char* o : {"--preset", "--seed", "--size", "--formats", "--set", "--threads", "--save-recipe", "--out"})
    EXPECT_NE(gen.out.find(o), std::string::npos) << o;
}

TEST(Cli, PresetsListsTheBuiltIns) {
  Result r = cli("presets");
  EXPECT_EQ(r.code, 0);
  for (const char* p : {"island", "hills", "mountains", "desert"}) EXPECT_NE(r.out.find(p), std::string::npos) << p;
}

TEST(Cli, ExplainShowsTheParameterTable) {
  Result r = cli("explain noise");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("octaves"), std::string::npos);
  EXPECT_NE(r.out.find("1..16"), std::string::npos);
  Result j = cli("explain --json");
  ASSERT_EQ(j.code, 0);
  auto doc = nlohmann::json::parse(j.out);
  EXPECT_GE(doc["stages"].size(), 8u);
  EXPECT_GE(doc["formats"].size(), 5u);
}

TEST(Cli, GenerateWritesTheDefaultFiles) {
  TempDir d;
  Result r = cli("generate --preset island --seed 7 --size 65 -o " + d.path.string());
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* f : {"height.png", "height.r16", "height.json", "color.png", "albedo.png", "terrain.obj",
                        "terrain.mtl", "report.json"}) {
    EXPECT_TRUE(fs::exists(d.path / f)) << f;
    EXPECT_NE(r.out.find(f), std::string::npos) << "output should list " << f;
  }
  EXPECT_EQ(fs::file_size(d.path / "height.r16"), 65u * 65u * 2u);
  auto report = nlohmann::json::parse(slurp(d.path / "report.json"));
  EXPECT_EQ(report["seed"], 7);
  EXPECT_EQ(report["recipe"]["world"]["size"], nlohmann::json::array({65, 65}));
  EXPECT_TRUE(report["performance"]["stages"].is_array());
  EXPECT_GT(report["performance"]["peak_memory_bytes"].get<double>(), 0);
  // No temporary files are left behind.
  for (auto& e : fs::directory_iterator(d.path)) EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos);
}

TEST(Cli, OutputIsByteIdenticalForAnyThreadCount) {
  TempDir a, b;
  ASSERT_EQ(cli("generate island --seed 11 --size 97x65 --threads 1 -q -o " + a.path.string()).code, 0);
  ASSERT_EQ(cli("generate island --seed 11 --size 97x65 --threads 3 -q -o " + b.path.string()).code, 0);
  for (auto& e : fs::directory_iterator(a.path)) {
    const std::string name = e.path().filename().string();
    if (name == "report.json") {
      auto ja = nlohmann::json::parse(slurp(e.path())), jb = nlohmann::json::parse(slurp(b.path / name));
      ja.erase("performance"), jb.erase("performance");
      EXPECT_EQ(ja, jb);
    } else {
      EXPECT_EQ(slurp(e.path()), slurp(b.path / name)) << name;
    }
  }
}

TEST(Cli, DifferentSeedsGiveDifferentHeights) { EXPECT_NE(heights_of("--seed 1"), heights_of("--seed 2")); }

TEST(Cli, RandomSeedIsPrintedAndReproduces) {
  TempDir a;
  Result r = cli("generate --size 33 --formats heightmap -o " + a.path.string());
  ASSERT_EQ(r.code, 0) << r.out;
  auto pos = r.out.find("--seed ");
  ASSERT_NE(pos, std::string::npos) << r.out;
  std::string seed = r.out.substr(pos + 7, r.out.find(')', pos) - pos - 7);
  EXPECT_EQ(slurp(a.path / "height.r16"), heights_of("--seed " + seed));
}

TEST(Cli, SavedRecipeReproducesTheResult) {
  TempDir a, b;
  ASSERT_EQ(cli("generate mountains --seed 5 --size 49 --set 'stages[0].octaves=5' --formats heightmap -q -o " +
                   a.path.string() + " --save-recipe " + (a / "resolved.json"))
                .code,
            0);
  auto doc = nlohmann::json::parse(slurp(a.path / "resolved.json"));
  EXPECT_EQ(doc["seed"], 5);
  EXPECT_EQ(doc["stages"][0]["octaves"], 5);
  ASSERT_EQ(cli("generate " + (a / "resolved.json") + " --formats heightmap -q -o " + b.path.string()).code, 0);
  EXPECT_EQ(slurp(a.path / "height.png"), slurp(b.path / "height.png"));
}

TEST(Cli, SetOverridesChangeTheResult) {
  EXPECT_NE(heights_of("--seed 3"), heights_of("--seed 3 --set 'stages[0].octaves=2'"));
}

TEST(CliBadInput, OutOfRangeParameter) {
  expect_bad_input("generate --size 33 -q --set 'stages[0].octaves=40' -o /tmp/relief-never",
                   "stages[0].octaves: expected an integer in 1..16, got 40");
}

TEST(CliBadInput, NonFiniteParameter) {
  expect_bad_input("generate --size 33 -q --set 'stages[0].lacunarity=1e999' -o /tmp/relief-never", "stages[0].lacunarity");
}

TEST(CliBadInput, WrongType) {
  expect_bad_input("generate --size 33 -q --set 'stages[0].octaves=\"many\"' -o /tmp/relief-never",
                   "stages[0].octaves: expected an integer in 1..16, got \"many\"");
}

TEST(CliBadInput, UnknownPresetSuggests) {
  expect_bad_input("generate --preset moutains -o /tmp/relief-never", "did you mean 'mountains'?");
}

TEST(CliBadInput, UnknownStageSuggests) {
  TempDir d;
  std::ofstream(d / "r.json") << R"({"stages": [{"stage": "terace"}]})";
  expect_bad_input("generate " + (d / "r.json") + " -o " + (d / "out"), "stages[0].stage: unknown stage \"terace\" (did you mean 'terrace'?)");
  EXPECT_FALSE(fs::exists(d.path / "out" / "height.png"));
}

TEST(CliBadInput, MalformedRecipe) {
  TempDir d;
  std::ofstream(d / "r.json") << R"({"stages": [{"stage": "noise",]})";
  expect_bad_input("generate " + (d / "r.json") + " -o " + (d / "out"), "is not valid JSON");
}

TEST(CliBadInput, BadSizeAndSeed) {
  expect_bad_input("generate --size 1 -o /tmp/relief-never", "--size: expected N or NxM");
  expect_bad_input("generate --size 12x -o /tmp/relief-never", "--size: expected N or NxM");
  expect_bad_input("generate --seed -4 -o /tmp/relief-never", "--seed: expected an integer in 0..9007199254740991");
  expect_bad_input("generate --seed 9007199254740992 -o /tmp/relief-never", "--seed");
}

TEST(CliBadInput, UnknownFormat) {
  expect_bad_input("generate --size 33 --formats heightmap,gltf -o /tmp/relief-never", "--formats: unknown format \"gltf\"");
}

TEST(CliBadInput, SizeBeyondMemory) {
  expect_bad_input("generate --size 32769 -o /tmp/relief-never", "world.size: a 32769x32769 terrain");
}

TEST(CliBadInput, UnwritableOutputDirectory) {
  TempDir d;
  std::ofstream(d / "file") << "x";
  expect_bad_input("generate --size 33 -o " + (d / "file") + "/sub", "output: ");
}

TEST(CliBadInput, FailedRunLeavesPreviousFilesIntact) {
  TempDir d;
  ASSERT_EQ(cli("generate --seed 1 --size 33 -q -o " + d.path.string()).code, 0);
  const std::string before = slurp(d.path / "height.png"), color_before = slurp(d.path / "color.png");
  // A recipe with no colour stage cannot write color.png: the run fails before any file changes.
  std::ofstream(d / "plain.json") << R"({"seed": 2, "world": {"size": 33}, "stages": [{"stage": "noise"}]})";
  expect_bad_input("generate " + (d / "plain.json") + " --formats heightmap,color -o " + d.path.string(), "color");
  EXPECT_EQ(slurp(d.path / "height.png"), before);
  EXPECT_EQ(slurp(d.path / "color.png"), color_before);
  // The heightmap writer may have finished (its files staged) before the colour writer failed:
  // nothing of it is left behind.
  for (auto& e : std::filesystem::directory_iterator(d.path))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
}

// ---- island presets ------------------------------------------------------------------------------

TEST(CliIslands, VolcanicIslandWritesStepsInStageOrderAndIslandFiles) {
  TempDir d;
  Result r = cli("generate --preset volcanic-island --seed 3 --size 129 -q -o " + d / "out" + " --steps " + d / "steps");
  ASSERT_EQ(r.code, 0) << r.out;
  const auto recipe = nlohmann::json::parse(slurp(d.path / "out" / "report.json"))["recipe"];
  std::vector<std::string> want, got;
  for (std::size_t k = 0; k < recipe["stages"].size(); ++k) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%02zu-%s.png", k + 1, recipe["stages"][k]["stage"].get<std::string>().c_str());
    want.push_back(buf);
  }
  want.push_back("steps.png");
  for (auto& e : fs::directory_iterator(d.path / "steps")) got.push_back(e.path().filename().string());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, want);
  const auto props = nlohmann::json::parse(slurp(d.path / "out" / "props.json"));
  const std::string csv = slurp(d.path / "out" / "props.csv");
  EXPECT_EQ(std::size_t(std::count(csv.begin(), csv.end(), '\n')), props["count"].get<std::size_t>() + 1);
  EXPECT_GT(props["count"].get<int>(), 50);
  const auto biomes = nlohmann::json::parse(slurp(d.path / "out" / "biomes.json"));
  EXPECT_EQ(biomes["biomes"][0]["name"], "ocean");
  EXPECT_EQ(nlohmann::json::parse(slurp(d.path / "out" / "features.json"))["features"][0]["kind"], "volcano");
}

TEST(CliIslands, SameBytesForAnyThreadCount) {
  TempDir a, b;
  ASSERT_EQ(cli("generate volcanic-island --seed 8 --size 97 --threads 1 -q -o " + a.path.string()).code, 0);
  ASSERT_EQ(cli("generate volcanic-island --seed 8 --size 97 --threads 3 -q -o " + b.path.string()).code, 0);
  for (const char* f : {"props.json", "props.csv", "biome.png", "biomes.json", "features.json", "terrain.obj", "color.png"})
    EXPECT_EQ(slurp(a.path / f), slurp(b.path / f)) << f;
}

TEST(CliIslands, DefaultSetSkipsIslandWritersWithNothingToWrite) {
  TempDir d;
  ASSERT_EQ(cli("generate island --seed 1 --size 33 -q -o " + d.path.string()).code, 0);
  EXPECT_FALSE(fs::exists(d.path / "props.json"));
  EXPECT_FALSE(fs::exists(d.path / "biome.png"));
  // Asked for by name, the writer says what is missing.
  expect_bad_input("generate island --seed 1 --size 33 -q --formats biomes -o " + d.path.string(), "biomes needs a 'biome' layer");
}

TEST(CliRecipeFile, TextureResolvesAgainstTheRecipeFolderFromAnyWorkingDirectory) {
  TempDir d;
  fs::create_directories(d.path / "recipes" / "tex");
  fs::create_directories(d.path / "elsewhere");
  relief::Layer px;
  px.channels = 3;
  px.data.assign(12, 0.5f);
  relief::write_file_atomic(d / "recipes/tex/moss.png", relief::encode_png_rgb8(px, 2, 2));
  relief::test::write_text(d.path / "recipes" / "r.json", R"({"world": {"size": 17}, "stages": [{"stage": "noise"},
    {"stage": "color", "levels": [{"at": 1, "color": "#000000", "texture": "tex/moss.png", "tile_m": 10}]}]})");
  // Run from a folder without the texture: the name is the recipe folder's.
  const std::string run = "cd " + d / "elsewhere" + " && " + RELIEF_BINARY + " generate ../recipes/r.json --seed 1 -q --formats albedo -o out";
  const Result ok = relief::test::sh(run + " --save-recipe saved.json");
  ASSERT_EQ(ok.code, 0) << ok.out;
  const auto saved = nlohmann::json::parse(slurp(d.path / "elsewhere" / "saved.json"));
  EXPECT_EQ(saved["stages"][1]["levels"][0]["texture"], (fs::absolute(d.path) / "recipes" / "tex" / "moss.png").string());
  // The saved recipe (absolute names) replays from yet another folder, byte for byte.
  const Result again = relief::test::sh("cd " + d.path.string() + " && " + RELIEF_BINARY + " generate elsewhere/saved.json -q -o out2");
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_EQ(slurp(d.path / "out2" / "albedo.png"), slurp(d.path / "elsewhere" / "out" / "albedo.png"));
  // A name typed on the command line is the working directory's.
  const Result typed = relief::test::sh(run + " --set 'stages[1].levels[0].texture=\"tex/moss.png\"'");
  EXPECT_EQ(typed.code, 2) << typed.out;
  EXPECT_NE(typed.out.find("cannot read texture 'tex/moss.png'"), std::string::npos) << typed.out;
}

TEST(CliIslands, BadIslandParametersExit2NamingTheField) {
  TempDir d;
  const std::string g = "generate volcanic-island --size 33 -q -o " + d / "out" + " ";
  expect_bad_input(g + "--set 'stages[2].types[1].octaves=40'", "stages[2].types[1].octaves: expected an integer in 1..16");
  expect_bad_input(g + "--set 'stages[2].types[0].texture=\"no-such.png\"'", "stages[2].types[0].texture: cannot read texture 'no-such.png'");
  expect_bad_input(g + "--set 'stages[3].rim_radius_m=5000'", "stages[3].rim_radius_m");
  expect_bad_input(g + "--set 'stages[2].blend=\"average\"'", "stages[2].blend");
  expect_bad_input(g + "--set 'stages[7].types[0].biomes=[\"swamp\"]'", "stages[7].types[0].biomes[0]: unknown biome \"swamp\"");
  expect_bad_input("generate archipelago --size 33 -q -o " + d / "out" + " --set 'stages[3].table[0].temperature_min=0.1'",
                   "stages[3].table: no row covers temperature 0.00");
  EXPECT_TRUE(!fs::exists(d.path / "out") || fs::is_empty(d.path / "out"));  // nothing half-written
}

// ---- failed runs leave the file system unchanged -------------------------------------------------

TEST(CliFailure, FailedRunCreatesNoOutputDirectory) {
  TempDir d;
  // Valid recipe, but it has no colour stage, so the color writer fails after generation.
  std::ofstream(d / "plain.json") << R"({"seed": 2, "world": {"size": 33}, "stages": [{"stage": "noise"}]})";
  expect_bad_input("generate " + (d / "plain.json") + " --formats heightmap,color -o " + (d / "new/sub") + " --steps " +
                       (d / "steps"),
                   "color");
  EXPECT_FALSE(fs::exists(d.path / "new"));
  EXPECT_FALSE(fs::exists(d.path / "steps"));
  std::vector<std::string> left;
  for (auto& e : fs::directory_iterator(d.path)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"plain.json"});
}

TEST(CliFailure, SuccessfulRunCreatesMissingParents) {
  TempDir d;
  ASSERT_EQ(cli("generate --seed 1 --size 17 --formats heightmap -q -o " + (d / "a/b/c")).code, 0);
  EXPECT_TRUE(fs::exists(d.path / "a/b/c/height.png"));
}

TEST(CliFailure, OutputUnderAFileIsRefusedBeforeGenerating) {
  TempDir d;
  std::ofstream(d / "file") << "x";
  Result r = cli("generate --seed 1 --size 17 -o " + (d / "file") + "/sub");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.out.find("output: cannot create directory"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("seed 1"), std::string::npos) << "refused only after generating:\n" << r.out;
}

// ---- --save-recipe keeps the export settings --------------------------------------------------------

namespace {
// Every file of a directory but `skip`, by name.
std::map<std::string, std::string> files_of(const fs::path& dir, const std::string& skip = "") {
  std::map<std::string, std::string> m;
  for (auto& e : fs::directory_iterator(dir))
    if (e.path().filename() != skip) m[e.path().filename().string()] = slurp(e.path());
  return m;
}
// report.json without its performance block (timings differ between runs by design).
std::string report_without_performance(const std::string& text) {
  auto j = nlohmann::json::parse(text);
  j.erase("performance");
  return j.dump();
}
}  // namespace

// The fsync and rename calls of one `relief generate` run, in order, as strace saw them: "F" for a
// flush (fsync or fdatasync), "R:NAME" for a rename onto NAME (the file name only).
std::vector<std::string> sync_trace(const TempDir& d, const std::string& args) {
  const fs::path log = d.path / "strace.log";
  // LeakSanitizer cannot stop a traced process's threads (sanitizer builds): its check is off here.
  Result r = relief::test::sh("ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0\" strace -f -qq -e "
                              "trace=fsync,fdatasync,rename,renameat,renameat2 -o " +
                              log.string() + " " + RELIEF_BINARY + " " + args);
  EXPECT_EQ(r.code, 0) << r.out;
  std::vector<std::string> calls;
  std::istringstream in(slurp(log));
  for (std::string line; std::getline(in, line);) {
    if (line.find(" = 0") == std::string::npos) continue;  // only calls that succeeded
    if (line.find("fsync(") != std::string::npos || line.find("fdatasync(") != std::string::npos) {
      calls.push_back("F");
    } else if (line.find("rename") != std::string::npos) {
      // rename("…/.height.png.tmp-abc123", "…/height.png") = 0: the last quoted path is the target.
      const auto close = line.rfind('"'), open = line.rfind('"', close - 1);
      calls.push_back("R:" + fs::path(line.substr(open + 1, close - open - 1)).filename().string());
    }
  }
  return calls;
}

TEST(CliSync, GeneratedFilesAreFlushedOnlyWithSyncAndTheSavedRecipeAlways) {
  if (relief::test::sh("strace -qq -e trace=none true").code != 0) GTEST_SKIP() << "strace cannot trace here";
  const std::vector<std::string> files = {"albedo.png", "color.png",   "height.json",  "height.png",
                                          "height.r16", "report.json", "terrain.mtl", "terrain.obj"};
  TempDir plain, synced;
  // Default: every generated file is renamed into place (atomic) but none is flushed; the saved
  // recipe, which the user may have edited by hand next, is flushed before its rename.
  const std::string common = "generate --preset island --seed 3 --size 33 -q ";
  std::vector<std::string> a = sync_trace(plain, common + "-o " + (plain / "out") + " --save-recipe " + (plain / "r.json"));
  // One commit for every file of the run: the saved recipe is flushed while every file is being
  // prepared, before any of them is renamed; then the output folder's files in name order, then
  // the recipe.
  std::vector<std::string> expect_a = {"F"};
  for (auto& f : files) expect_a.push_back("R:" + f);
  expect_a.push_back("R:r.json");
  EXPECT_EQ(a, expect_a);
  // --sync: all files are flushed before the first of them becomes visible (so a power cut leaves
  // the old set or the new set on disk), then renamed in name order.
  std::vector<std::string> b = sync_trace(synced, common + "--sync -o " + (synced / "out"));
  std::vector<std::string> expect_b(files.size(), "F");
  for (auto& f : files) expect_b.push_back("R:" + f);
  EXPECT_EQ(b, expect_b);
  // Same bytes either way.
  for (auto& f : files) {
    if (f == "report.json") continue;  // its timings differ
    EXPECT_EQ(slurp(plain.path / "out" / f), slurp(synced.path / "out" / f)) << f;
  }
}

TEST(CliSaveRecipe, ReplayReproducesEveryExportFileByteForByte) {
  TempDir a, b, c;
  const std::string flags =
      "--formats heightmap,glb,fbx,stl,normalmap,splat,hillshade,report --engine unity --chunk-quads 16 --style lowpoly "
      "--stl-size-mm 80 --stl-base-mm 5 --normal-bits 16 --splat-rock-slope-deg 25 --hillshade-azimuth-deg 200";
  ASSERT_EQ(cli("generate volcanic-island --seed 7 --size 65 -q " + flags + " -o " + a.path.string() + " --save-recipe " +
                   (a / "saved.json"))
                .code,
            0);
  const auto saved = nlohmann::json::parse(slurp(a.path / "saved.json"));
  ASSERT_TRUE(saved.contains("export")) << saved.dump(2);
  EXPECT_EQ(saved["export"]["engine"], "unity");
  EXPECT_EQ(saved["export"]["chunk_quads"], 16);
  EXPECT_EQ(saved["export"]["style"], "lowpoly");
  EXPECT_EQ(saved["export"]["normal_bits"], 16);

  ASSERT_EQ(cli("generate " + (a / "saved.json") + " -q -o " + b.path.string()).code, 0);
  auto fa = files_of(a.path, "saved.json"), fb = files_of(b.path);
  std::vector<std::string> na, nb;
  for (auto& [n, bytes] : fa) na.push_back(n);
  for (auto& [n, bytes] : fb) nb.push_back(n);
  ASSERT_EQ(na, nb);
  EXPECT_TRUE(fa.count("terrain.glb") && fa.count("terrain.fbx") && fa.count("terrain.stl") && fa.count("splat0.png"));
  for (auto& [name, bytes] : fa) {
    if (name == "report.json") EXPECT_EQ(report_without_performance(bytes), report_without_performance(fb.at(name)));
    else EXPECT_TRUE(bytes == fb.at(name)) << name << " differs after replaying the saved recipe";
  }

  // The options did change the files (without them the replay would not match), and flags still
  // override the recipe's block.
  ASSERT_EQ(cli("generate volcanic-island --seed 7 --size 65 -q --formats glb,stl -o " + c.path.string()).code, 0);
  EXPECT_NE(slurp(c.path / "terrain.glb"), fa.at("terrain.glb"));
  EXPECT_NE(slurp(c.path / "terrain.stl"), fa.at("terrain.stl"));
  ASSERT_EQ(cli("generate " + (a / "saved.json") + " -q --stl-size-mm 150 --formats stl -o " + c.path.string()).code, 0);
  EXPECT_NE(slurp(c.path / "terrain.stl"), fa.at("terrain.stl"));
}

TEST(CliSaveRecipe, DefaultRunSavesTheWritersThatRan) {
  TempDir a, b;
  ASSERT_EQ(cli("generate island --seed 3 --size 33 -q -o " + a.path.string() + " --save-recipe " + (a / "r.json")).code, 0);
  const auto saved = nlohmann::json::parse(slurp(a.path / "r.json"));
  // The island has no flow stage, so the default set's rivers and lakes writers did not run.
  EXPECT_EQ(saved["export"]["formats"], "heightmap,color,albedo,obj,report");
  EXPECT_EQ(saved["export"]["engine"], "none");
  ASSERT_EQ(cli("generate " + (a / "r.json") + " -q -o " + b.path.string()).code, 0);
  auto fa = files_of(a.path, "r.json"), fb = files_of(b.path);
  ASSERT_EQ(fa.size(), fb.size());
  for (auto& [name, bytes] : fa) {
    if (name == "report.json") continue;  // holds timings
    EXPECT_TRUE(bytes == fb.at(name)) << name;
  }
}

TEST(CliSaveRecipe, BadExportBlockNamesTheField) {
  TempDir d;
  std::ofstream(d / "r.json") << R"({"world": {"size": 17}, "stages": [{"stage": "noise"}], "export": {"chunk_quads": 0}})";
  expect_bad_input("generate " + (d / "r.json") + " -o " + (d / "out"), "export.chunk_quads: ");
  std::ofstream(d / "f.json") << R"({"world": {"size": 17}, "stages": [{"stage": "noise"}], "export": {"formats": "heightmap,glbb"}})";
  expect_bad_input("generate " + (d / "f.json") + " -o " + (d / "out"), "export.formats: unknown format \"glbb\" (did you mean 'glb'?)");
  EXPECT_FALSE(fs::exists(d.path / "out"));
}


// `relief bench` on tiny sizes: every entry has the fields the speed issue asks for (name, grid
// size, threads, median/min/max over the runs, million samples per second), noise entries carry
// libnoise measured in the same run and the ratio, and the file says which machine it came from.
TEST(CliBench, JsonEntriesNameTheCaseTheMachineAndThePeer) {
  TempDir dir;
  const std::string out = dir / "bench.json";
  Result r = cli("bench --cases noise,regenerate --runs 1 --threads 1,2 --noise-size 64 --peer-size 32 --json " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("machine: "), std::string::npos) << r.out;
  const nlohmann::json doc = nlohmann::json::parse(slurp(out));
  EXPECT_EQ(doc["runs"], 1);
  EXPECT_FALSE(doc["cpu"].get<std::string>().empty());
  EXPECT_FALSE(doc["simd_target"].get<std::string>().empty());
  int noise = 0, regenerate = 0;
  std::map<int, int> per_threads;
  for (const auto& e : doc["entries"]) {
    const std::string name = e["name"];
    for (const char* key : {"size", "threads", "median_ms", "min_ms", "max_ms", "cpu_median_ms", "msamples_per_s"})
      ASSERT_TRUE(e.contains(key)) << name << " has no " << key;
    EXPECT_LE(e["min_ms"].get<double>(), e["median_ms"].get<double>()) << name;
    EXPECT_LE(e["median_ms"].get<double>(), e["max_ms"].get<double>()) << name;
    EXPECT_GT(e["msamples_per_s"].get<double>(), 0.0) << name;
    ++per_threads[e["threads"].get<int>()];
    if (e.contains("peer")) {
      ++noise;
      EXPECT_EQ(e["size"][0], 64) << name;
      EXPECT_NE(e["peer"]["name"].get<std::string>().find("libnoise"), std::string::npos) << name;
      EXPECT_NEAR(e["ratio"].get<double>(), e["msamples_per_s"].get<double>() / e["peer"]["msamples_per_s"].get<double>(),
                  1e-6 * e["ratio"].get<double>())
          << name;
    }
    if (name.find("regenerate") != std::string::npos) ++regenerate;
  }
  // Single-octave gradient, Perlin, simplex, value and cellular; 6-octave fBm and ridged of the
  // gradient, Perlin and simplex bases: 11 noise cases per thread count.
  EXPECT_EQ(noise, 2 * 11);
  EXPECT_GE(regenerate, 2);
  EXPECT_EQ(per_threads.size(), 2u);
}

// The dem group: the slope and hillshade stages, each with GDAL's gdaldem measured in the same run
// (GDAL is installed by scripts/setup.sh) and the ratios to it and to a copy.
TEST(CliBench, DemCasesCarryGdalAsThePeer) {
  TempDir dir;
  const std::string out = dir / "bench.json";
  Result r = cli("bench --cases dem --runs 1 --threads 1 --noise-size 64 --json " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  const nlohmann::json doc = nlohmann::json::parse(slurp(out));
  std::set<std::string> names;
  for (const auto& e : doc["entries"]) {
    const std::string name = e["name"];
    names.insert(name);
    EXPECT_EQ(e["size"][0], 65) << name;
    if (name.rfind("hillshade in island", 0) == 0) {
      // The stage inside a recipe (fresh output layers, and recycled ones) against its kernel.
      for (const char* key : {"median_ms", "kernel_median_ms", "vs_kernel", "recipe_median_ms"})
        ASSERT_TRUE(e.contains(key)) << name << " has no " << key;
      EXPECT_NEAR(e["vs_kernel"].get<double>() * e["kernel_median_ms"].get<double>(), e["median_ms"].get<double>(), 1e-9) << name;
      continue;
    }
    for (const char* key : {"median_ms", "cpu_median_ms", "msamples_per_s", "vs_copy", "ratio", "vs_peer", "vs_peer_cpu"})
      ASSERT_TRUE(e.contains(key)) << name << " has no " << key;
    EXPECT_NE(e["peer"]["name"].get<std::string>().find("GDAL gdaldem"), std::string::npos) << name;
    EXPECT_NEAR(e["ratio"].get<double>() * e["vs_peer"].get<double>(), 1.0, 1e-9) << name;
  }
  EXPECT_EQ(names, (std::set<std::string>{"slope stage", "hillshade stage", "hillshade in island recipe", "hillshade in island, recycled"}));
}

// Issue 16 §3: every file a run writes — the output folder, the step pictures, the saved recipe —
// is one commit, checked before anything is renamed.
TEST(CliOneCommit, BadSaveRecipeOrStepsTargetWritesNothing) {
  TempDir d;
  const std::string out = d / "rr1";
  ASSERT_EQ(cli("generate island --seed 1 --size 33 -q -o " + out).code, 0);
  const std::string before = slurp(d.path / "rr1" / "height.png");
  const std::string base = "generate island --seed 2 --size 33 -q -o " + out + " ";
  relief::test::write_text(d.path / "afile", "x");
  expect_bad_input(base + "--save-recipe " + (d.path / "afile" / "x.json").string(), "--save-recipe: ");
  fs::create_directories(d.path / "afolder");
  expect_bad_input(base + "--save-recipe " + (d / "afolder"), "--save-recipe: expected a file name");
  expect_bad_input(base + "--steps /proc/x", "--steps: ");
  expect_bad_input(base + "--save-recipe " + (d.path / "rr1" / "report.json").string(), "--save-recipe: ");
  EXPECT_EQ(slurp(d.path / "rr1" / "height.png"), before);  // the earlier run's files stand
  // A recipe saved into the output folder under its own name is fine, and written with the rest.
  ASSERT_EQ(cli(base + "--save-recipe " + (d.path / "rr1" / "saved.json").string()).code, 0);
  EXPECT_NE(slurp(d.path / "rr1" / "height.png"), before);
  EXPECT_TRUE(fs::exists(d.path / "rr1" / "saved.json"));
}

// Issue 16 §6: a writer named in --formats whose input the recipe lacks is an error naming what
// is missing, not a silent run that writes nothing.
TEST(CliBadInput, FormatWhoseInputIsMissingNamesIt) {
  TempDir d;
  expect_bad_input("generate island --seed 1 --size 33 -q --formats rivers -o " + (d / "a"), "--formats: rivers needs a 'flow' layer");
  expect_bad_input("generate island --seed 1 --size 33 -q --formats heightmap,lakes -o " + (d / "a"), "--formats: lakes needs a 'flow' layer");
  EXPECT_FALSE(fs::exists(d.path / "a"));
  // With a flow stage they write their files.
  ASSERT_EQ(cli("generate river-island --seed 1 --size 65 -q --formats rivers,lakes -o " + (d / "b")).code, 0);
  EXPECT_TRUE(fs::exists(d.path / "b" / "rivers.json"));
  EXPECT_TRUE(fs::exists(d.path / "b" / "lakes.json"));
}

// --formats accepts the default set plus or minus writers.
TEST(Cli, FormatsCombineTheDefaultSetWithNamesAndExclusions) {
  TempDir d;
  ASSERT_EQ(cli("generate island --seed 1 --size 33 -q --formats default,-obj,glb -o " + (d / "a")).code, 0);
  EXPECT_TRUE(fs::exists(d.path / "a" / "terrain.glb"));
  EXPECT_TRUE(fs::exists(d.path / "a" / "height.png"));
  EXPECT_FALSE(fs::exists(d.path / "a" / "terrain.obj"));
  EXPECT_FALSE(fs::exists(d.path / "a" / "terrain.mtl"));
  // --formats all includes the tilemap (a tilemap stage is added, as for --formats tilemap).
  ASSERT_EQ(cli("generate island --seed 1 --size 65 -q --formats all -o " + (d / "b")).code, 0);
  EXPECT_TRUE(fs::exists(d.path / "b" / "tilemap.tmx"));
}

// Issue 16 §4: Ctrl-C (SIGINT) or SIGTERM at any point of a run: exit 130 / 143 with a message,
// no temporary file left, the previous run's files unchanged. The run is interrupted at several
// moments after its start, as fractions of an uninterrupted run's time on this machine: during the
// stages, during the encoding of the 2049² OBJ (1025² under the sanitizers), near the commit. A run
// that finishes first (exit 0; also when the signal comes once the commit has begun replacing
// files) becomes the new "previous run". "Its start" is the moment the process has its signal thread (a second thread): a signal
// that lands while the dynamic loader still maps the libraries (seconds in a sanitizer build under
// load) ends the process by the default action, before any code of ours runs or any file is opened.
TEST(CliInterrupt, SignalLeavesNoTemporaryAndNoChangedFile) {
  TempDir d;
  const std::string out = d / "out";
  const auto t0 = std::chrono::steady_clock::now();
#if defined(__SANITIZE_ADDRESS__)
  const std::string size = "1025";  // the sanitizer build: a 2049² run takes 12 s there (the test 89 s)
#else
  const std::string size = "2049";
#endif
  // A run's files (0.9 GB at 2049², the OBJ) sit beside the previous run's until the commit: with
  // less free disk the runs fail for want of space, not for the property tested (the likely cause
  // of one CI failure, with 1.8 GB free: this test failed and the glTF validator's suite setup too).
  const std::uintmax_t need = size == "2049" ? 2600ull << 20 : 800ull << 20;
  if (const auto space = fs::space(d.path); space.available < need)
    GTEST_SKIP() << "needs " << (need >> 20) << " MiB free in " << d.path << ", has " << (space.available >> 20) << " MiB";
  ASSERT_EQ(cli("generate island --seed 1 --size " + size + " -q -o " + out).code, 0);
  const double full_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Each file by its size, inode and modification time: a file replaced by a rename has another
  // inode, one rewritten in place another time. (Reading them would take seconds: the OBJ is
  // 0.9 GB; and a failure prints a short list, not a diff of two such files.)
  auto files = [&] {
    std::map<std::string, std::string> m;
    for (auto& e : fs::directory_iterator(d.path / "out")) {
      struct stat st {};
      ::stat(e.path().c_str(), &st);
      m[e.path().filename().string()] = std::to_string(st.st_size) + " bytes, inode " + std::to_string(st.st_ino) + ", mtime " +
                                        std::to_string(st.st_mtim.tv_sec) + "." + std::to_string(st.st_mtim.tv_nsec);
    }
    return m;
  };
  std::map<std::string, std::string> before = files();
  int interrupted = 0, seed = 2;
  for (const auto& [fraction, sig] : {std::pair{0.15, "INT"}, {0.45, "TERM"}, {0.75, "INT"}, {0.95, "TERM"}}) {
    const std::string when = std::to_string(fraction * full_s);
    const std::string log = d / "log.txt";
    Result r = relief::test::sh(std::string(RELIEF_BINARY) + " generate island --seed " + std::to_string(seed++) +
                                " --size " + size + " -o " + out + " > " + log +
                                " 2>&1 & pid=$!; while kill -0 $pid 2>/dev/null && [ $(ls /proc/$pid/task | wc -l) -lt 2 ]; do "
                                "sleep 0.01; done; sleep " + when + "; kill -s " + sig + " $pid 2>/dev/null; wait $pid; code=$?; cat " +
                                log + "; exit $code");
    if (r.code == 0) {  // finished first: its files are the previous run's for the next one
      before = files();
      continue;
    }
    ++interrupted;
    EXPECT_EQ(r.code, std::string(sig) == "INT" ? 130 : 143) << r.out;
    EXPECT_NE(r.out.find(std::string("relief: interrupted by SIG") + sig + "; no file was changed"), std::string::npos) << r.out;
    EXPECT_EQ(files(), before) << "interrupted at " << when << " s (of " << full_s << " s) by SIG" << sig;
  }
  EXPECT_GT(interrupted, 0);
}

// Issue 16 §4: temporary files of a run killed outright (SIGKILL) are removed by the next run into
// that folder; a temporary file of a process that still runs is left alone.
TEST(CliInterrupt, NextRunRemovesTemporariesOfDeadRuns) {
  TempDir d;
  fs::create_directories(d.path / "out");
  const std::string dead_pid = relief::test::sh("sh -c 'echo $$'").out;  // exited: its pid names no process
  const std::string dead = ".height.png.tmp-" + dead_pid.substr(0, dead_pid.find('\n')) + "-abc123";
  const std::string live = ".terrain.obj.tmp-" + std::to_string(::getpid()) + "-abc123";
  relief::test::write_text(d.path / "out" / dead, "partial");
  relief::test::write_text(d.path / "out" / live, "partial");
  relief::test::write_text(d.path / "out" / ".notes.tmp-1-x", "not ours: wrong shape");
  ASSERT_EQ(cli("generate island --seed 1 --size 33 -q -o " + (d / "out")).code, 0);
  EXPECT_FALSE(fs::exists(d.path / "out" / dead));
  EXPECT_TRUE(fs::exists(d.path / "out" / live));
  EXPECT_TRUE(fs::exists(d.path / "out" / ".notes.tmp-1-x"));
}

// Issue 16 §5: each run's report.json lists the files it wrote; the next run into the folder
// removes those of them it does not write (only those), unless --keep-stale.
TEST(CliStale, NextRunRemovesOnlyThePreviousRunsFilesItDoesNotWrite) {
  TempDir d;
  const std::string out = d / "out";
  ASSERT_EQ(cli("generate volcanic-island --seed 7 --size 65 -q -o " + out).code, 0);
  const auto manifest = nlohmann::json::parse(slurp(d.path / "out" / "report.json"))["files"];
  EXPECT_TRUE(std::find(manifest.begin(), manifest.end(), "props.json") != manifest.end()) << manifest.dump();
  EXPECT_TRUE(std::find(manifest.begin(), manifest.end(), "report.json") != manifest.end()) << manifest.dump();
  relief::test::write_text(d.path / "out" / "mine.txt", "the user's");
  // --keep-stale: nothing removed.
  ASSERT_EQ(cli("generate island --seed 7 --size 65 -q --keep-stale -o " + out).code, 0);
  EXPECT_TRUE(fs::exists(d.path / "out" / "props.json"));
  // The island run after the volcano's: its props, biomes and features go; the user's file stays.
  ASSERT_EQ(cli("generate volcanic-island --seed 7 --size 65 -q -o " + out).code, 0);
  Result r = cli("generate island --seed 7 --size 65 -o " + out);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("removed 5 files of the previous run"), std::string::npos) << r.out;
  for (const char* f : {"props.json", "props.csv", "biomes.json", "biome.png", "features.json"})
    EXPECT_FALSE(fs::exists(d.path / "out" / f)) << f;
  EXPECT_TRUE(fs::exists(d.path / "out" / "mine.txt"));
  EXPECT_TRUE(fs::exists(d.path / "out" / "terrain.obj"));
  // A failed run removes nothing.
  relief::test::write_text(d.path / "out" / "props.json", "kept");
  ASSERT_EQ(cli("generate volcanic-island --seed 7 --size 65 -q -o " + out).code, 0);
  expect_bad_input("generate island --seed 7 --size 65 -q --set 'stages[0].octaves=99' -o " + out, "stages[0].octaves");
  EXPECT_TRUE(fs::exists(d.path / "out" / "props.json"));
}
