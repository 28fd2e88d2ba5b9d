// Resuming a run from a snapshot (RunOptions::resume) and cancelling between stages
// (RunOptions::cancelled): what the studio's stage cache and superseding rely on.
#include <gtest/gtest.h>

#include <cstring>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

using namespace relief;

namespace {

json island_doc(int size = 65, std::uint64_t seed = 7) {
  json doc = load_preset("island");
  doc["world"]["size"] = size;
  doc["seed"] = seed;
  return doc;
}

// Every layer of `a` equals the same layer of `b` bit for bit, and they have the same layers.
void expect_same_terrain(const Terrain& a, const Terrain& b) {
  ASSERT_EQ(a.layers.size(), b.layers.size());
  for (auto& [name, la] : a.layers) {
    ASSERT_TRUE(b.has(name)) << name;
    const Layer& lb = b.layers.at(name);
    ASSERT_EQ(la.channels, lb.channels) << name;
    ASSERT_EQ(la.data.size(), lb.data.size()) << name;
    EXPECT_EQ(0, std::memcmp(la.data.data(), lb.data.data(), la.data.size() * sizeof(float))) << name;
  }
  EXPECT_EQ(a.points.size(), b.points.size());
}

std::vector<Terrain> snapshots_of(const Recipe& r) {
  std::vector<Terrain> snaps;
  RunOptions opt;
  opt.after_stage = [&](const Terrain& t, const RecipeStage&, int) { snaps.push_back(t); };
  run(r, opt);
  return snaps;
}

}  // namespace

TEST(Resume, FromEverySnapshotEqualsTheFullRun) {
  const Recipe r = parse_recipe(island_doc());
  const RunResult full = run(r);
  const std::vector<Terrain> snaps = snapshots_of(r);
  ASSERT_EQ(snaps.size(), r.stages.size());
  for (std::size_t k = 1; k <= r.stages.size(); ++k) {
    RunOptions opt;
    opt.resume = Resume{&snaps[k - 1], int(k)};
    const RunResult res = run(r, opt);
    SCOPED_TRACE("resumed at stage " + std::to_string(k));
    expect_same_terrain(full.terrain, res.terrain);
    EXPECT_EQ(res.timings.size(), r.stages.size() - k);  // only the stages that ran
  }
}

// The studio's cache: snapshots where fused chains end, so the cached run keeps fusion. The island
// preset is noise, island, redistribute (one fused chain), then color and hillshade.
TEST(Resume, SnapshotsAtChainEndsKeepFusion) {
  const Recipe r = parse_recipe(island_doc());
  const RunResult full = run(r);
  std::vector<int> at;
  std::vector<Terrain> snaps;
  RunOptions opt;
  opt.after_stage_keeps_fusion = true;
  opt.after_stage = [&](const Terrain& t, const RecipeStage&, int i) {
    at.push_back(i);
    snaps.push_back(t);
  };
  const RunResult res = run(r, opt);
  expect_same_terrain(full.terrain, res.terrain);
  ASSERT_EQ(r.stages.size(), 5u);
  EXPECT_EQ(at, (std::vector<int>{2, 3, 4}));  // the chain [0, 3) ends at 2
  ASSERT_EQ(res.timings.size(), 5u);
  EXPECT_TRUE(res.timings[1].fused && res.timings[2].fused);  // fusion stayed on
  for (std::size_t k = 0; k < at.size(); ++k) {
    RunOptions o;
    o.resume = Resume{&snaps[k], at[k] + 1};
    SCOPED_TRACE("resumed after stage " + std::to_string(at[k]));
    expect_same_terrain(full.terrain, run(r, o).terrain);
  }
  // Without the flag, after_stage sees every stage and fusion is off.
  RunOptions plain;
  at.clear();
  plain.after_stage = [&](const Terrain&, const RecipeStage&, int i) { at.push_back(i); };
  const RunResult unfused = run(r, plain);
  EXPECT_EQ(at, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_FALSE(unfused.timings[1].fused);
}

TEST(Resume, ColourChangeReusesTheHeightsOfTheOldRecipe) {
  // The studio's case: only the colour stage's params change, so the snapshot taken before it by
  // the old recipe is a valid start for the new one.
  json a = island_doc(), b = island_doc();
  int color_index = -1;
  for (std::size_t i = 0; i < b["stages"].size(); ++i)
    if (b["stages"][i]["stage"] == "color") color_index = int(i);
  ASSERT_GE(color_index, 1);
  b["stages"][color_index]["rock_slope_deg"] = 12;
  b["stages"][color_index]["variation"] = 0.1;
  const Recipe ra = parse_recipe(a), rb = parse_recipe(b);
  const std::vector<Terrain> snaps = snapshots_of(ra);
  RunOptions opt;
  opt.resume = Resume{&snaps[color_index - 1], color_index};
  const RunResult resumed = run(rb, opt);
  const RunResult full = run(rb);
  expect_same_terrain(full.terrain, resumed.terrain);
  // and the change is real: the old recipe's albedo differs
  EXPECT_NE(0, std::memcmp(snaps.back().get("albedo").data.data(), full.terrain.get("albedo").data.data(),
                           full.terrain.get("albedo").data.size() * sizeof(float)));
}

TEST(Resume, AtTheEndReturnsTheSnapshotUnchanged) {
  const Recipe r = parse_recipe(island_doc());
  const std::vector<Terrain> snaps = snapshots_of(r);
  RunOptions opt;
  opt.resume = Resume{&snaps.back(), int(r.stages.size())};
  const RunResult res = run(r, opt);
  expect_same_terrain(snaps.back(), res.terrain);
  EXPECT_TRUE(res.timings.empty());
}

TEST(Resume, RejectsASnapshotOfAnotherFrame) {
  const Recipe small = parse_recipe(island_doc(65)), big = parse_recipe(island_doc(129));
  const std::vector<Terrain> snaps = snapshots_of(small);
  RunOptions opt;
  opt.resume = Resume{&snaps[0], 1};
  try {
    run(big, opt);
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "resume");
  }
}

