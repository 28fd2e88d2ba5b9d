// Binary FBX 7.4 writer of our own: the terrain (chunks as meshes with normals, UVs and the
// embedded albedo texture), props as models sharing one geometry per type, metres through
// UnitScaleFactor = 100 (FBX counts centimetres), Y up.
//
// No Debian package writes an FBX that Blender accepts, hence this writer. The binary layout
// follows Blender's reverse-engineered encoder (io_scene_fbx/encode_bin.py, Campbell Barton,
// 2013) and the "FBX binary file format specification" notes of the Blender developer wiki:
//   header "Kaydara FBX Binary  \0\x1a\0" + uint32 version; node records (uint32 end offset,
//   uint32 property count, uint32 property bytes, uint8 name length, name, properties, nested
//   records, then a 13-byte null record when there are nested records — or, for a node without
//   properties and children, unless it is the last in its list); a null record after the top
//   level; the footer (16-byte id, 4 zero bytes, padding to 16, version, 120 zeros, 16-byte magic).
// Files are deterministic: the creation time is fixed at 1970-01-01 10:00:00:000 with the matching
// FileId and footer id, which is what FBX readers that check them expect for that time.
#include <zlib.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "relief/error.hpp"
#include "relief/export.hpp"
#include "relief/output.hpp"

#ifndef RELIEF_VERSION
#define RELIEF_VERSION "0.1.0"
#endif

namespace relief {
namespace {

constexpr std::uint32_t kVersion = 7400;
const char kFileId[] = "\x28\xb3\x2a\xeb\xb6\x24\xcc\xc2\xbf\xc8\xb0\x2a\xa9\x2b\xfc\xf1";
const char kFootId[] = "\xfa\xbc\xab\x09\xd0\xc8\xd4\x66\xb1\x76\xfb\x83\x1c\xf7\x26\x7e";
const char kFootMagic[] = "\xf8\x5a\x8c\x6a\xde\xf5\xd9\x7e\xec\xe9\x0c\xe3\x75\x8f\x29\x0b";
const char kTime[] = "1970-01-01 10:00:00:000";

void put_u32(std::string& s, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) s.push_back(char((v >> (8 * k)) & 0xFF));
}
template <class T>
void put_le(std::string& s, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));  // x86-64 and every target we build for are little-endian
  s.append(b, sizeof(T));
}

// One FBX node with its encoded properties.
struct Node {
  std::string name;
  std::string props;
  std::uint32_t nprops = 0;
  std::vector<Node> children;

  explicit Node(std::string n) : name(std::move(n)) {}
  Node& add(std::string n) {
    children.emplace_back(std::move(n));
    return children.back();
  }
  Node& i32(std::int32_t v) { return prop('I', [&] { put_le(props, v); }); }
  Node& i64(std::int64_t v) { return prop('L', [&] { put_le(props, v); }); }
  Node& f64(double v) { return prop('D', [&] { put_le(props, v); }); }
  Node& boolean(bool v) { return prop('C', [&] { props.push_back(v ? 1 : 0); }); }
  Node& str(const std::string& s) {
    return prop('S', [&] {
      put_u32(props, std::uint32_t(s.size()));
      props += s;
    });
  }
  Node& raw(const std::string& s) {
    return prop('R', [&] {
      put_u32(props, std::uint32_t(s.size()));
      props += s;
    });
  }
  template <class T>
  Node& array(char type, const std::vector<T>& v) {
    return prop(type, [&] {
      const std::size_t bytes = v.size() * sizeof(T);
      put_u32(props, std::uint32_t(v.size()));
      if (bytes <= 128) {  // small arrays raw, larger ones deflated (as FBX SDK files do)
        put_u32(props, 0);
        put_u32(props, std::uint32_t(bytes));
        props.append(reinterpret_cast<const char*>(v.data()), bytes);
        return;
      }
      uLongf len = compressBound(uLong(bytes));
      std::string z(len, '\0');
      if (compress2(reinterpret_cast<Bytef*>(z.data()), &len, reinterpret_cast<const Bytef*>(v.data()), uLong(bytes), 1) != Z_OK)
        throw Error("output", "fbx: zlib compression failed");
      put_u32(props, 1);
      put_u32(props, std::uint32_t(len));
      props.append(z.data(), len);
    });
  }
  Node& f64s(const std::vector<double>& v) { return array('d', v); }
  Node& i32s(const std::vector<std::int32_t>& v) { return array('i', v); }

  template <class F>
  Node& prop(char type, F&& body) {
    props.push_back(type);
    body();
    ++nprops;
    return *this;
  }
};

