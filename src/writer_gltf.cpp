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

#ifndef RELIEF_VERSION
#define RELIEF_VERSION "0.1.0"
#endif

namespace relief {
namespace {

constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;

class GltfBuilder {
 public:
  tinygltf::Model model;

  GltfBuilder() {
    model.asset.version = "2.0";
    model.asset.generator = std::string("Relief ") + RELIEF_VERSION;
    model.buffers.emplace_back();
  }

  int view(const void* data, std::size_t bytes, int target) {
    auto& b = model.buffers[0].data;
    while (b.size() % 4) b.push_back(0);
    tinygltf::BufferView v;
    v.buffer = 0;
    v.byteOffset = b.size();
    v.byteLength = bytes;
    v.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    b.insert(b.end(), p, p + bytes);
    model.bufferViews.push_back(v);
    return int(model.bufferViews.size() - 1);
  }

  // Float attribute with `comps` components (VEC2/VEC3/VEC4); min/max when `bounds`.
  int floats(const std::vector<float>& v, int comps, bool bounds, int target = kArrayBuffer) {
    tinygltf::Accessor a;
    a.bufferView = view(v.data(), v.size() * sizeof(float), target);
    a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
    a.count = v.size() / comps;
    a.type = comps == 2 ? TINYGLTF_TYPE_VEC2 : comps == 3 ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC4;
    if (bounds) {
      a.minValues.assign(comps, std::numeric_limits<double>::max());
      a.maxValues.assign(comps, std::numeric_limits<double>::lowest());
      for (std::size_t k = 0; k < v.size(); ++k) {
        a.minValues[k % comps] = std::min(a.minValues[k % comps], double(v[k]));
        a.maxValues[k % comps] = std::max(a.maxValues[k % comps], double(v[k]));
      }
    }
    model.accessors.push_back(a);
    return int(model.accessors.size() - 1);
  }

  // uint16 when every index fits below 65535 (the reserved restart value), else uint32.
  int indices(const std::vector<std::uint32_t>& idx, std::size_t vertex_count) {
    tinygltf::Accessor a;
    if (vertex_count <= 65535) {
      std::vector<std::uint16_t> s(idx.begin(), idx.end());
      a.bufferView = view(s.data(), s.size() * 2, kElementArrayBuffer);
      a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    } else {
      a.bufferView = view(idx.data(), idx.size() * 4, kElementArrayBuffer);
      a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
    }
    a.count = idx.size();
    a.type = TINYGLTF_TYPE_SCALAR;
    model.accessors.push_back(a);
    return int(model.accessors.size() - 1);
  }

  int mesh(const std::string& name, const MeshData& m, int material, bool with_uv) {
    tinygltf::Primitive p;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    p.attributes["POSITION"] = floats(m.positions, 3, true);
    p.attributes["NORMAL"] = floats(m.normals, 3, false);
    if (with_uv && !m.uvs.empty()) p.attributes["TEXCOORD_0"] = floats(m.uvs, 2, false);
    if (!m.colors.empty()) {
      // glTF vertex colours are linear; ours are sRGB (IEC 61966-2-1 transfer function).
      std::vector<float> lin(m.colors.size());
      for (std::size_t k = 0; k < lin.size(); ++k) {
        const double c = std::clamp(double(m.colors[k]), 0.0, 1.0);
        lin[k] = float(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
      }
      p.attributes["COLOR_0"] = floats(lin, 3, false);
    }
    p.indices = indices(m.indices, m.vertex_count());
    p.material = material;
    tinygltf::Mesh me;
    me.name = name;
    me.primitives.push_back(p);
    model.meshes.push_back(me);
    return int(model.meshes.size() - 1);
  }

  int node(tinygltf::Node n) {
    model.nodes.push_back(std::move(n));
    return int(model.nodes.size() - 1);
  }

  int material(const std::string& name, int texture) {
    tinygltf::Material m;
    m.name = name;
    m.pbrMetallicRoughness.metallicFactor = 0.0;
    m.pbrMetallicRoughness.roughnessFactor = 1.0;
    if (texture >= 0) m.pbrMetallicRoughness.baseColorTexture.index = texture;
    model.materials.push_back(m);
    return int(model.materials.size() - 1);
  }

  int png_texture(const std::string& name, const std::string& png) {
    tinygltf::Image img;
    img.name = name;
    img.mimeType = "image/png";
    img.bufferView = view(png.data(), png.size(), 0);
    model.bufferViews.back().target = 0;  // images: no target
    model.images.push_back(img);
    tinygltf::Sampler s;
    s.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
    s.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR;
    s.wrapS = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    s.wrapT = TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
    model.samplers.push_back(s);
    tinygltf::Texture t;
    t.name = name;
    t.source = int(model.images.size() - 1);
    t.sampler = int(model.samplers.size() - 1);
    model.textures.push_back(t);
    return int(model.textures.size() - 1);
  }

  std::string glb() {
    model.buffers[0].name = "relief";
    while (model.buffers[0].data.size() % 4) model.buffers[0].data.push_back(0);
    std::ostringstream os;
    tinygltf::TinyGLTF g;
    if (!g.WriteGltfSceneToStream(&model, os, false, true)) throw Error("output", "glb: tinygltf could not serialise the model");
    return os.str();
  }
};

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
