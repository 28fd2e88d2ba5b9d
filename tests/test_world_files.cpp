// The world files beside a world build's tiles (relief/world.hpp, issue 18): the points of the
// stages that make them (props.json, props.csv, features.json), byte for byte the whole map's, kept
// per tile in points/ for resuming; and overview.png's picture.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "relief/world.hpp"
#include "relief/world_points.hpp"
#include "support.hpp"
#include "world_support.hpp"

namespace fs = std::filesystem;
using namespace relief;
using namespace relief::test::world;
using relief::test::relief_cli;
using relief::test::slurp;
using relief::test::TempDir;

namespace {

// `relief generate` of the whole map into `dir`; the point files are compared with the world's.
void generate_whole(const std::string& recipe, const std::string& size, const std::string& dir) {
  const auto r = relief_cli("generate " + recipe + " --size " + size + " --seed 7 -q -o " + dir);
  ASSERT_EQ(r.code, 0) << r.out;
}

json report_of(const fs::path& dir) { return json::parse(slurp(dir / "report.json")); }

}  // namespace

TEST(WorldFiles, PropsOfATiledWorldAreTheWholeMapsFilesByteForByte) {
  TempDir d("world-props");
  generate_whole("archipelago", "513", d / "whole");
  const std::string whole_json = slurp(fs::path(d / "whole") / "props.json");
  ASSERT_GT(whole_json.size(), 100u);
  for (const char* tile : {"65", "129"}) {
    SCOPED_TRACE(std::string("tile ") + tile);
    const fs::path w = d / (std::string("w") + tile);
    const auto r = relief_cli("world archipelago --size 513 --tile " + std::string(tile) + " --seed 7 -j 2 -o " + w.string());
    ASSERT_EQ(r.code, 0) << r.out;
    EXPECT_NE(r.out.find("props.json, props.csv"), std::string::npos) << r.out;
    EXPECT_EQ(slurp(w / "props.json"), whole_json);
    EXPECT_EQ(slurp(w / "props.csv"), slurp(fs::path(d / "whole") / "props.csv"));
    EXPECT_FALSE(fs::exists(w / "features.json"));
  }
}

TEST(WorldFiles, AClippedWorldsPropsAreTheWholeMaps) {
  TempDir d("world-props-clip");
  generate_whole("archipelago", "500x513", d / "whole");
  const auto r = relief_cli("world archipelago --size 500x513 --tile 129 --seed 7 -j 1 -q -o " + (d / "w"));
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_EQ(slurp(fs::path(d / "w") / "props.json"), slurp(fs::path(d / "whole") / "props.json"));
}

TEST(WorldFiles, TheVolcanoPointAndPropsComeInRecipeOrderAsOnTheWholeMap) {
  TempDir d("world-volcano-points");
  const std::string recipe = d / "volcanic.json";
  relief::test::write_text(recipe, volcanic_fixed_doc().dump(2));
  generate_whole(recipe, "513", d / "whole");
  const auto r = relief_cli("world " + recipe + " --size 513 --tile 129 --seed 7 -j 2 -q -o " + (d / "w"));
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string features = slurp(fs::path(d / "w") / "features.json");
  EXPECT_NE(features.find("volcano"), std::string::npos);
  EXPECT_EQ(features, slurp(fs::path(d / "whole") / "features.json"));
  EXPECT_EQ(slurp(fs::path(d / "w") / "props.json"), slurp(fs::path(d / "whole") / "props.json"));
}

