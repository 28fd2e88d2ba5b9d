// The real client tools load what we write (CTest label `slow`):
//   * Khronos gltf-validator (npm, tools/) reports 0 errors on every GLB variant;
//   * `assimp info` loads GLB, FBX, OBJ and STL with the expected counts, and the texture files
//     the OBJ and FBX name exist;
//   * Blender 3.4 imports GLB, OBJ and FBX (one Blender run) with the expected vertex and face
//     counts, UVs, vertex colours and texture;
//   * Pillow (and a small PNG decoder in Python for 16-bit RGB, which Pillow reduces to 8 bits)
//     reads the 16-bit PNGs back with the expected sizes and value ranges.
// The fixture: the island preset at 65² with hand-made props and a vertex-jiggle layer.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "relief/export.hpp"
#include "support.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/random.hpp"
#include "relief/recipe.hpp"
#include "writer_defs.hpp"

namespace fs = std::filesystem;
using namespace relief;

namespace {

using relief::test::Shell;
using relief::test::sh;
using relief::test::slurp;

constexpr int kSize = 65, kChunk = 32;

// Writes every mesh and map variant once for all tests of this file.
class Clients : public relief::test::SharedFilesTest<Clients> {
 protected:
  static inline fs::path dir;
  static inline Terrain terrain;
  static inline std::size_t prop_vertices = 0, prop_triangles = 0;

