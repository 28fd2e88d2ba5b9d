// relief::generate (relief/generate.hpp): the one writing path behind the CLI, the studio and the
// bench — writer selection and implied writers, refusals before any work, the one commit of every
// output, and the same bytes through memory and files.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "relief/generate.hpp"
#include "support.hpp"

using namespace relief;
namespace fs = std::filesystem;

namespace {

Recipe small(const std::string& preset, int n, std::uint64_t seed = 7) { return test::preset_recipe(preset, n, seed); }

std::vector<std::string> names(const WriterPlan& p) {
  std::vector<std::string> v;
  for (auto* w : p.writers) v.push_back(w->name);
  return v;
}

bool contains(const std::vector<std::string>& v, const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); }

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(SelectWriters, ObjAndFbxBringTheAlbedoTheyName) {
  EXPECT_EQ(names(select_writers("obj", {})), (std::vector<std::string>{"albedo", "obj"}));
  EXPECT_TRUE(contains(names(select_writers("fbx", {})), "albedo"));
  EXPECT_FALSE(contains(names(select_writers("glb", {})), "albedo"));  // the GLB embeds its texture
  // Every implied writer is one the registry declares on the chooser, never found by file name.
  for (const WriterDef& w : writer_registry())
    for (const std::string& n : w.implies) EXPECT_NE(find_writer(n), nullptr) << w.name << " implies " << n;
}

TEST(SelectWriters, DefaultAllAndExclusions) {
  const auto def = names(select_writers("", {}));
  EXPECT_EQ(def, names(select_writers("default", {})));
  for (const WriterDef& w : writer_registry()) EXPECT_EQ(contains(def, w.name), w.in_default_set) << w.name;
  const auto all = names(select_writers("all", {}));
  EXPECT_TRUE(contains(all, "tilemap"));
  EXPECT_TRUE(contains(all, "glb"));
  EXPECT_FALSE(contains(all, "engine"));  // no engine chosen
  ExportOptions unity;
  unity.engine = Engine::Unity;
  EXPECT_TRUE(contains(names(select_writers("all", unity)), "engine"));
  EXPECT_TRUE(contains(names(select_writers("heightmap", unity)), "engine"));  // an engine asks for its files
  const auto no_obj = names(select_writers("default,-obj", {}));
  EXPECT_FALSE(contains(no_obj, "obj"));
  EXPECT_TRUE(contains(no_obj, "heightmap"));
  EXPECT_EQ(names(select_writers("glb,heightmap", {})), names(select_writers("heightmap,glb,glb", {})));  // registry order, once
}

TEST(SelectWriters, BadListsNameTheField) {
  EXPECT_NE(error_of([] { select_writers("heightmap,gltf", {}, "--formats"); }).find("--formats: unknown format \"gltf\" (did you mean 'glb'?)"),
            std::string::npos);
  EXPECT_NE(error_of([] { select_writers(",,", {}, "export.formats"); }).find("export.formats: expected at least one format"),
            std::string::npos);
  EXPECT_NE(error_of([] { select_writers("heightmap,-heightmap", {}); }).find("no format left"), std::string::npos);
}

TEST(Generate, MemoryAndFilesGiveTheSameBytesAndTheReportListsThem) {
  relief::test::TempDir dir("relief-generate");
  GenerateSettings s;
  s.recipe = small("island", 65);
  s.formats = "heightmap,obj,glb,report";
  MemoryOutput mem;
  const GenerateReport a = generate(s, mem);
  FileOutput files(dir.path.string(), FileOutput::Mode::OnCommit);
  s.threads = 1;
  const GenerateReport b = generate(s, files);
  EXPECT_EQ(a.seed, 7u);
  std::vector<std::string> listed;
  for (auto& f : a.files) listed.push_back(f.name);
  EXPECT_EQ(listed, (std::vector<std::string>{"albedo.png", "height.json", "height.png", "height.r16", "report.json", "terrain.glb",
                                              "terrain.mtl", "terrain.obj"}));
  ASSERT_EQ(a.files.size(), mem.files.size());
  for (auto& f : a.files) {
    ASSERT_TRUE(mem.files.count(f.name)) << f.name;
    EXPECT_EQ(f.bytes, mem.files.at(f.name).size()) << f.name;
    if (f.name != "report.json")  // its timings differ
      EXPECT_EQ(relief::test::slurp(dir.path / f.name), mem.files.at(f.name)) << f.name;
  }
  EXPECT_EQ(a.files.size(), b.files.size());
  // The resolved recipe names the writers that ran, implied ones included.
  ASSERT_TRUE(a.recipe.export_settings.has_value());
  EXPECT_EQ(a.recipe.export_settings->formats, "heightmap,albedo,obj,report,glb");
  EXPECT_EQ(a.timings.size(), s.recipe.stages.size());
}

