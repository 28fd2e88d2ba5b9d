#pragma once
// Internal: a glTF 2.0 model under construction (tinygltf), shared by the GLB writers (terrain
// chunks and props in writer_gltf.cpp, the volume's chunks in writer_volume.cpp).
//
// Specification: "glTF 2.0 Specification" (Khronos, 2021): §3.6 buffers (4-byte alignment),
// §3.7.2.1 POSITION needs min/max, indices must not use the component type's maximum value (so
// uint16 indices serve at most 65535 vertices). glTF vertex colours are linear (COLOR_0); ours are
// sRGB and converted here.
#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/mesh.hpp"

#ifndef RELIEF_VERSION
#define RELIEF_VERSION "0.1.0"
#endif

namespace relief::detail {

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

}  // namespace relief::detail
