// `relief generate` with the export writers and writer options: flags generated from the option
// table, bad values exit 2 naming the flag, --engine picks a legal size and adds the engine files,
// --formats all, byte-identical output for any thread count, `relief explain` lists the options.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "support.hpp"

namespace fs = std::filesystem;
using relief::test::relief_cli;
using relief::test::slurp;
using relief::test::TempDir;
using Result = relief::test::Shell;

namespace {

void expect_bad(const std::string& args, const std::string& prefix) {
  relief::test::expect_cli_error(args, "relief: error: " + prefix);
}

}  // namespace

TEST(ExportCli, BadOptionValuesExit2NamingTheFlag) {
  TempDir d;
  const std::string base = "generate island --seed 1 --size 33 -q -o " + d.path.string() + " ";
  expect_bad(base + "--formats stl --stl-size-mm 5", "--stl-size-mm: expected a number in 10..2000, got 5");
  expect_bad(base + "--formats stl --stl-exaggeration lots", "--stl-exaggeration: ");
  expect_bad(base + "--engine cryengine", "--engine: ");
  expect_bad(base + "--engine unreal --split 4", "--split: expected NxM");
  expect_bad(base + "--split 2x2", "--split: splitting writes engine tiles");
  expect_bad(base + "--formats normalmap --normal-bits 12", "--normal-bits: expected 8 or 16");
  expect_bad(base + "--formats glb --lod-msft", "--lod-msft: MSFT_lod needs a chain");
  expect_bad("generate island --seed 1 --size 100 -q -o " + d.path.string() + " --engine unity", "--engine: unity needs one of");
  expect_bad(base + "--formats engine", "--engine: the engine writer needs an engine");
  // Nothing was written by any of the failed runs.
  EXPECT_TRUE(fs::is_empty(d.path));
}

TEST(ExportCli, EnginePicksALegalSizeAndWritesItsFiles) {
  TempDir d;
  // The island recipe is 513²: Unreal's nearest legal size is 505.
  const Result r = relief_cli("generate island --seed 2 --engine unreal --formats heightmap -o " + d.path.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("unreal: using --size 505x505"), std::string::npos) << r.out;
  for (const char* f : {"unreal_height.png", "unreal_height.json", "unreal_import.txt", "height.png"})
    EXPECT_TRUE(fs::exists(d.path / f)) << f;
  const auto s = nlohmann::json::parse(slurp(d.path / "unreal_height.json"));
  EXPECT_EQ(s["samples_per_tile"], 505);
  EXPECT_EQ(fs::file_size(d.path / "height.r16"), 505u * 505u * 2u);

  TempDir t;
  const Result tiles = relief_cli("generate island --seed 2 --size 65 --engine unity --split 2x2 -q --formats heightmap -o " + t.path.string());
  ASSERT_EQ(tiles.code, 0) << tiles.out;
  for (const char* f : {"unity_height_x0_y0.raw", "unity_height_x1_y0.raw", "unity_height_x0_y1.raw", "unity_height_x1_y1.raw"})
    EXPECT_EQ(fs::file_size(t.path / f), 33u * 33u * 2u) << f;

  // Unreal's tiles abut (no shared sample): without --size, a 2×2 split of the 513² island becomes
  // 2 × 253 = 506 samples a side, four 253² tiles (the legal size nearest to half the map).
  TempDir u;
  const Result un = relief_cli("generate island --seed 2 --engine unreal --split 2x2 --formats heightmap -o " + u.path.string());
  ASSERT_EQ(un.code, 0) << un.out;
  EXPECT_NE(un.out.find("unreal: using --size 506x506"), std::string::npos) << un.out;
  const auto us = nlohmann::json::parse(slurp(u.path / "unreal_height.json"));
  EXPECT_EQ(us["samples_per_tile"], 253);
  for (const char* f : {"unreal_height_x0_y0.png", "unreal_height_x1_y0.png", "unreal_height_x0_y1.png", "unreal_height_x1_y1.png"})
    EXPECT_TRUE(fs::exists(u.path / f)) << f;
}

TEST(ExportCli, FormatsAllWritesEveryFileIdenticallyForAnyThreadCount) {
  TempDir a, b;
  const std::string args = "generate island --seed 9 --size 65 --formats all --engine godot --lod-levels 1 --chunk-quads 32 -q -o ";
  ASSERT_EQ(relief_cli(args + a.path.string() + " --threads 1").code, 0);
  const Result r = relief_cli(args + b.path.string() + " --threads 3");
  ASSERT_EQ(r.code, 0) << r.out;
  for (const char* f : {"terrain.glb", "terrain_lod1.glb", "terrain.fbx", "terrain.stl", "terrain.obj", "normal.png", "splat0.png",
                        "splat.json", "hillshade.png", "godot_height.exr", "godot_height.json", "godot_import.txt", "albedo.png"})
    EXPECT_TRUE(fs::exists(a.path / f)) << f;
  std::size_t compared = 0;
  for (auto& e : fs::directory_iterator(a.path)) {
    const std::string name = e.path().filename().string();
    if (name == "report.json") continue;
    EXPECT_EQ(slurp(e.path()), slurp(b.path / name)) << name;
    ++compared;
  }
  EXPECT_GE(compared, 18u);
}

TEST(ExportCli, ExplainAndHelpListTheWriterOptions) {
  const Result e = relief_cli("explain");
  ASSERT_EQ(e.code, 0);
  for (const char* s : {"writer options", "--stl-size-mm", "--engine", "unity|unreal|godot", "--split", "--instancing"})
    EXPECT_NE(e.out.find(s), std::string::npos) << s;
  const auto j = nlohmann::json::parse(relief_cli("explain --json").out);
  bool found = false;
  for (auto& o : j["writer_options"])
    if (o["name"] == "stl_base_mm") {
      found = true;
      EXPECT_EQ(o["flag"], "--stl-base-mm");
      EXPECT_EQ(o["unit"], "mm");
      EXPECT_EQ(o["default"], 3.0);
    }
  EXPECT_TRUE(found);
  const Result h = relief_cli("generate --help");
  EXPECT_NE(h.out.find("--lod-levels"), std::string::npos);
  EXPECT_NE(h.out.find("--stl-exaggeration"), std::string::npos);
}