TEST(Resume, RejectsAFirstStageOutOfRange) {
  const Recipe r = parse_recipe(island_doc());
  const std::vector<Terrain> snaps = snapshots_of(r);
  for (int bad : {-1, int(r.stages.size()) + 1}) {
    RunOptions opt;
    opt.resume = Resume{&snaps[0], bad};
    try {
      run(r, opt);
      FAIL() << "expected an Error for " << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.path(), "resume");
      EXPECT_NE(std::string(e.what()).find("0.." + std::to_string(r.stages.size())), std::string::npos) << e.what();
    }
  }
}

TEST(Resume, NeedsTheRecipeSeed) {
  json doc = island_doc();
  const std::vector<Terrain> snaps = snapshots_of(parse_recipe(doc));
  doc.erase("seed");
  RunOptions opt;
  opt.resume = Resume{&snaps[0], 1};
  try {
    run(parse_recipe(doc), opt);
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "seed");
  }
}

TEST(Cancel, StopsBetweenStagesWithCancelled) {
  const Recipe r = parse_recipe(island_doc());
  int ran = 0;
  RunOptions opt;
  opt.after_stage = [&](const Terrain&, const RecipeStage&, int) { ++ran; };
  opt.cancelled = [&] { return ran == 2; };
  EXPECT_THROW(run(r, opt), Cancelled);
  EXPECT_EQ(ran, 2);
}

TEST(Cancel, NeverCancelledRunsEveryStage) {
  const Recipe r = parse_recipe(island_doc());
  int asked = 0;
  RunOptions opt;
  opt.cancelled = [&] { return ++asked < 0; };
  const RunResult res = run(r, opt);
  EXPECT_GE(asked, int(r.stages.size()));  // before each stage, and more within the row pass
  EXPECT_EQ(res.timings.size(), r.stages.size());
}

// A lone noise stage (one row pass) is cancelled between its row blocks, not only after it.
TEST(Cancel, StopsWithinARowPass) {
  json doc = island_doc(513);
  doc["stages"] = json::array({doc["stages"][0]});
  const Recipe r = parse_recipe(doc);
  int asked = 0;
  bool finished = false;
  RunOptions opt;
  opt.threads = 1;
  opt.after_stage = [&](const Terrain&, const RecipeStage&, int) { finished = true; };
  opt.cancelled = [&] { return ++asked == 3; };
  EXPECT_THROW(run(r, opt), Cancelled);
  EXPECT_FALSE(finished);
  EXPECT_EQ(asked, 3);
}

// A long stage that reports progress (stream power, every step) is cancelled inside it.
TEST(Cancel, StopsInsideALongStageWhereItReportsProgress) {
  json doc = island_doc(129);
  doc["stages"] = json::array({doc["stages"][0], json{{"stage", "stream_power"}, {"steps", 40}}});
  const Recipe r = parse_recipe(doc);
  int finished = 0, asked_in_erosion = 0;
  RunOptions opt;
  opt.threads = 1;
  opt.after_stage = [&](const Terrain&, const RecipeStage&, int) { ++finished; };
  opt.cancelled = [&] { return finished == 1 && ++asked_in_erosion == 5; };
  EXPECT_THROW(run(r, opt), Cancelled);
  EXPECT_EQ(finished, 1);  // the noise stage, not the erosion
  EXPECT_EQ(asked_in_erosion, 5);
}
