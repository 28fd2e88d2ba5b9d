// glTF 2.0 binary (GLB) through tinygltf: Y up, metres, chunked terrain with normals, UVs and an
// embedded albedo texture, props as shared meshes or EXT_mesh_gpu_instancing, an optional
// MSFT_lod chain.
//
// Specifications: "glTF 2.0 Specification" (Khronos, 2021): §3.6 buffers (4-byte alignment),
// §3.7.2.1 POSITION needs min/max, §3.7.2.1 indices must not use the component type's maximum
// value (so uint16 indices serve at most 65535 vertices); EXT_mesh_gpu_instancing and MSFT_lod
// from the glTF extension registry. glTF multiplies COLOR_0 by the base colour texture, so vertex
// colours are written only for untextured meshes (low-poly style and props).
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "relief/error.hpp"
#include "relief/export.hpp"
#include "relief/output.hpp"
#include "gltf_builder.hpp"

namespace relief {
namespace {

using detail::GltfBuilder;

const Layer* albedo_layer(const Terrain& t) {
  for (const char* n : {"albedo", "color"}) {
    auto it = t.layers.find(n);
    if (it != t.layers.end() && it->second.channels == 3 && it->second.data.size() == t.frame.count() * 3) return &it->second;
  }
  return nullptr;
}

// Terrain chunks as meshes; returns the chunk node indices (not yet attached).
std::vector<int> add_terrain(GltfBuilder& g, const std::vector<TerrainChunk>& chunks, int material, bool with_uv,
                             const std::string& suffix) {
  std::vector<int> nodes;
  for (const TerrainChunk& c : chunks) {
    const std::string name = "terrain_x" + std::to_string(c.cx) + "_z" + std::to_string(c.cz) + suffix;
    tinygltf::Node n;
    n.name = name;
    n.mesh = g.mesh(name, c.mesh, material, with_uv);
    nodes.push_back(g.node(std::move(n)));
  }
  return nodes;
}

struct TerrainMaterial {
  int material = -1;
  bool with_uv = false;
};

TerrainMaterial terrain_material(GltfBuilder& g, const Terrain& t, const ExportOptions& o) {
  const Layer* albedo = albedo_layer(t);
  if (o.style == MeshStyle::Lowpoly || !albedo) return {g.material("terrain", -1), false};
  const int tex = g.png_texture("albedo", encode_png_rgb8(*albedo, t.frame.nx, t.frame.nz));
  return {g.material("terrain", tex), true};
}

std::vector<double> quat_y(double deg) {
  const double h = deg * M_PI / 360.0;
  return {0.0, std::sin(h), 0.0, std::cos(h)};
}

void add_props(GltfBuilder& g, const Terrain& t, const ExportOptions& o, std::vector<int>& scene) {
  const auto props = terrain_props(t);
  if (props.empty()) return;
  const int mat = g.material("props", -1);
  tinygltf::Node root;
  root.name = "props";
  for (const std::string& type : prop_types()) {
    std::vector<const Point*> mine;
    for (const Point* p : props)
      if (p->type == type) mine.push_back(p);
    if (mine.empty()) continue;
    const int mesh = g.mesh(type, prop_mesh(type), mat, false);
    if (o.instancing == Instancing::Gpu) {
      std::vector<float> tr, rot, sc;
      for (const Point* p : mine) {
        tr.insert(tr.end(), {float(p->x_m), float(p->y_m), float(p->z_m)});
        for (double q : quat_y(p->rotation_deg)) rot.push_back(float(q));
        sc.insert(sc.end(), 3, float(p->scale));
      }
      tinygltf::Node n;
      n.name = type + "_instances";
      n.mesh = mesh;
      tinygltf::Value::Object attrs;
      attrs["TRANSLATION"] = tinygltf::Value(g.floats(tr, 3, false, 0));
      attrs["ROTATION"] = tinygltf::Value(g.floats(rot, 4, false, 0));
      attrs["SCALE"] = tinygltf::Value(g.floats(sc, 3, false, 0));
      tinygltf::Value::Object ext;
      ext["attributes"] = tinygltf::Value(attrs);
      n.extensions["EXT_mesh_gpu_instancing"] = tinygltf::Value(ext);
      root.children.push_back(g.node(std::move(n)));
    } else {
      for (std::size_t k = 0; k < mine.size(); ++k) {
        const Point* p = mine[k];
        tinygltf::Node n;
        n.name = type + "_" + std::to_string(k);
        n.mesh = mesh;
        n.translation = {p->x_m, p->y_m, p->z_m};
        if (p->rotation_deg != 0) n.rotation = quat_y(p->rotation_deg);
        if (p->scale != 1) n.scale = {p->scale, p->scale, p->scale};
        root.children.push_back(g.node(std::move(n)));
      }
    }
  }
  if (o.instancing == Instancing::Gpu) g.model.extensionsUsed.push_back("EXT_mesh_gpu_instancing");
  scene.push_back(g.node(std::move(root)));
}

std::string finish(GltfBuilder& g, const std::vector<int>& scene_nodes) {
  tinygltf::Scene s;
  s.name = "relief";
  s.nodes = scene_nodes;
  g.model.scenes.push_back(s);
  g.model.defaultScene = 0;
  return g.glb();
}

}  // namespace

GlbFiles encode_glb(const Terrain& t, const ExportOptions& o) {
  GlbFiles out;
  const std::vector<std::vector<TerrainChunk>> lods = build_terrain_lod_chain(t, o, o.lod_levels);

  {
    GltfBuilder g;
    const TerrainMaterial tm = terrain_material(g, t, o);
    const auto base = build_terrain_chunks(t, o, 0);
    std::vector<int> chunk_nodes = add_terrain(g, base, tm.material, tm.with_uv, "");
    if (o.lod_msft) {
      // MSFT_lod: each chunk node lists its lower-detail nodes, highest detail first; the LOD
      // nodes are not part of the scene. MSFT_screencoverage gives the switch points.
      std::vector<std::vector<int>> lod_nodes;
      for (std::size_t k = 0; k < lods.size(); ++k)
        lod_nodes.push_back(add_terrain(g, lods[k], tm.material, tm.with_uv, "_lod" + std::to_string(k + 1)));
      for (std::size_t c = 0; c < chunk_nodes.size(); ++c) {
        tinygltf::Value::Array ids, coverage;
        for (std::size_t k = 0; k < lods.size(); ++k) ids.push_back(tinygltf::Value(lod_nodes[k][c]));
        for (std::size_t k = 0; k <= lods.size(); ++k) coverage.push_back(tinygltf::Value(std::ldexp(0.5, -int(k))));
        tinygltf::Value::Object ext;
        ext["ids"] = tinygltf::Value(ids);
        auto& n = g.model.nodes[std::size_t(chunk_nodes[c])];
        n.extensions["MSFT_lod"] = tinygltf::Value(ext);
        tinygltf::Value::Object extras;
        extras["MSFT_screencoverage"] = tinygltf::Value(coverage);
        n.extras = tinygltf::Value(extras);
      }
      g.model.extensionsUsed.push_back("MSFT_lod");
    }
    tinygltf::Node terrain;
    terrain.name = "terrain";
    terrain.children = chunk_nodes;
    std::vector<int> scene = {g.node(std::move(terrain))};
    add_props(g, t, o, scene);
    out.base = finish(g, scene);
  }
  for (std::size_t k = 0; k < lods.size(); ++k) {
    GltfBuilder g;
    const TerrainMaterial tm = terrain_material(g, t, o);
    tinygltf::Node terrain;
    terrain.name = "terrain_lod" + std::to_string(k + 1);
    terrain.children = add_terrain(g, lods[k], tm.material, tm.with_uv, "");
    out.lods.push_back(finish(g, {g.node(std::move(terrain))}));
  }
  return out;
}

}  // namespace relief