void write_node(std::string& out, const Node& n, bool is_last) {
  const std::size_t start = out.size();
  put_u32(out, 0);  // end offset, patched below
  put_u32(out, n.nprops);
  put_u32(out, std::uint32_t(n.props.size()));
  out.push_back(char(n.name.size()));
  out += n.name;
  out += n.props;
  if (!n.children.empty()) {
    for (std::size_t k = 0; k < n.children.size(); ++k) write_node(out, n.children[k], k + 1 == n.children.size());
    out.append(13, '\0');
  } else if (n.nprops == 0 && !is_last) {
    out.append(13, '\0');
  }
  if (out.size() > 0xFFFFFFFFu) throw Error("output", "fbx: file exceeds 4 GiB, the limit of FBX 7.4 (use a smaller --size)");
  const std::uint32_t end = std::uint32_t(out.size());
  std::memcpy(&out[start], &end, 4);
}

std::string name_class(const std::string& name, const std::string& cls) { return name + std::string("\0\x01", 2) + cls; }

// Properties70 entry helpers.
Node& P(Node& p70, const std::string& name, const std::string& type, const std::string& label, const std::string& flags) {
  return p70.add("P").str(name).str(type).str(label).str(flags);
}

// A geometry layer element (version 101): its name and how its values map onto the mesh.
Node& layer_element(Node& geometry, const std::string& type, const std::string& name, const std::string& mapping,
                    const std::string& reference) {
  Node& e = geometry.add(type).i32(0);
  e.add("Version").i32(101);
  e.add("Name").str(name);
  e.add("MappingInformationType").str(mapping);
  e.add("ReferenceInformationType").str(reference);
  return e;
}

struct Builder {
  std::int64_t next_id = 1000000;
  Node objects{"Objects"};
  Node connections{"Connections"};
  int geometries = 0, models = 0, materials = 0, textures = 0, videos = 0;

  std::int64_t id() { return next_id++; }
  void connect(std::int64_t child, std::int64_t parent) { connections.add("C").str("OO").i64(child).i64(parent); }
  void connect_prop(std::int64_t child, std::int64_t parent, const std::string& prop) {
    connections.add("C").str("OP").i64(child).i64(parent).str(prop);
  }

  std::int64_t geometry(const std::string& name, const MeshData& m) {
    const std::int64_t gid = id();
    ++geometries;
    Node& g = objects.add("Geometry").i64(gid).str(name_class(name, "Geometry")).str("Mesh");
    g.add("Properties70");
    g.add("GeometryVersion").i32(124);
    g.add("Vertices").f64s(std::vector<double>(m.positions.begin(), m.positions.end()));
    std::vector<std::int32_t> pvi(m.indices.size());
    for (std::size_t k = 0; k < m.indices.size(); ++k)
      pvi[k] = k % 3 == 2 ? -std::int32_t(m.indices[k]) - 1 : std::int32_t(m.indices[k]);  // last corner: ~index
    g.add("PolygonVertexIndex").i32s(pvi);
    layer_element(g, "LayerElementNormal", "", "ByVertice", "Direct")
        .add("Normals").f64s(std::vector<double>(m.normals.begin(), m.normals.end()));
    if (!m.uvs.empty()) {
      std::vector<double> uv(m.uvs.size());
      for (std::size_t k = 0; k < uv.size(); ++k) uv[k] = k % 2 ? 1.0 - double(m.uvs[k]) : double(m.uvs[k]);  // FBX v = 0 at the image bottom
      layer_element(g, "LayerElementUV", "UVMap", "ByVertice", "Direct").add("UV").f64s(uv);
    }
    if (!m.colors.empty()) {
      std::vector<double> rgba;
      rgba.reserve(m.colors.size() / 3 * 4);
      for (std::size_t k = 0; k < m.colors.size(); k += 3)
        rgba.insert(rgba.end(), {double(m.colors[k]), double(m.colors[k + 1]), double(m.colors[k + 2]), 1.0});
      layer_element(g, "LayerElementColor", "Col", "ByVertice", "Direct").add("Colors").f64s(rgba);
    }
    layer_element(g, "LayerElementMaterial", "", "AllSame", "IndexToDirect").add("Materials").i32s({0});
    Node& layer = g.add("Layer").i32(0);
    layer.add("Version").i32(100);
    auto element = [&](const char* type) {
      Node& e = layer.add("LayerElement");
      e.add("Type").str(type);
      e.add("TypedIndex").i32(0);
    };
    element("LayerElementNormal");
    if (!m.uvs.empty()) element("LayerElementUV");
    if (!m.colors.empty()) element("LayerElementColor");
    element("LayerElementMaterial");
    return gid;
  }

