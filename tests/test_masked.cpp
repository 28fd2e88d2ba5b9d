// The optional `mask` parameter of the stages that change height (src/stage_masked.cpp):
// out = before + clamp(m, 0, 1) · (stage(before) − before), fused or not, on windows, with errors
// naming stages[i].mask.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/stage.hpp"
#include "support.hpp"

using namespace relief;

namespace {

json world(int size) { return {{"size", size}, {"width_m", 3000}, {"height_m", 800}, {"sea_level", 0.35}}; }

// A base terrain and a soft mask with fractional values: noise, then a mask band with soft edges.
json base_stages() {
  return json::array({{{"stage", "noise"}, {"octaves", 5}},
                      {{"stage", "island"}, {"distance", "circular"}, {"mix", 0.7}},
                      {{"stage", "mask"}, {"from", 0.4}, {"to", 0.6}, {"soft", 0.15}, {"layer", "m"}}});
}

Recipe recipe_with(const json& more, int size = 65) {
  json stages = base_stages();
  for (auto& s : more) stages.push_back(s);
  return parse_recipe(json{{"seed", 9}, {"world", world(size)}, {"stages", stages}});
}

RunResult run_with(const json& more, int size = 65, int threads = 0, bool fuse = true) {
  RunOptions o;
  o.threads = threads;
  o.fuse = fuse;
  return run(recipe_with(more, size), o);
}

const std::vector<float>& height(const RunResult& r) { return r.terrain.get("height").data; }

// One case per stage that takes the mask, with parameters that change the height visibly.
std::vector<json> masked_stage_cases() {
  return {
      {{"stage", "noise"}, {"blend", "add"}, {"amplitude", 0.2}, {"offset", -0.1}, {"salt", 4}},
      {{"stage", "redistribute"}, {"exponent", 2.0}},
      {{"stage", "terrace"}, {"levels", 5}},
      {{"stage", "terrace"}, {"levels", 9}, {"filter_samples", 2}},
      {{"stage", "island"}, {"distance", "square_bump"}, {"mix", 0.8}},
      {{"stage", "curve"}, {"points", {{0.0, 0.0}, {0.5, 0.2}, {1.0, 1.0}}}},
      {{"stage", "thermal"}, {"talus_deg", 10}, {"distance_m", 200}},
      {{"stage", "hydraulic"}, {"droplets_per_km2", 2000}},
      {{"stage", "stream_power"}, {"steps", 5}, {"duration_years", 2e5}},
      {{"stage", "amplify"}},
  };
}

json with_mask(json s, const std::string& mask) {
  s["mask"] = mask;
  return s;
}

TEST(MaskParam, EveryHeightStageBlendsItsEffectThroughTheMask) {
  const std::vector<float> before = height(run_with(json::array()));
  const std::vector<float> m = run_with(json::array()).terrain.get("m").data;
  int fractional = 0;
  for (float w : m) fractional += w > 0.0f && w < 1.0f;
  ASSERT_GT(fractional, 20) << "the mask must have soft edges for this test";
  for (const json& st : masked_stage_cases()) {
    const std::string what = st.dump();
    const std::vector<float> full = height(run_with(json::array({st})));
    const std::vector<float> got = height(run_with(json::array({with_mask(st, "m")})));
    ASSERT_EQ(got.size(), before.size()) << what;
    int changed = 0, kept = 0;
    for (std::size_t k = 0; k < got.size(); ++k) {
      const float w = m[k];
      const float want = w >= 1.0f ? full[k] : before[k] + w * (full[k] - before[k]);
      ASSERT_EQ(got[k], want) << what << " at " << k << " mask " << w;
      kept += w == 0.0f && got[k] == before[k];
      changed += w > 0.0f && full[k] != before[k] && got[k] != before[k];
    }
    EXPECT_GT(kept, 0) << what;
    EXPECT_GT(changed, 0) << what << ": the stage must change the height under the mask";
  }
}

TEST(MaskParam, AllZeroMaskLeavesTheHeightAllOnesIsTheStage) {
  for (const json& st : masked_stage_cases()) {
    const std::string what = st.dump();
    const json zero = {{"stage", "noise"}, {"layer", "z"}, {"amplitude", 0}, {"offset", 0}};
    const json one = {{"stage", "noise"}, {"layer", "o"}, {"amplitude", 0}, {"offset", 1}};
    const std::vector<float> before = height(run_with(json::array({zero, one})));
    EXPECT_EQ(height(run_with(json::array({zero, one, with_mask(st, "z")}))), before) << what;
    EXPECT_EQ(height(run_with(json::array({zero, one, with_mask(st, "o")}))), height(run_with(json::array({zero, one, st}))))
        << what;
  }
}

TEST(MaskParam, FusedEqualsStageByStageForAnyThreadCount) {
  const json chain = json::array({with_mask({{"stage", "noise"}, {"blend", "add"}, {"amplitude", 0.2}, {"salt", 2}}, "m"),
                                  with_mask({{"stage", "redistribute"}, {"exponent", 1.6}}, "m"),
                                  {{"stage", "noise"}, {"layer", "m"}, {"blend", "multiply"}, {"octaves", 2}, {"salt", 5}},
                                  with_mask({{"stage", "terrace"}, {"levels", 7}, {"mode", "smooth"}}, "m"),
                                  with_mask({{"stage", "curve"}, {"points", {{0.0, 0.1}, {1.0, 0.9}}}}, "m")});
  const RunResult fused = run_with(chain, 97, 1, true);
  int n_fused = 0;
  for (auto& t : fused.timings) n_fused += t.fused;
  EXPECT_GE(n_fused, 3) << "masked row stages stay fusable";
  for (int threads : {1, 2, 3}) {
    EXPECT_EQ(height(run_with(chain, 97, threads, true)), height(fused)) << threads;
    EXPECT_EQ(height(run_with(chain, 97, threads, false)), height(fused)) << threads;
  }
}

TEST(MaskParam, WindowsOfMaskedStagesJoinTheWholeMap) {
  // Masked pointwise (noise, terrace) and neighbourhood (thermal) stages on a window equal the whole map.
  const Recipe r = recipe_with(json::array({with_mask({{"stage", "noise"}, {"blend", "add"}, {"amplitude", 0.1}}, "m"),
                                            with_mask({{"stage", "thermal"}, {"talus_deg", 15}, {"distance_m", 150}}, "m"),
                                            with_mask({{"stage", "terrace"}, {"levels", 6}}, "m")}),
                               129);
  const RunResult whole = run(r);
  RunOptions o;
  o.window = r.world.frame().window(40, 24, 65, 81);
  const RunResult part = run(r, o);
  for (int j = 0; j < 81; ++j)
    for (int i = 0; i < 65; ++i)
      ASSERT_EQ(part.terrain.get("height").data[std::size_t(j) * 65 + i],
                whole.terrain.get("height").data[std::size_t(24 + j) * 129 + 40 + i])
          << i << "," << j;
}

TEST(MaskParam, ErrorsNameTheMaskField) {
  auto path_of = [](const json& more) -> std::string {
    try {
      run_with(more, 33);
    } catch (const Error& e) {
      return e.path();
    }
    return "no error";
  };
  EXPECT_EQ(path_of(json::array({with_mask({{"stage", "terrace"}}, "nope")})), "stages[3].mask");
  EXPECT_EQ(path_of(json::array({with_mask({{"stage", "thermal"}}, "nope")})), "stages[3].mask");
  EXPECT_EQ(path_of(json::array({with_mask({{"stage", "terrace"}}, "height")})), "stages[3].mask");
  EXPECT_EQ(path_of(json::array({with_mask({{"stage", "noise"}, {"layer", "m"}}, "m")})), "stages[3].mask");
  try {
    recipe_with(json::array({{{"stage", "terrace"}, {"mask", 3}}}));
    FAIL() << "a mask that is not a string is refused";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[3].mask");
  }
  try {
    recipe_with(json::array({{{"stage", "color"}, {"mask", "m"}}}));
    FAIL() << "stages that do not change height take no mask";
  } catch (const Error& e) {
    EXPECT_EQ(e.path(), "stages[3].mask");
  }
}

TEST(MaskParam, DeclaredOnTheHeightStagesAndListedOnlyWhenSet) {
  for (const char* name : {"noise", "redistribute", "terrace", "island", "curve", "hydraulic", "thermal", "stream_power", "amplify"}) {
    const StageDef* d = find_stage(name);
    ASSERT_NE(d, nullptr) << name;
    int n = 0;
    for (auto& p : d->params) n += p.name == "mask" && p.type == ParamType::Text && p.default_value == "";
    EXPECT_EQ(n, 1) << name;
  }
  for (const char* name : {"color", "fill", "flow", "slope", "hillshade"}) {
    for (auto& p : find_stage(name)->params) EXPECT_NE(p.name, "mask") << name;
  }
  // An unmasked stage resolves as before (saved recipes of existing recipes do not change); a masked one says so.
  const Recipe r = recipe_with(json::array({{{"stage", "terrace"}}, {{"stage", "terrace"}, {"mask", ""}}, with_mask({{"stage", "terrace"}}, "m")}));
  EXPECT_FALSE(r.stages[3].stage->params().contains("mask"));
  EXPECT_FALSE(r.stages[4].stage->params().contains("mask"));
  EXPECT_EQ(r.stages[5].stage->params().at("mask"), "m");
  // And the resolved params read back to the same stage.
  json again = r.stages[5].stage->params();
  again["stage"] = "terrace";
  const Recipe back = parse_recipe(json{{"seed", 9}, {"world", world(65)}, {"stages", json::array({again})}});
  EXPECT_EQ(back.stages[0].stage->params(), r.stages[5].stage->params());
}

TEST(MaskParam, MemoryEstimateCountsTheCopyOfAMaskedLayer) {
  // stream_power's scratch (44 bytes a sample) is above the encoders' (18), so the copy shows.
  const Recipe plain = recipe_with(json::array({{{"stage", "stream_power"}}}), 257);
  const Recipe masked = recipe_with(json::array({with_mask({{"stage", "stream_power"}}, "m")}), 257);
  EXPECT_EQ(estimate_memory_bytes(masked, false) - estimate_memory_bytes(plain, false), 257u * 257u * 4u);
}

}  // namespace