TEST(WorldFiles, AMissingOrDamagedPointFileRebuildsItsTileAndTheFilesStayTheSame) {
  TempDir d("world-points-resume");
  const fs::path w = d / "w";
  const std::string args = "world archipelago --size 513 --tile 129 --seed 7 -j 2 -q -o " + w.string();
  ASSERT_EQ(relief_cli(args).code, 0);
  const std::string props = slurp(w / "props.json");
  const fs::path one = w / "points" / "p0" / "x0001_z0002.json";
  ASSERT_TRUE(fs::exists(one));
  // Complete: a rerun rebuilds nothing and writes the same files.
  ASSERT_EQ(relief_cli(args).code, 0);
  EXPECT_EQ(report_of(w)["tiles"]["built"], 0);
  EXPECT_EQ(slurp(w / "props.json"), props);
  // Missing: that tile is built again.
  fs::remove(one);
  ASSERT_EQ(relief_cli(args).code, 0);
  EXPECT_EQ(report_of(w)["tiles"]["built"], 1);
  EXPECT_TRUE(fs::exists(one));
  EXPECT_EQ(slurp(w / "props.json"), props);
  // Damaged, or of another tile: built again.
  relief::test::write_text(one, slurp(w / "points" / "p0" / "x0002_z0002.json"));
  ASSERT_EQ(relief_cli(args).code, 0);
  EXPECT_EQ(report_of(w)["tiles"]["built"], 1);
  relief::test::write_text(one, "{\"format\": 1, \"phase\"");
  ASSERT_EQ(relief_cli(args).code, 0);
  EXPECT_EQ(report_of(w)["tiles"]["built"], 1);
  EXPECT_EQ(slurp(w / "props.json"), props);
  EXPECT_TRUE(verify_world(w.string()).empty());
}

TEST(WorldFiles, ForceRemovesTheOldWorldsPointFiles) {
  TempDir d("world-points-force");
  const fs::path w = d / "w";
  ASSERT_EQ(relief_cli("world archipelago --size 257 --tile 129 --seed 7 -q -o " + w.string()).code, 0);
  ASSERT_TRUE(fs::exists(w / "props.json"));
  ASSERT_TRUE(fs::exists(w / "points" / "p0"));
  relief::test::write_text(w / "notes.txt", "mine");
  const auto r = relief_cli("world island --size 257 --tile 129 --seed 7 -q --force -o " + w.string());
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_FALSE(fs::exists(w / "props.json"));
  EXPECT_FALSE(fs::exists(w / "props.csv"));
  EXPECT_FALSE(fs::exists(w / "points"));
  EXPECT_TRUE(fs::exists(w / "notes.txt"));
}

TEST(WorldFiles, PointFilesReadBackAndRefuseAnotherTileOrPhase) {
  std::vector<Point> pts(2);
  pts[0] = {"prop", "palm", 0.1, 1.0 / 3.0, 12345.678901234567, 17.5, 0.93};
  pts[1] = {"volcano", "volcano", -2.5e-300, 7e300, 3, 0, 1};
  const std::string bytes = encode_world_points("abc-p0", 3, 4, pts);
  const std::vector<Point> back = decode_world_points(bytes, "abc-p0", 3, 4, "f");
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back[i].kind, pts[i].kind);
    EXPECT_EQ(back[i].type, pts[i].type);
    EXPECT_EQ(back[i].x_m, pts[i].x_m);  // exactly: the files must give the whole map's bytes
    EXPECT_EQ(back[i].y_m, pts[i].y_m);
    EXPECT_EQ(back[i].z_m, pts[i].z_m);
    EXPECT_EQ(back[i].rotation_deg, pts[i].rotation_deg);
    EXPECT_EQ(back[i].scale, pts[i].scale);
  }
  EXPECT_THROW(decode_world_points(bytes, "abc-p1", 3, 4, "f"), Error);
  EXPECT_THROW(decode_world_points(bytes, "abc-p0", 4, 3, "f"), Error);
  for (const char* bad : {"", "[]", "{\"format\": 2}", "{\"format\": 1, \"phase\": \"abc-p0\", \"tile\": [3, 4], \"points\": [[1]]}",
                          "{\"format\": 1, \"phase\": \"abc-p0\", \"tile\": [3, 4], \"points\": [[\"a\", \"b\", 1, 2, 3, 4, \"x\"]]}"})
    EXPECT_THROW(decode_world_points(bad, "abc-p0", 3, 4, "f"), Error) << bad;
}

