#pragma once
// Helpers shared by the world-build tests (test_world*.cpp): recipes, settings, the whole-map
// reference and byte comparisons of layers and stores.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/world.hpp"
#include "support.hpp"

namespace relief::test::world {

namespace fs = std::filesystem;

inline Recipe recipe_of(json doc, std::uint64_t seed = 11) {
  doc["seed"] = seed;
  return parse_recipe(doc);
}

inline json preset_doc(const std::string& name) { return load_preset(name); }

inline WorldSettings settings(const Recipe& r, std::int64_t nx, std::int64_t nz, int tile, const std::string& dir, int threads = 2) {
  WorldSettings s;
  s.recipe = r;
  s.nx = nx;
  s.nz = nz;
  s.tile = tile;
  s.out_dir = dir;
  s.threads = threads;
  return s;
}

// The whole-map run of `r` at nx × nz.
inline Terrain whole_map(Recipe r, int nx, int nz) {
  r.world.nx = nx;
  r.world.nz = nz;
  RunOptions opt;
  opt.threads = 2;
  return run(r, opt).terrain;
}

inline void expect_same_layers(const Terrain& whole, const Terrain& world) {
  ASSERT_EQ(whole.layers.size(), world.layers.size());
  for (auto& [name, a] : whole.layers) {
    ASSERT_TRUE(world.has(name)) << name;
    const Layer& b = world.layers.at(name);
    ASSERT_EQ(a.channels, b.channels) << name;
    ASSERT_EQ(a.data.size(), b.data.size()) << name;
    std::size_t first = a.data.size();
    for (std::size_t k = 0; k < a.data.size() && first == a.data.size(); ++k)
      if (std::memcmp(&a.data[k], &b.data[k], 4) != 0) first = k;
    EXPECT_EQ(first, a.data.size()) << "layer " << name << " differs first at value " << first;
  }
}

// Every regular file under `dir` (relative path → bytes), leaving out report.json (times).
inline std::map<std::string, std::string> store_files(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) {
      const std::string rel = fs::relative(e.path(), dir).string();
      if (rel != "report.json") files[rel] = relief::test::slurp(e.path());
    }
  return files;
}

inline void expect_same_store(const fs::path& a, const fs::path& b) {
  const auto fa = store_files(a), fb = store_files(b);
  ASSERT_EQ(fa.size(), fb.size());
  for (auto& [name, bytes] : fa) {
    ASSERT_TRUE(fb.count(name)) << name;
    EXPECT_TRUE(bytes == fb.at(name)) << name << " differs";
  }
}

// The river-island preset without its bounded stages (stream_power, hydraulic, thermal), with a
// fill before the flow: noise, island, redistribute, fill, flow (rivers), color, hillshade — every
// stage exact in a world build.
inline json river_world_doc() {
  json doc = load_preset("river-island");
  json stages = json::array();
  for (const json& st : doc["stages"]) {
    const std::string name = st.value("stage", "");
    if (name == "stream_power" || name == "hydraulic" || name == "thermal") continue;
    if (name == "flow") stages.push_back({{"stage", "fill"}, {"epsilon_m", st.value("epsilon_m", 0.0)}});
    stages.push_back(st);
  }
  doc["stages"] = stages;
  doc["name"] = "river-world";
  return doc;
}

// volcanic-island with every stage local: the volcano at a fixed place (the island's middle) and no
// features (a volcano placed on land and features are world algorithms: test_world_features.cpp).
// Both a volcano point (features.json) and props (props.json).
inline json volcanic_fixed_doc() {
  json doc = load_preset("volcanic-island");
  json stages = json::array();
  for (json s : doc["stages"]) {
    if (s["stage"] == "features") continue;
    if (s["stage"] == "volcano") {
      s["placement"] = "fixed";
      s["x_m"] = 2150.0;
      s["z_m"] = 1900.0;
    }
    stages.push_back(s);
  }
  doc["stages"] = stages;
  return doc;
}

// The same points in the same order, bit for bit (positions compared as bytes).
inline void expect_same_points(const std::vector<Point>& a, const std::vector<Point>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    SCOPED_TRACE("point " + std::to_string(k));
    EXPECT_EQ(a[k].kind, b[k].kind);
    EXPECT_EQ(a[k].type, b[k].type);
    EXPECT_EQ(std::memcmp(&a[k].x_m, &b[k].x_m, 8), 0);
    EXPECT_EQ(std::memcmp(&a[k].y_m, &b[k].y_m, 8), 0);
    EXPECT_EQ(std::memcmp(&a[k].z_m, &b[k].z_m, 8), 0);
    EXPECT_EQ(a[k].rotation_deg, b[k].rotation_deg);
    EXPECT_EQ(a[k].scale, b[k].scale);
    if (::testing::Test::HasFailure()) return;
  }
}

}  // namespace relief::test::world