TEST(Generate, NamedWriterWithoutItsInputIsAnErrorAndWritesNothing) {
  relief::test::TempDir dir("relief-generate");
  const fs::path out = dir.path / "out";
  for (const char* f : {"rivers", "lakes", "biomes", "tilemap"}) {
    GenerateSettings s;
    s.recipe = small("island", 33);  // no flow, biomes or tilemap stage
    s.formats = std::string("heightmap,") + f;
    s.formats_path = "--formats";
    FileOutput files(out.string(), FileOutput::Mode::OnCommit);
    const std::string e = error_of([&] { generate(s, files); });
    EXPECT_NE(e.find(std::string("--formats: ") + f + " needs "), std::string::npos) << e;
    EXPECT_FALSE(fs::exists(out)) << f;
  }
  // From the default set they are skipped, and the report says so.
  GenerateSettings s;
  s.recipe = small("island", 33);
  MemoryOutput mem;
  const GenerateReport r = generate(s, mem);
  EXPECT_TRUE(contains(r.skipped, "rivers"));
  EXPECT_FALSE(mem.files.count("rivers.json"));
}

TEST(Generate, RefusalsComeBeforeAnyWork) {
  relief::test::TempDir dir("relief-generate");
  const fs::path out = dir.path / "out";
  int stages_run = 0;
  auto settings = [&] {
    GenerateSettings s;
    s.recipe = small("island", 65);
    s.after_stage = [&](const Terrain&, const RecipeStage&, int) { ++stages_run; };
    return s;
  };
  {
    GenerateSettings s = settings();
    s.memory_budget_bytes = 1 << 20;  // 1 MiB: nothing fits
    FileOutput files(out.string(), FileOutput::Mode::OnCommit);
    EXPECT_NE(error_of([&] { generate(s, files); }).find("world.size: a 65x65 terrain with these formats needs about"), std::string::npos);
  }
  {
    GenerateSettings s = settings();
    ExportOptions o;
    o.engine = Engine::Unreal;  // 65² is not one of Unreal's sizes
    s.options = o;
    FileOutput files(out.string(), FileOutput::Mode::OnCommit);
    EXPECT_NE(error_of([&] { generate(s, files); }).find("export.engine: unreal needs one of"), std::string::npos);
  }
  EXPECT_EQ(stages_run, 0);
  EXPECT_FALSE(fs::exists(out));
}

TEST(Generate, CancelledOrFailedRunChangesNoOutput) {
  relief::test::TempDir dir("relief-generate");
  const fs::path out = dir.path / "out", other = dir.path / "other";
  fs::create_directories(out);
  relief::test::write_text(out / "height.png", "old");
  int calls = 0;
  GenerateSettings s;
  s.recipe = small("island", 65);
  s.cancelled = [&] { return ++calls > 2; };
  {
    FileOutput files(out.string(), FileOutput::Mode::OnCommit);
    EXPECT_THROW(generate(s, files), Cancelled);
  }
  EXPECT_EQ(relief::test::slurp(out / "height.png"), "old");
  // A writer that fails in before_commit (a second output's file) leaves both outputs unchanged.
  s.cancelled = nullptr;
  {
    FileOutput extra(other.string(), FileOutput::Mode::OnCommit);
    s.also_commit = {&extra};
    s.before_commit = [&](const Terrain&, const Recipe&) {
      extra.put("a.txt", "new");
      throw Error("steps", "no font");
    };
    FileOutput files(out.string(), FileOutput::Mode::OnCommit);
    EXPECT_THROW(generate(s, files), Error);
  }
  EXPECT_FALSE(fs::exists(other / "a.txt"));
  EXPECT_EQ(relief::test::slurp(out / "height.png"), "old");
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator()), 1);  // no temporary left
  // And with it succeeding, both outputs change together.
  {
    FileOutput extra(other.string(), FileOutput::Mode::OnCommit);
    s.also_commit = {&extra};
    s.before_commit = [&](const Terrain&, const Recipe& r) { extra.put("a.txt", "seed " + std::to_string(*r.seed)); };
    FileOutput files(out.string(), FileOutput::Mode::OnCommit);
    generate(s, files);
  }
  EXPECT_NE(relief::test::slurp(out / "height.png"), "old");
  EXPECT_EQ(relief::test::slurp(other / "a.txt"), "seed 7");
}

TEST(Generate, AGivenTerrainIsWrittenWithoutRunningTheStages) {
  GenerateSettings s;
  s.recipe = small("island", 33);
  RunResult res = run(s.recipe);
  int stages_run = 0;
  s.after_stage = [&](const Terrain&, const RecipeStage&, int) { ++stages_run; };
  s.formats = "heightmap";
  MemoryOutput direct;
  GenerateSettings plain = s;
  plain.after_stage = nullptr;
  generate(plain, direct);
  s.terrain = &res.terrain;
  MemoryOutput given;
  generate(s, given);
  EXPECT_EQ(stages_run, 0);
  EXPECT_EQ(given.files, direct.files);
  // A terrain of another size is refused.
  s.recipe = small("island", 65);
  EXPECT_NE(error_of([&] { generate(s, given); }).find("world: the terrain given"), std::string::npos);
}

// Every prop type a built-in preset places has a model, so every preset exports every mesh format
// (the archipelago's palms made --formats all fail before).
TEST(Generate, EveryPresetExportsEveryMeshFormat) {
  for (const PresetInfo& p : list_presets()) {
    if (p.origin != "built-in") continue;
    GenerateSettings s;
    s.recipe = small(p.name, 65);
    s.formats = "glb,fbx,obj";
    MemoryOutput mem;
    EXPECT_NO_THROW(generate(s, mem)) << p.name;
    EXPECT_TRUE(mem.files.count("terrain.glb")) << p.name;
  }
}