TEST(WorldFiles, GlobalStagePointsGoWhereTheirStageStands) {
  // volcano (global here) before props (local): the volcano's list first, then the props by position.
  const Recipe r = recipe_of(volcanic_fixed_doc());
  int volcano = -1;
  for (std::size_t i = 0; i < r.stages.size(); ++i)
    if (r.stages[i].def->name == "volcano") volcano = int(i);
  ASSERT_GE(volcano, 0);
  Point a{"prop", "palm", 5, 0, 9, 0, 1}, b{"prop", "rock", 1, 0, 2, 0, 1}, v{"volcano", "volcano", 3, 0, 3, 0, 1};
  const std::vector<Point> m = merge_world_points(r, {{a}, {b}}, {{volcano, {v}}});
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0].kind, "volcano");
  EXPECT_EQ(m[1].type, "rock");  // z 2 before z 9
  EXPECT_EQ(m[2].type, "palm");
}

TEST(WorldFiles, OverviewIsTheWorldDownsampledAndShaded) {
  TempDir d("world-overview");
  const fs::path w = d / "w";
  ASSERT_EQ(relief_cli("world island --size 4097x2049 --tile 513 --seed 3 -j 2 -q -o " + w.string()).code, 0);
  const json m = read_world_manifest(w.string());
  const int step = m["overview"]["step"].get<int>();
  EXPECT_EQ(step, 3);
  const relief::test::Png png = relief::test::decode_png(slurp(w / "overview.png"), SPNG_FMT_RGB8);
  EXPECT_EQ(png.width(), (4097 - 1) / 3 + 1);
  EXPECT_EQ(png.height(), (2049 - 1) / 3 + 1);
  // Sea (blue dominant) and land (not) both appear: the island preset has both.
  std::size_t sea = 0, land = 0;
  for (std::size_t k = 0; k + 2 < png.bytes.size(); k += 3) (png.bytes[k + 2] > png.bytes[k + 1] ? sea : land)++;
  EXPECT_GT(sea, png.bytes.size() / 3 / 10);
  EXPECT_GT(land, png.bytes.size() / 3 / 20);
  // No temporary file is left in the folder.
  for (const auto& e : fs::directory_iterator(w)) EXPECT_EQ(e.path().filename().string().find(".overview"), std::string::npos);
}

TEST(WorldFiles, TheVolcanicIslandPresetsFeaturesAndPropsAreTheWholeMaps) {
  // The volcano (placed on land) and the features are world algorithms: their points reach the
  // world's features.json through WorldStageIO::points, in recipe order before the props.
  TempDir d("world-volcanic-files");
  generate_whole("volcanic-island", "513", d / "whole");
  const auto r = relief_cli("world volcanic-island --size 513 --tile 129 --seed 7 -j 2 -q -o " + (d / "w"));
  ASSERT_EQ(r.code, 0) << r.out;
  const std::string features = slurp(fs::path(d / "w") / "features.json");
  EXPECT_NE(features.find("volcano"), std::string::npos);
  EXPECT_NE(features.find("crater"), std::string::npos);
  EXPECT_EQ(features, slurp(fs::path(d / "whole") / "features.json"));
  EXPECT_EQ(slurp(fs::path(d / "w") / "props.json"), slurp(fs::path(d / "whole") / "props.json"));
  // A rerun of the complete build (every phase skipped) writes the same files from points/.
  ASSERT_EQ(relief_cli("world volcanic-island --size 513 --tile 129 --seed 7 -j 2 -q -o " + (d / "w")).code, 0);
  EXPECT_EQ(report_of(fs::path(d / "w"))["tiles"]["built"], 0);
  EXPECT_EQ(slurp(fs::path(d / "w") / "features.json"), features);
}