 public:
  static void prepare() {
    dir = fs::temp_directory_path() / ("relief_clients_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    json doc = load_preset("island");
    doc["world"]["size"] = kSize;
    doc["seed"] = 5;
    terrain = run(parse_recipe(doc)).terrain;
    // Hand-made props on the ground (the island-systems branch places them for real).
    const Layer& h = terrain.get("height");
    int k = 0;
    for (const std::string& type : prop_types())
      for (int n = 0; n < 2; ++n, ++k) {
        const int i = 20 + 3 * k, j = 24 + 2 * k;
        Point p;
        p.kind = "prop";
        p.type = type;
        p.x_m = terrain.frame.x_m(i);
        p.z_m = terrain.frame.z_m(j);
        p.y_m = terrain.frame.y_m(h.data[std::size_t(j) * kSize + i]);
        p.rotation_deg = 30.0 * k;
        p.scale = 1.0 + 0.05 * k;
        terrain.points.push_back(p);
      }
    for (const std::string& type : prop_types()) {
      const MeshData m = prop_mesh(type);
      prop_vertices += m.vertex_count();
      prop_triangles += m.triangle_count();
    }
    Layer& off = terrain.layer("offset", 2);
    off.data.resize(terrain.frame.count() * 2);
    for (std::size_t q = 0; q < off.data.size(); ++q)
      off.data[q] = float(0.2 * terrain.frame.cell_m() * (2 * unit_double(hash64(17, q)) - 1));

    FileOutput out(dir.string());
    WriteContext ctx;
    ctx.options.chunk_quads = kChunk;
    for (const char* w : {"albedo", "obj", "glb", "fbx", "stl", "normalmap", "splat", "hillshade"}) find_writer(w)->write(terrain, ctx, out);
    auto glb = [&](const std::string& name, ExportOptions o) {
      GlbFiles g = encode_glb(terrain, o);
      out.put(name + ".glb", g.base);
      for (std::size_t q = 0; q < g.lods.size(); ++q) out.put(name + "_lod" + std::to_string(q + 1) + ".glb", g.lods[q]);
    };
    ExportOptions o;
    o.chunk_quads = kChunk;
    o.instancing = Instancing::Gpu;
    glb("gpu", o);
    o.instancing = Instancing::Nodes;
    o.style = MeshStyle::Lowpoly;
    o.simplify_error_m = 2.0;
    glb("lowpoly", o);
    o.style = MeshStyle::Smooth;
    o.simplify_error_m = 0;
    o.lod_levels = 2;
    o.lod_msft = true;
    glb("msft", o);
    o = ExportOptions{};
    o.chunk_quads = 64;
    o.triangle_budget = 3000;
    glb("budget", o);
    // uint32 indices: one chunk of 257² vertices.
    json big = load_preset("island");
    big["world"]["size"] = 257;
    big["seed"] = 5;
    Terrain t257 = run(parse_recipe(big)).terrain;
    o = ExportOptions{};
    o.chunk_quads = 256;
    out.put("u32.glb", encode_glb(t257, o).base);
    // Engine files and a 16-bit normal map.
    json unreal = load_preset("island");
    unreal["world"]["size"] = 127;
    unreal["seed"] = 5;
    Terrain t127 = run(parse_recipe(unreal)).terrain;
    o = ExportOptions{};
    o.engine = Engine::Unreal;
    write_engine_files(t127, o, out);
    out.put("normal16.png", encode_normal_map(terrain, 16, false));
  }
  static void TearDownTestSuite() {
    if (std::getenv("RELIEF_KEEP_TEST_FILES")) return;  // for debugging: keep the files
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};

// ---- Khronos glTF validator ------------------------------------------------------------------

TEST_F(Clients, GltfValidatorReportsNoErrorsOnEveryGlb) {
  const fs::path tools = fs::path(RELIEF_SOURCE_DIR) / "tools";
  ASSERT_TRUE(fs::exists(tools / "node_modules" / "gltf-validator")) << "run scripts/setup.sh (npm ci in tools/)";
  std::string files;
  int count = 0;
  for (auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".glb") files += " '" + e.path().string() + "'", ++count;
  EXPECT_EQ(count, 8);  // terrain, gpu, lowpoly, msft (+2 lods), budget, u32
  const Shell r = sh("node '" + (tools / "validate_gltf.mjs").string() + "'" + files);
  EXPECT_EQ(r.code, 0) << r.out;
  std::istringstream s(r.out);
  std::string line;
  int reports = 0;
  while (std::getline(s, line)) {
    const json j = json::parse(line);
    ++reports;
    EXPECT_EQ(j["errors"], 0) << line;
    EXPECT_EQ(j["warnings"], 0) << line;
  }
  EXPECT_EQ(reports, count);
}

// ---- assimp ---------------------------------------------------------------------------------

struct AssimpInfo {
  int code = -1;
  long meshes = -1, vertices = -1, faces = -1, embedded = -1;
  std::string out;
};
AssimpInfo assimp_info(const fs::path& p) {
  AssimpInfo a;
  // -r: raw import, no post-processing (vertex joining would make the counts approximate).
  const Shell r = sh("assimp info '" + p.string() + "' -r");
  a.code = r.code;
  a.out = r.out;
  auto num = [&](const char* label) {
    std::smatch m;
    if (std::regex_search(r.out, m, std::regex(std::string(label) + R"(\s+(\d+))"))) return std::stol(m[1]);
    return -1L;
  };
  a.meshes = num("Meshes:");
  a.vertices = num("Vertices:");
  a.faces = num("Faces:");
  a.embedded = num(R"(Textures \(embed\.\):)");
  return a;
}

TEST_F(Clients, AssimpLoadsEveryMeshFormat) {
  const long grid_tris = 2L * (kSize - 1) * (kSize - 1);
  const long chunk_verts = 4L * (kChunk + 1) * (kChunk + 1);

  const AssimpInfo glb = assimp_info(dir / "terrain.glb");
  EXPECT_EQ(glb.code, 0) << glb.out;
  EXPECT_EQ(glb.meshes, 4 + int(prop_types().size()));
  EXPECT_EQ(glb.vertices, chunk_verts + long(prop_vertices));
  EXPECT_EQ(glb.faces, grid_tris + long(prop_triangles));
  EXPECT_EQ(glb.embedded, 1);

  const AssimpInfo fbx = assimp_info(dir / "terrain.fbx");
  EXPECT_EQ(fbx.code, 0) << fbx.out;
  EXPECT_EQ(fbx.meshes, 4 + int(prop_types().size()));  // shared prop geometry converted once per type
  EXPECT_EQ(fbx.faces, grid_tris + long(prop_triangles));
  EXPECT_EQ(fbx.vertices, 3 * fbx.faces);  // assimp's FBX importer keeps one vertex per polygon corner
  EXPECT_EQ(fbx.embedded, 1);
  // The FBX also names the texture beside it.
  EXPECT_NE(slurp(dir / "terrain.fbx").find("albedo.png"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "albedo.png"));

  const AssimpInfo obj = assimp_info(dir / "terrain.obj");
  EXPECT_EQ(obj.code, 0) << obj.out;
  EXPECT_EQ(obj.faces, grid_tris);
  EXPECT_EQ(obj.vertices, 3 * obj.faces);  // one vertex per corner (v/vt/vn triplets)
  // assimp does not check that the MTL's texture exists: we do.
  const std::string mtl = slurp(dir / "terrain.mtl");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(mtl, m, std::regex(R"(map_Kd\s+(\S+))")));
  EXPECT_TRUE(fs::exists(dir / m[1].str())) << m[1];

  const AssimpInfo stl = assimp_info(dir / "terrain.stl");
  EXPECT_EQ(stl.code, 0) << stl.out;
  EXPECT_EQ(stl.faces, grid_tris + 3L * 4 * (kSize - 1));
  EXPECT_EQ(stl.vertices, 3 * stl.faces);

  // A broken file is refused (the tool really checks).
  std::string broken = slurp(dir / "terrain.fbx").substr(0, 2000);
  { std::ofstream(dir / "broken.fbx", std::ios::binary) << broken; }
  EXPECT_NE(assimp_info(dir / "broken.fbx").code, 0);
  fs::remove(dir / "broken.fbx");
}

// ---- Blender ----------------------------------------------------------------------------------

TEST_F(Clients, BlenderImportsGlbObjAndFbx) {
  const fs::path script = fs::path(RELIEF_SOURCE_DIR) / "tests" / "clients" / "blender_check.py";
  const fs::path report = dir / "blender.json";
  const std::vector<std::string> files = {"terrain.glb", "terrain.obj", "terrain.fbx", "lowpoly.glb", "gpu.glb"};
  std::string args;
  for (auto& f : files) args += " '" + (dir / f).string() + "'";
  const Shell r = sh("blender -b --factory-startup --python-exit-code 1 --python '" + script.string() + "' -- '" + report.string() + "'" + args);
  ASSERT_EQ(r.code, 0) << r.out;
  const json rep = json::parse(slurp(report));
  const Layer& albedo = terrain.get("albedo");
  auto top_left = [&](int c) { return long(std::lround(std::clamp(double(albedo.data[std::size_t(c)]), 0.0, 1.0) * 255)); };

  struct Totals {
    long terrain_objects = 0, terrain_vertices = 0, terrain_faces = 0, prop_objects = 0, uv_objects = 0;
    std::set<std::string> prop_meshes;
  };
  auto totals = [&](const json& file) {
    Totals t;
    for (auto& o : file["objects"]) {
      const std::string name = o["name"];
      if (name.rfind("terrain", 0) == 0) {
        ++t.terrain_objects;
        t.terrain_vertices += o["vertices"].get<long>();
        t.terrain_faces += o["faces"].get<long>();
        t.uv_objects += o["uv_layers"].get<long>() > 0;
      } else {
        ++t.prop_objects;
        t.prop_meshes.insert(o["mesh"].get<std::string>());
        EXPECT_GE(o["color_attributes"].get<int>(), 1) << name;  // props are vertex-coloured
      }
    }
    return t;
  };
  auto check_texture = [&](const json& file, const char* what) {
    bool found = false;
    for (auto& im : file["images"]) {
      if (im["size"] != json::array({kSize, kSize})) continue;
      found = true;
      EXPECT_TRUE(im["has_pixels"].get<bool>()) << what;
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(im["top_left"][c].get<long>(), top_left(c), 1) << what << " channel " << c;
    }
    EXPECT_TRUE(found) << what << ": no 65x65 texture";
    EXPECT_FALSE(file["textured_materials"].empty()) << what;
    // The terrain corner at min x on the z-min edge maps to the image's top-left: uv (0, 1) in Blender.
    ASSERT_TRUE(file["corner_uv"].is_array()) << what;
    EXPECT_NEAR(file["corner_uv"][0].get<double>(), 0.0, 1e-4) << what;
    EXPECT_NEAR(file["corner_uv"][1].get<double>(), 1.0, 1e-4) << what;
  };

  const long chunk_verts = 4L * (kChunk + 1) * (kChunk + 1), grid_faces = 2L * (kSize - 1) * (kSize - 1);
  // GLB and FBX: four textured chunks covering the grid, two props of each type sharing one mesh per type.
  auto check_chunked = [&](const json& f, const char* what) {
    const Totals t = totals(f);
    EXPECT_EQ(t.terrain_objects, 4) << what;
    EXPECT_EQ(t.terrain_vertices, chunk_verts) << what;
    EXPECT_EQ(t.terrain_faces, grid_faces) << what;
    EXPECT_EQ(t.uv_objects, 4) << what;
    EXPECT_EQ(t.prop_objects, int(2 * prop_types().size())) << what;
    EXPECT_EQ(t.prop_meshes.size(), prop_types().size()) << what;  // instances share their type's mesh
    check_texture(f, what);
  };
  {
    check_chunked(rep[(dir / "terrain.glb").string()], "glb");
  }
  {
    const json& f = rep[(dir / "terrain.obj").string()];
    ASSERT_EQ(f["objects"].size(), 1u);
    EXPECT_EQ(f["objects"][0]["vertices"], kSize * kSize);
    EXPECT_EQ(f["objects"][0]["faces"], grid_faces);
    EXPECT_EQ(f["objects"][0]["uv_layers"], 1);
    check_texture(f, "obj");
  }
  {
    const json& f = rep[(dir / "terrain.fbx").string()];
    check_chunked(f, "fbx");
    // Metres and axes: the FBX terrain has the GLB terrain's bounds in Blender, and spans the
    // world's width (give or take the jiggle of the border vertices).
    auto bounds = [](const json& file) {
      std::array<double, 6> b = {1e9, 1e9, 1e9, -1e9, -1e9, -1e9};
      for (auto& o : file["objects"])
        if (o["name"].get<std::string>().rfind("terrain", 0) == 0)
          for (int k = 0; k < 3; ++k) b[k] = std::min(b[k], o["min"][k].get<double>()), b[3 + k] = std::max(b[3 + k], o["max"][k].get<double>());
      return b;
    };
    const auto bf = bounds(f), bg = bounds(rep[(dir / "terrain.glb").string()]);
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(bf[std::size_t(k)], bg[std::size_t(k)], 1e-2) << k;
    EXPECT_NEAR(bf[3] - bf[0], terrain.frame.width_m(), 0.4 * terrain.frame.cell_m());
    // Prop colours: glTF stores linear COLOR_0, FBX sRGB; Blender shows both the same (its FBX
    // importer keeps 8-bit sRGB colours, hence the tolerance).
    for (auto& o : f["objects"])
      for (auto& g : rep[(dir / "terrain.glb").string()]["objects"])
        if (o["name"] == g["name"] && o.contains("color_min")) {
          for (int c = 0; c < 3; ++c) EXPECT_NEAR(o["color_min"][c].get<double>(), g["color_min"][c].get<double>(), 6e-3) << o["name"];
        }
  }
  {
    const json& f = rep[(dir / "lowpoly.glb").string()];
    long colour_objects = 0, terrain_faces = 0;
    for (auto& o : f["objects"])
      if (o["name"].get<std::string>().rfind("terrain", 0) == 0) {
        colour_objects += o["color_attributes"].get<int>() > 0;
        terrain_faces += o["faces"].get<long>();
        // Colours come from the albedo: a sandy/green island, never black or white.
        EXPECT_GT(o["color_max"][1].get<double>(), 0.05);
      }
    EXPECT_EQ(colour_objects, 4);
    EXPECT_LT(terrain_faces, grid_faces);  // simplified
  }
  {
    // Blender 3.4 ignores EXT_mesh_gpu_instancing (used, not required): it still loads the terrain.
    const Totals t = totals(rep[(dir / "gpu.glb").string()]);
    EXPECT_EQ(t.terrain_vertices, chunk_verts);
  }
}

// ---- Pillow / Python ------------------------------------------------------------------------

TEST_F(Clients, PythonReadsSixteenBitPngsWithTheRightSizesAndRanges) {
  const std::string script = R"PY(
import json, struct, sys, zlib
from PIL import Image

def png16(path):
    # Minimal PNG decoder (filters 0-4, 16-bit RGB) — Pillow reduces 16-bit RGB to 8 bits.
    data = open(path, 'rb').read()
    assert data[:8] == b'\x89PNG\r\n\x1a\n'
    pos, idat, ihdr = 8, b'', None
    while pos < len(data):
        n, kind = struct.unpack('>I4s', data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b'IHDR': ihdr = struct.unpack('>IIBBBBB', body)
        if kind == b'IDAT': idat += body
        pos += 12 + n
    w, h, depth, ctype = ihdr[:4]
    ch = {0: 1, 2: 3, 4: 2, 6: 4}[ctype]
    bpp = ch * depth // 8
    raw = zlib.decompress(idat)
    stride = w * bpp
    prev = bytearray(stride)
    rows = []
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if f == 1: line[i] = (line[i] + a) & 255
            elif f == 2: line[i] = (line[i] + b) & 255
            elif f == 3: line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    vals = [struct.unpack('>%dH' % (stride // 2), r) for r in rows]
    return w, h, depth, ch, vals

out = {}
im = Image.open(sys.argv[1])
out['unreal'] = {'mode': im.mode, 'size': im.size, 'min': im.getextrema()[0], 'max': im.getextrema()[1]}
w, h, depth, ch, vals = png16(sys.argv[2])
flat = [v for r in vals for v in r]
out['normal16'] = {'size': [w, h], 'depth': depth, 'channels': ch,
                   'min': [min(flat[k::3]) for k in range(3)], 'max': [max(flat[k::3]) for k in range(3)],
                   'first': list(vals[0][:3])}
print(json.dumps(out))
)PY";
  { std::ofstream(dir / "png16.py") << script; }
  const Shell r = sh(std::string(RELIEF_SYSTEM_PYTHON) + " '" + (dir / "png16.py").string() + "' '" + (dir / "unreal_height.png").string() +
                   "' '" + (dir / "normal16.png").string() + "'");
  ASSERT_EQ(r.code, 0) << r.out;
  const json j = json::parse(r.out);
  // Pillow 9 opens 16-bit greyscale as mode "I" (newer versions: "I;16"); values above 255 prove the depth.
  EXPECT_TRUE(j["unreal"]["mode"] == "I;16" || j["unreal"]["mode"] == "I") << j["unreal"]["mode"];
  EXPECT_EQ(j["unreal"]["size"], json::array({127, 127}));
  EXPECT_GT(j["unreal"]["max"].get<int>(), 30000);  // island peaks well above the middle
  EXPECT_LT(j["unreal"]["min"].get<int>(), 20000);  // and a sea floor below it
  EXPECT_EQ(j["normal16"]["size"], json::array({kSize, kSize}));
  EXPECT_EQ(j["normal16"]["depth"], 16);
  EXPECT_EQ(j["normal16"]["channels"], 3);
  EXPECT_GT(j["normal16"]["min"][2].get<int>(), 32768);  // normals point up: blue above the middle
  EXPECT_GT(j["normal16"]["max"][0].get<int>() - j["normal16"]["min"][0].get<int>(), 2000);  // real relief
  // The first pixel is the normal of sample (0, 0) (the mesh's normal there), OpenGL convention.
  ExportOptions o;
  o.chunk_quads = kChunk;
  const MeshData m = build_terrain_chunks(terrain, o)[0].mesh;
  const double n[3] = {m.normals[0], -m.normals[2], m.normals[1]};
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(j["normal16"]["first"][c].get<double>(), (n[c] + 1) / 2 * 65535, 2.0) << c;
}

}  // namespace
