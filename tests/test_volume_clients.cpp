// The real client tools load the volume files (CTest label `slow`):
//   * Khronos gltf-validator reports 0 errors and 0 warnings on caves.glb;
//   * `assimp info` loads caves.glb and caves.obj with our triangle counts;
//   * Blender 3.4 imports caves.glb (one object per chunk, vertex colours) and reads caves.vdb as a
//     volume object whose grid "surface" loads.
// The fixture: a small cave recipe written once by the CLI.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <regex>
#include <sstream>

#include "relief/generate.hpp"
#include "relief/recipe.hpp"
#include "relief/volume.hpp"
#include "support.hpp"

namespace fs = std::filesystem;
using namespace relief;
using relief::test::Shell;
using relief::test::sh;
using relief::test::slurp;

namespace {

class VolumeClients : public relief::test::SharedFilesTest<VolumeClients> {
 protected:
  static inline fs::path dir;
  static inline long triangles = 0, chunks = 0;

 public:
  static void prepare() {
    dir = fs::temp_directory_path() / ("relief_volume_clients_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const Shell r = sh(std::string(RELIEF_BINARY) + " generate sea-cliff --size 129 --seed 3 -q --formats caves,caves_obj,vdb -o '" +
                       dir.string() + "'");
    ASSERT_EQ(r.code, 0) << r.out;
    // Our own count, from the library on the same recipe.
    json doc = load_preset("sea-cliff");
    doc["world"]["size"] = 129;
    doc["seed"] = 3;
    const Terrain t = run(parse_recipe(doc)).terrain;
    mesh_volume(t, *t.volume, 3, [&](VolumeChunkMesh&& c) {
      triangles += long(c.mesh.triangle_count());
      ++chunks;
    });
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

}  // namespace

TEST_F(VolumeClients, GltfValidatorReportsNoErrorsOrWarnings) {
  const fs::path tools = fs::path(RELIEF_SOURCE_DIR) / "tools";
  ASSERT_TRUE(fs::exists(tools / "node_modules" / "gltf-validator")) << "run scripts/setup.sh (npm ci in tools/)";
  const Shell r = sh("node '" + (tools / "validate_gltf.mjs").string() + "' '" + (dir / "caves.glb").string() + "'");
  EXPECT_EQ(r.code, 0) << r.out;
  const json j = json::parse(r.out.substr(0, r.out.find('\n')));
  EXPECT_EQ(j["errors"], 0) << r.out;
  EXPECT_EQ(j["warnings"], 0) << r.out;
}

TEST_F(VolumeClients, AssimpCountsOurTriangles) {
  ASSERT_GT(triangles, 1000);
  for (const char* f : {"caves.glb", "caves.obj"}) {
    const Shell r = sh("assimp info '" + (dir / f).string() + "' -r");
    ASSERT_EQ(r.code, 0) << r.out;
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(Faces:\s+(\d+))"))) << r.out;
    EXPECT_EQ(std::stol(m[1]), triangles) << f;
    ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(Meshes:\s+(\d+))"))) << r.out;
    EXPECT_EQ(std::stol(m[1]), chunks) << f;
  }
}

TEST_F(VolumeClients, BlenderImportsTheMeshAndReadsTheVdbAsAVolume) {
  const fs::path script = fs::path(RELIEF_SOURCE_DIR) / "tests" / "clients" / "blender_volume.py";
  const fs::path report = dir / "blender.json";
  const Shell r = sh("PATH=/usr/bin:/bin blender -b --factory-startup --python-exit-code 1 --python '" + script.string() + "' -- '" +
                     report.string() + "' '" + (dir / "caves.glb").string() + "' '" + (dir / "caves.vdb").string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const json rep = json::parse(slurp(report));
  long faces = 0, objects = 0;
  for (auto& o : rep["glb"]["objects"]) {
    EXPECT_EQ(o["name"].get<std::string>().rfind("caves_x", 0), 0u) << o;
    EXPECT_GE(o["color_attributes"].get<int>(), 1) << o;
    faces += o["faces"].get<long>();
    ++objects;
  }
  EXPECT_EQ(objects, chunks);
  EXPECT_EQ(faces, triangles);
  ASSERT_EQ(rep["vdb"]["objects"].size(), 1u) << rep.dump();
  const json& v = rep["vdb"]["objects"][0];
  EXPECT_EQ(v["type"], "VOLUME");
  ASSERT_EQ(v["grids"].size(), 1u) << v.dump();
  EXPECT_EQ(v["grids"][0]["name"], "surface");
  EXPECT_EQ(v["grids"][0]["data_type"], "FLOAT");
  EXPECT_TRUE(v["grids"][0]["is_loaded"].get<bool>());
}