  std::int64_t model(const std::string& name, const std::string& type, const double t[3], double rot_y_deg, double scale) {
    const std::int64_t mid = id();
    ++models;
    Node& m = objects.add("Model").i64(mid).str(name_class(name, "Model")).str(type);
    m.add("Version").i32(232);
    Node& p = m.add("Properties70");
    P(p, "Lcl Translation", "Lcl Translation", "", "A").f64(t[0]).f64(t[1]).f64(t[2]);
    P(p, "Lcl Rotation", "Lcl Rotation", "", "A").f64(0).f64(rot_y_deg).f64(0);
    P(p, "Lcl Scaling", "Lcl Scaling", "", "A").f64(scale).f64(scale).f64(scale);
    P(p, "DefaultAttributeIndex", "int", "Integer", "").i32(0);
    P(p, "InheritType", "enum", "", "").i32(1);
    m.add("MultiLayer").i32(0);
    m.add("MultiTake").i32(0);
    m.add("Shading").boolean(true);
    m.add("Culling").str("CullingOff");
    return mid;
  }

  std::int64_t material(const std::string& name) {
    const std::int64_t id_ = id();
    ++materials;
    Node& m = objects.add("Material").i64(id_).str(name_class(name, "Material")).str("");
    m.add("Version").i32(102);
    m.add("ShadingModel").str("Phong");
    m.add("MultiLayer").i32(0);
    Node& p = m.add("Properties70");
    P(p, "DiffuseColor", "Color", "", "A").f64(1).f64(1).f64(1);
    P(p, "DiffuseFactor", "Number", "", "A").f64(1);
    P(p, "SpecularFactor", "Number", "", "A").f64(0);
    P(p, "ShininessExponent", "Number", "", "A").f64(2);
    return id_;
  }

  // A texture with its image embedded (Video.Content), also named as the file beside the FBX.
  std::int64_t texture(const std::string& file, const std::string& png) {
    const std::int64_t tid = id(), vid = id();
    ++textures, ++videos;
    Node& t = objects.add("Texture").i64(tid).str(name_class("albedo", "Texture")).str("");
    t.add("Type").str("TextureVideoClip");
    t.add("Version").i32(202);
    t.add("TextureName").str(name_class("albedo", "Texture"));
    Node& tp = t.add("Properties70");
    P(tp, "UseMaterial", "bool", "", "").i32(1);
    t.add("Media").str(name_class("albedo", "Video"));
    t.add("FileName").str(file);
    t.add("RelativeFilename").str(file);
    t.add("ModelUVTranslation").f64(0).f64(0);
    t.add("ModelUVScaling").f64(1).f64(1);
    t.add("Texture_Alpha_Source").str("None");
    t.add("Cropping").i32(0).i32(0).i32(0).i32(0);
    Node& v = objects.add("Video").i64(vid).str(name_class("albedo", "Video")).str("Clip");
    v.add("Type").str("Clip");
    Node& vp = v.add("Properties70");
    P(vp, "Path", "KString", "XRefUrl", "").str(file);
    v.add("UseMipMap").i32(0);
    v.add("Filename").str(file);
    v.add("RelativeFilename").str(file);
    v.add("Content").raw(png);
    connect(vid, tid);
    return tid;
  }
};

const Layer* albedo_of(const Terrain& t) {
  for (const char* n : {"albedo", "color"}) {
    auto it = t.layers.find(n);
    if (it != t.layers.end() && it->second.channels == 3 && it->second.data.size() == t.frame.count() * 3) return &it->second;
  }
  return nullptr;
}

}  // namespace

