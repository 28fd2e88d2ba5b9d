// Fusion of row stages in run(): a chain of consecutive fusable stages runs in one pass over the
// rows, and must give exactly the bytes of running the stages one by one.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "support.hpp"
#include "relief/stage.hpp"

using namespace relief;

namespace {

Recipe preset(const std::string& name, int size, std::uint64_t seed = 5) { return test::preset_recipe(name, size, seed); }

// Every row stage in one chain, on two layers, with blends that read the layer.
Recipe all_row_stages(int size) {
  json doc = {{"name", "all row stages"},
              {"seed", 11},
              {"world", {{"size", size}, {"width_m", 3000}, {"sea_level", 0.35}}},
              {"stages",
               {{{"stage", "noise"}, {"octaves", 5}},
                {{"stage", "noise"}, {"layer", "moisture"}, {"blend", "multiply"}, {"octaves", 2}},
                {{"stage", "island"}, {"distance", "hyperboloid"}, {"mix", 0.6}},
                {{"stage", "noise"}, {"blend", "add"}, {"amplitude", 0.2}, {"offset", -0.1}, {"salt", 3}},
                {{"stage", "redistribute"}, {"exponent", 1.3}, {"land_only", true}},
                {{"stage", "terrace"}, {"levels", 9}, {"mode", "smooth"}},
                {{"stage", "noise"}, {"layer", "moisture"}, {"blend", "max"}, {"basis", "value"}},
                {{"stage", "curve"}, {"points", {{0.0, 0.0}, {0.5, 0.4}, {1.0, 1.0}}}},
                {{"stage", "color"}},
                {{"stage", "island"}, {"distance", "circular"}, {"shaping", "subtract"}, {"mix", 1.0}},
                {{"stage", "hillshade"}}}}};
  return parse_recipe(doc);
}

void expect_same_layers(const Terrain& a, const Terrain& b, const std::string& what) {
  ASSERT_EQ(a.layers.size(), b.layers.size()) << what;
  for (auto& [name, layer] : a.layers) {
    ASSERT_TRUE(b.has(name)) << what << " " << name;
    EXPECT_EQ(layer.channels, b.get(name).channels) << what << " " << name;
    EXPECT_EQ(layer.data, b.get(name).data) << what << " " << name;
  }
}

}  // namespace

TEST(Fusion, FusedRunEqualsStageByStage) {
  std::vector<std::pair<std::string, Recipe>> recipes = {{"all row stages", all_row_stages(97)}};
  for (const char* p : {"island", "hills", "mountains", "desert", "terraced-valley"}) recipes.push_back({p, preset(p, 97)});
  for (auto& [name, r] : recipes) {
    for (int threads : {1, 3}) {
      RunOptions fused, apart;
      fused.threads = apart.threads = threads;
      apart.fuse = false;
      expect_same_layers(run(r, fused).terrain, run(r, apart).terrain, name + " threads " + std::to_string(threads));
    }
  }
}

TEST(Fusion, TimingsMarkTheFusedStages) {
  RunResult res = run(all_row_stages(33));
  ASSERT_EQ(res.timings.size(), 11u);
  // noise … curve form one chain; color breaks it; island is a chain of one; hillshade.
  const std::vector<bool> fused = {false, true, true, true, true, true, true, true, false, false, false};
  for (std::size_t i = 0; i < fused.size(); ++i) {
    EXPECT_EQ(res.timings[i].fused, fused[i]) << i << " " << res.timings[i].name;
    if (fused[i]) {
      EXPECT_EQ(res.timings[i].ms, 0.0) << i;
    }
  }
  EXPECT_GT(res.timings[0].ms, 0.0);  // the chain's time sits on its first stage
}

TEST(Fusion, OffWhenStagesAreWatched) {
  // after_stage needs every stage's own output: it sees each stage's height, and no stage is fused.
  Recipe r = preset("island", 65);
  std::vector<std::vector<float>> seen;
  RunOptions o;
  o.after_stage = [&](const Terrain& t, const RecipeStage&, int) { seen.push_back(t.get("height").data); };
  RunResult watched = run(r, o);
  ASSERT_EQ(seen.size(), r.stages.size());
  EXPECT_NE(seen[0], seen[1]);  // noise, then island: the island changed the height
  EXPECT_NE(seen[1], seen[2]);  // then redistribute
  for (auto& t : watched.timings) EXPECT_FALSE(t.fused) << t.name;
  // And the final result is the fused run's.
  expect_same_layers(watched.terrain, run(r).terrain, "island watched vs fused");
}

