// Issue 5's end-to-end claim: a 1025² volcanic island with its props (placed by the props stage,
// not made by hand) exports to every mesh and engine format, and each file loads in the real tools:
// the Khronos glTF validator, assimp and Blender 3.4. CTest label `slow` (not in the ASan pass).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>

#include "support.hpp"

namespace fs = std::filesystem;
using json = nlohmann::json;
using relief::test::Shell;
using relief::test::sh;
using relief::test::slurp;

namespace {

constexpr int kSize = 1025;
constexpr long kGridTriangles = 2L * (kSize - 1) * (kSize - 1);

long assimp_count(const std::string& out, const char* label) {
  std::smatch m;
  if (std::regex_search(out, m, std::regex(std::string(label) + R"(\s+(\d+))"))) return std::stol(m[1]);
  return -1;
}

class VolcanicExport : public relief::test::SharedFilesTest<VolcanicExport> {
 protected:
  static fs::path dir;
  static json props;
 public:
  static void prepare() {
    dir = fs::temp_directory_path() / ("relief-volcanic-" + std::to_string(::getpid()));
    fs::remove_all(dir);
    const Shell r = sh(std::string(RELIEF_BINARY) + " generate volcanic-island --seed 7 --size " + std::to_string(kSize) +
                       " --formats glb,fbx,obj,stl,props --engine unity -q -o '" + dir.string() + "'");
    ASSERT_EQ(r.code, 0) << r.out;
    props = json::parse(slurp(dir / "props.json"));
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};
fs::path VolcanicExport::dir;
json VolcanicExport::props;

}  // namespace

TEST_F(VolcanicExport, TheIslandHasPropsOfSeveralTypes) {
  ASSERT_TRUE(props["props"].is_array());
  EXPECT_GT(props["props"].size(), 500u);
  std::set<std::string> types;
  for (auto& p : props["props"]) types.insert(p["type"].get<std::string>());
  EXPECT_GE(types.size(), 3u);
}

TEST_F(VolcanicExport, GltfValidatorReportsNoErrors) {
  const fs::path tools = fs::path(RELIEF_SOURCE_DIR) / "tools";
  ASSERT_TRUE(fs::exists(tools / "node_modules" / "gltf-validator")) << "run scripts/setup.sh";
  const Shell r = sh("node '" + (tools / "validate_gltf.mjs").string() + "' '" + (dir / "terrain.glb").string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const json j = json::parse(r.out.substr(0, r.out.find('\n')));
  EXPECT_EQ(j["errors"], 0) << r.out;
}

TEST_F(VolcanicExport, AssimpLoadsEveryMeshFormat) {
  for (const char* f : {"terrain.glb", "terrain.fbx", "terrain.obj", "terrain.stl"}) {
    const Shell r = sh("assimp info '" + (dir / f).string() + "' -r");
    EXPECT_EQ(r.code, 0) << f << "\n" << r.out.substr(0, 2000);
    const long faces = assimp_count(r.out, "Faces:");
    if (std::string(f) == "terrain.obj") EXPECT_EQ(faces, kGridTriangles) << f;
    else EXPECT_GT(faces, kGridTriangles) << f;  // props (glb, fbx) or skirt and base (stl) on top
  }
  // assimp does not check that named textures exist: we do.
  EXPECT_TRUE(fs::exists(dir / "albedo.png"));
  EXPECT_NE(slurp(dir / "terrain.mtl").find("map_Kd albedo.png"), std::string::npos);
}

TEST_F(VolcanicExport, BlenderImportsGlbAndFbxWithEveryProp) {
  const fs::path script = fs::path(RELIEF_SOURCE_DIR) / "tests" / "clients" / "blender_check.py";
  const fs::path report = dir / "blender.json";
  const Shell r = sh("blender -b --factory-startup --python-exit-code 1 --python '" + script.string() + "' -- '" +
                     report.string() + "' '" + (dir / "terrain.glb").string() + "' '" + (dir / "terrain.fbx").string() + "'");
  ASSERT_EQ(r.code, 0) << r.out.substr(r.out.size() > 4000 ? r.out.size() - 4000 : 0);
  const json j = json::parse(slurp(report));
  std::set<std::string> prop_types;
  for (auto& p : props["props"]) prop_types.insert(p["type"].get<std::string>());
  for (const char* f : {"terrain.glb", "terrain.fbx"}) {
    const std::string key = (dir / f).string();
    ASSERT_TRUE(j.contains(key)) << f;
    long terrain_faces = 0, prop_objects = 0;
    for (auto& ob : j[key]["objects"]) {
      const std::string name = ob["name"];
      if (name.rfind("terrain", 0) == 0) terrain_faces += ob["faces"].get<long>();
      else
        for (auto& t : prop_types)
          if (name.rfind(t, 0) == 0) {
            ++prop_objects;
            break;
          }
    }
    EXPECT_EQ(terrain_faces, kGridTriangles) << f;
    EXPECT_EQ(prop_objects, long(props["props"].size())) << f;
    EXPECT_GE(j[key]["textured_materials"].size(), 1u) << f;
  }
}

TEST_F(VolcanicExport, UnityRawHasTheEngineSizeAndByteCount) {
  EXPECT_EQ(fs::file_size(dir / "unity_height.raw"), std::uintmax_t(kSize) * kSize * 2);
  const json meta = json::parse(slurp(dir / "unity_height.json"));
  EXPECT_NE(meta.dump().find("1025"), std::string::npos);
}