std::string encode_fbx(const Terrain& t, const ExportOptions& o) {
  Builder b;
  const double origin[3] = {0, 0, 0};
  const auto chunks = build_terrain_chunks(t, o, 0);
  const Layer* albedo = albedo_of(t);

  const std::int64_t terrain = b.model("terrain", "Null", origin, 0, 1);
  b.connect(terrain, 0);
  const std::int64_t tmat = b.material("terrain");
  if (albedo && o.style != MeshStyle::Lowpoly)
    b.connect_prop(b.texture("albedo.png", encode_png_rgb8(*albedo, t.frame.nx, t.frame.nz)), tmat, "DiffuseColor");
  for (const TerrainChunk& c : chunks) {
    const std::string name = "terrain_x" + std::to_string(c.cx) + "_z" + std::to_string(c.cz);
    MeshData m = c.mesh;
    if (!albedo || o.style == MeshStyle::Lowpoly) m.uvs.clear();
    const std::int64_t g = b.geometry(name, m);
    const std::int64_t mdl = b.model(name, "Mesh", origin, 0, 1);
    b.connect(mdl, terrain);
    b.connect(g, mdl);
    b.connect(tmat, mdl);
  }

  const auto props = terrain_props(t);
  if (!props.empty()) {
    const std::int64_t group = b.model("props", "Null", origin, 0, 1);
    b.connect(group, 0);
    const std::int64_t pmat = b.material("props");
    for (const std::string& type : prop_types()) {
      std::int64_t geom = -1;
      int k = 0;
      for (const Point* p : props) {
        if (p->type != type) continue;
        if (geom < 0) geom = b.geometry(type, prop_mesh(type));
        const double at[3] = {p->x_m, p->y_m, p->z_m};
        const std::int64_t mdl = b.model(type + "_" + std::to_string(k++), "Mesh", at, p->rotation_deg, p->scale);
        b.connect(mdl, group);
        b.connect(geom, mdl);  // every instance shares its type's geometry
        b.connect(pmat, mdl);
      }
    }
  }

  std::vector<Node> top;
  {
    Node h("FBXHeaderExtension");
    h.add("FBXHeaderVersion").i32(1003);
    h.add("FBXVersion").i32(std::int32_t(kVersion));
    h.add("EncryptionType").i32(0);
    Node& ts = h.add("CreationTimeStamp");
    for (auto [k, v] : std::initializer_list<std::pair<const char*, int>>{
             {"Version", 1000}, {"Year", 1970}, {"Month", 1}, {"Day", 1}, {"Hour", 10}, {"Minute", 0}, {"Second", 0}, {"Millisecond", 0}})
      ts.add(k).i32(v);
    h.add("Creator").str(std::string("Relief ") + RELIEF_VERSION);
    top.push_back(std::move(h));
  }
  top.emplace_back("FileId");
  top.back().raw(std::string(kFileId, 16));
  top.emplace_back("CreationTime");
  top.back().str(kTime);
  top.emplace_back("Creator");
  top.back().str(std::string("Relief ") + RELIEF_VERSION);
  {
    Node g("GlobalSettings");
    g.add("Version").i32(1000);
    Node& p = g.add("Properties70");
    // Right-handed, Y up, Z front, X right: the same axes as our meshes, so no conversion.
    P(p, "UpAxis", "int", "Integer", "").i32(1);
    P(p, "UpAxisSign", "int", "Integer", "").i32(1);
    P(p, "FrontAxis", "int", "Integer", "").i32(2);
    P(p, "FrontAxisSign", "int", "Integer", "").i32(1);
    P(p, "CoordAxis", "int", "Integer", "").i32(0);
    P(p, "CoordAxisSign", "int", "Integer", "").i32(1);
    P(p, "OriginalUpAxis", "int", "Integer", "").i32(1);
    P(p, "OriginalUpAxisSign", "int", "Integer", "").i32(1);
    P(p, "UnitScaleFactor", "double", "Number", "").f64(100.0);  // centimetres per unit: metres
    P(p, "OriginalUnitScaleFactor", "double", "Number", "").f64(100.0);
    P(p, "AmbientColor", "ColorRGB", "Color", "").f64(0).f64(0).f64(0);
    P(p, "DefaultCamera", "KString", "", "").str("Producer Perspective");
    P(p, "TimeMode", "enum", "", "").i32(11);
    P(p, "TimeSpanStart", "KTime", "Time", "").i64(0);
    P(p, "TimeSpanStop", "KTime", "Time", "").i64(46186158000);
    P(p, "CustomFrameRate", "double", "Number", "").f64(24.0);
    top.push_back(std::move(g));
  }
  {
    Node d("Documents");
    d.add("Count").i32(1);
    Node& doc = d.add("Document").i64(b.id()).str("Scene").str("Scene");
    doc.add("Properties70");
    doc.add("RootNode").i64(0);
    top.push_back(std::move(d));
  }
  top.emplace_back("References");
  {
    Node d("Definitions");
    d.add("Version").i32(100);
    int count = 1;
    std::vector<std::pair<const char*, int>> types = {{"Geometry", b.geometries}, {"Model", b.models}, {"Material", b.materials},
                                                      {"Texture", b.textures},   {"Video", b.videos}};
    for (auto& [n, c] : types) count += c > 0;
    d.add("Count").i32(count);
    d.add("ObjectType").str("GlobalSettings").add("Count").i32(1);
    for (auto& [n, c] : types)
      if (c > 0) d.add("ObjectType").str(n).add("Count").i32(c);
    top.push_back(std::move(d));
  }
  top.push_back(std::move(b.objects));
  top.push_back(std::move(b.connections));
  {
    Node tk("Takes");
    tk.add("Current").str("");
    top.push_back(std::move(tk));
  }

  std::string out = "Kaydara FBX Binary  ";
  out.push_back('\0');
  out.push_back('\x1a');
  out.push_back('\0');
  put_u32(out, kVersion);
  for (std::size_t k = 0; k < top.size(); ++k) write_node(out, top[k], k + 1 == top.size());
  out.append(13, '\0');
  out.append(kFootId, 16);
  out.append(4, '\0');
  std::size_t pad = ((out.size() + 15) & ~std::size_t(15)) - out.size();
  if (pad == 0) pad = 16;
  out.append(pad, '\0');
  put_u32(out, kVersion);
  out.append(120, '\0');
  out.append(kFootMagic, 16);
  return out;
}

}  // namespace relief