TEST(Fusion, WindowsOfAFusedRunAreSeamless) {
  Recipe r = all_row_stages(129);
  const Frame world = r.world.frame();
  RunResult whole = run(r);
  RunOptions o;
  o.window = world.window(64, 32, 65, 97);
  RunResult part = run(r, o);
  for (const char* layer : {"height", "moisture"})
    for (int j = 0; j < 97; ++j)
      for (int i = 0; i < 65; ++i)
        ASSERT_EQ(part.terrain.get(layer).data[std::size_t(j) * 65 + i],
                  whole.terrain.get(layer).data[std::size_t(32 + j) * 129 + 64 + i])
            << layer << " " << i << "," << j;
}

TEST(Fusion, ErrorInAChainNamesItsStage) {
  // The second stage of the chain needs a height layer nobody wrote.
  json doc = {{"seed", 1},
              {"world", {{"size", 17}}},
              {"stages", {{{"stage", "noise"}, {"layer", "moisture"}}, {{"stage", "curve"}}, {{"stage", "terrace"}}}}};
  try {
    run(parse_recipe(doc));
    ADD_FAILURE() << "expected relief::Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[1]") << e.what();
    EXPECT_NE(std::string(e.what()).find("'height'"), std::string::npos) << e.what();
  }
}

TEST(Fusion, MultiplyIntoANewLayerEqualsSet) {
  auto layer_of = [](const char* blend) {
    json doc = {{"seed", 4}, {"world", {{"size", 33}}}, {"stages", {{{"stage", "noise"}, {"blend", blend}}}}};
    return run(parse_recipe(doc)).terrain.get("height").data;
  };
  EXPECT_EQ(layer_of("multiply"), layer_of("set"));
}

TEST(Fusion, RowStagesDeclareThemselves) {
  for (auto& def : stage_registry()) {
    json obj = {{"stage", def.name}};
    const bool fusable = def.parse(obj, "s")->fusable();
    const bool row_stage = def.name == "noise" || def.name == "island" || def.name == "redistribute" ||
                           def.name == "terrace" || def.name == "curve";
    EXPECT_EQ(fusable, row_stage) << def.name;
    if (fusable) {
      EXPECT_EQ(def.locality, Locality::Pointwise) << def.name;
    }
  }
}

TEST(Recycle, ReusedBuffersGiveTheSameBytes) {
  Recipe r = all_row_stages(65);
  RunResult first = run(r);
  Terrain fresh = run(r).terrain;
  RunOptions o;
  o.recycle = &first.terrain;
  const float* reused = first.terrain.get("color").data.data();
  RunResult again = run(r, o);
  EXPECT_TRUE(first.terrain.layers.empty());  // its buffers moved into the new run
  expect_same_layers(again.terrain, fresh, "recycled vs fresh");
  // The buffer really was reused, for some layer of the same size.
  bool found = false;
  for (auto& [name, l] : again.terrain.layers) found = found || l.data.data() == reused;
  EXPECT_TRUE(found);
  EXPECT_TRUE(again.terrain.spare.empty());
}

TEST(Recycle, SparesAreNeverVisibleAsLayers) {
  // A recycled terrain that held a 'height' must not make noise's multiply see an existing layer.
  json doc = {{"seed", 4}, {"world", {{"size", 33}}}, {"stages", {{{"stage", "noise"}, {"blend", "multiply"}}}}};
  Recipe r = parse_recipe(doc);
  RunResult plain = run(r);
  Terrain old = plain.terrain;
  for (float& v : old.get("height").data) v = 0.0f;  // multiplying by these would give 0
  RunOptions o;
  o.recycle = &old;
  EXPECT_EQ(run(r, o).terrain.get("height").data, plain.terrain.get("height").data);
}
