// The volume writers: the density band of the "volume", "overhangs" and "caves" stages
// (relief/volume.hpp), meshed chunk by chunk by our marching cubes (relief/volume_mesh.hpp).
//   caves      caves.glb: one node per chunk (named caves_x<cx>_y<cy>_z<cz>), vertex colours
//   caves_obj  caves.obj: one object per chunk, vertex colours as the widely read "v x y z r g b"
//   vdb        caves.vdb: the surface as an OpenVDB level set (Museth, "VDB: High-resolution
//              sparse volumes with dynamic topology", ACM TOG 2013), grid "surface", metres,
//              voxel (i, j, k) at (i, j, k)·voxel_m, negative in rock (OpenVDB's convention, the
//              opposite of our density's sign), a narrow band of ±3 voxels, interior flood-filled.
// Chunks share their boundary samples, so the meshes' seam vertices coincide exactly; the files
// keep each chunk's own vertices (a chunk is a node/object of its own), so merging by position
// welds them.
#include <openvdb/io/Stream.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/SignedFloodFill.h>

#include <cctype>
#include <charconv>
#include <mutex>
#include <sstream>

#include "gltf_builder.hpp"
#include "relief/error.hpp"
#include "relief/generate.hpp"
#include "relief/output.hpp"
#include "relief/volume.hpp"
#include "writer_defs.hpp"

namespace relief {
namespace {

const VolumeSpec& need_volume(const Terrain& t, const char* writer) {
  if (!t.volume)
    throw Error(writer, "needs a volume: add a \"volume\", \"overhangs\" or \"caves\" stage to the recipe");
  return *t.volume;
}

void progress(const WriteContext& ctx, const char* what, double f) {
  if (ctx.progress) ctx.progress(what, f);
}

void write_glb(const Terrain& t, const WriteContext& ctx, Output& out) {
  const VolumeSpec& spec = need_volume(t, "caves");
  // The GLB is built whole in memory: refuse up front what would not fit (relief/generate.hpp's
  // memory policy), naming the parameter that sets the voxel count.
  const VolumeGrid vg = volume_grid(t, spec);
  const double need = vg.mesh_bytes_estimate(), budget = double(memory_budget_bytes());
  if (need > budget)
    throw Error((spec.path.empty() ? std::string("volume") : spec.path) + ".voxel_m", "caves.glb at " + std::to_string(vg.voxel_m) + " m voxels needs about " +
                                      std::to_string(std::int64_t(need / (1 << 20))) + " MiB (" + std::to_string(vg.surface_chunks) +
                                      " surface chunks), more than the memory budget of " +
                                      std::to_string(std::int64_t(budget / (1 << 20))) +
                                      " MiB: expected a larger voxel_m (or the caves_obj writer, which streams)");
  detail::GltfBuilder g;
  const int material = g.material("rock", -1);
  std::vector<int> nodes;
  mesh_volume(
      t, spec, ctx.seed,
      [&](VolumeChunkMesh&& c) {
        const std::string name = "caves_x" + std::to_string(c.cx) + "_y" + std::to_string(c.cy) + "_z" + std::to_string(c.cz);
        tinygltf::Node n;
        n.name = name;
        n.mesh = g.mesh(name, c.mesh, material, false);
        nodes.push_back(g.node(std::move(n)));
      },
      [&](double f) { progress(ctx, "caves", 0.95 * f); }, ctx.cancelled);
  tinygltf::Node root;
  root.name = "caves";
  root.children = nodes;
  const int r = g.node(std::move(root));
  tinygltf::Scene s;
  s.name = "caves";
  s.nodes = {r};
  g.model.scenes.push_back(s);
  g.model.defaultScene = 0;
  out.put("caves.glb", g.glb());
  progress(ctx, "caves", 1.0);
}

char* put(char* p, double v) {
  // Four decimals, "-0.0000" written as "0.0000" so that the text does not depend on the sign of zero.
  if (v == 0.0) v = 0.0;
  return std::to_chars(p, p + 40, v, std::chars_format::fixed, 4).ptr;
}

void write_obj(const Terrain& t, const WriteContext& ctx, Output& out) {
  const VolumeSpec& spec = need_volume(t, "caves_obj");
  auto stream = out.open("caves.obj");
  stream->write("# Relief volume: caves, overhangs and arches. Y up, metres, one object per chunk\n");
  std::uint64_t base = 1;  // OBJ indices are 1-based and global
  std::string buf;
  mesh_volume(
      t, spec, ctx.seed,
      [&](VolumeChunkMesh&& c) {
        const MeshData& m = c.mesh;
        const std::size_t nv = m.vertex_count();
        buf.clear();
        buf.reserve(nv * 110 + m.indices.size() * 24 + 64);
        buf += "o caves_x" + std::to_string(c.cx) + "_y" + std::to_string(c.cy) + "_z" + std::to_string(c.cz) + "\n";
        char line[256];
        for (std::size_t a = 0; a < nv; ++a) {
          char* p = line;
          *p++ = 'v';
          for (int k = 0; k < 3; ++k) {
            *p++ = ' ';
            p = put(p, m.positions[a * 3 + k]);
          }
          for (int k = 0; k < 3; ++k) {
            *p++ = ' ';
            p = put(p, m.colors[a * 3 + k]);
          }
          *p++ = '\n';
          buf.append(line, p);
        }
        for (std::size_t a = 0; a < nv; ++a) {
          char* p = line;
          *p++ = 'v';
          *p++ = 'n';
          for (int k = 0; k < 3; ++k) {
            *p++ = ' ';
            p = put(p, m.normals[a * 3 + k]);
          }
          *p++ = '\n';
          buf.append(line, p);
        }
        for (std::size_t q = 0; q + 2 < m.indices.size(); q += 3) {
          char* p = line;
          *p++ = 'f';
          for (int k = 0; k < 3; ++k) {
            const std::uint64_t i = base + m.indices[q + k];
            *p++ = ' ';
            p = std::to_chars(p, p + 24, i).ptr;
            *p++ = '/';
            *p++ = '/';
            p = std::to_chars(p, p + 24, i).ptr;
          }
          *p++ = '\n';
          buf.append(line, p);
        }
        base += nv;
        stream->write(buf);
      },
      [&](double f) { progress(ctx, "caves_obj", f); }, ctx.cancelled);
  stream->close();
}

void write_vdb(const Terrain& t, const WriteContext& ctx, Output& out) {
  const VolumeSpec& spec = need_volume(t, "vdb");
  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
  const VolumeGrid vg = volume_grid(t, spec);
  const float band = float(3.0 * vg.voxel_m);
  openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(band);
  grid->setName("surface");
  grid->setGridClass(openvdb::GRID_LEVEL_SET);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(vg.voxel_m));
  grid->insertMeta("relief_sign", openvdb::StringMetadata("negative in rock (OpenVDB level-set convention)"));
  auto acc = grid->getAccessor();
  evaluate_volume(
      t, spec, ctx.seed,
      [&](int, int, int, const DensityBlock& b) {
        // The chunk's own samples (the apron belongs to the neighbours), those within the band.
        for (int j = 1; j + 1 < b.ny; ++j)
          for (int k = 1; k + 1 < b.nz; ++k)
            for (int i = 1; i + 1 < b.nx; ++i) {
              const float d = b.at(i, j, k);
              if (!(std::fabs(d) < band)) continue;
              acc.setValue(openvdb::Coord(int(b.ix0 + i), int(b.iy0 + j), int(b.iz0 + k)), -d);
            }
      },
      [&](double f) { progress(ctx, "vdb", 0.9 * f); }, ctx.cancelled);
  openvdb::tools::signedFloodFill(grid->tree());
  grid->pruneGrid();
  std::ostringstream os(std::ios_base::binary);
  openvdb::io::Stream(os).write(openvdb::GridPtrVec{grid});
  // OpenVDB stamps every archive with a random UUID (io::Archive's header); ours is fixed, so that the
  // same recipe and seed give the same bytes. It is the 36-character text after the header's
  // magic, versions and compression flag; replaced in place (same length).
  std::string bytes = os.str();
  static constexpr char kUuid[] = "00000000-0000-4000-8000-000000000000";
  auto is_uuid = [&](std::size_t p) {
    if (p + 36 > bytes.size()) return false;
    for (std::size_t k = 0; k < 36; ++k) {
      const char c = bytes[p + k];
      const bool dash = k == 8 || k == 13 || k == 18 || k == 23;
      if (dash ? c != '-' : !std::isxdigit(static_cast<unsigned char>(c))) return false;
    }
    return true;
  };
  std::size_t at = 0;
  while (at < 64 && !is_uuid(at)) ++at;
  if (at == 64) throw Error("output", "caves.vdb: OpenVDB wrote a header without the expected UUID");
  bytes.replace(at, 36, kUuid);
  out.put("caves.vdb", std::move(bytes));
  progress(ctx, "vdb", 1.0);
}

bool has_volume(const Terrain& t) { return t.volume != nullptr; }

}  // namespace

std::vector<WriterDef> volume_writers() {
  std::vector<WriterDef> w;
  w.push_back({"caves", "caves.glb: the volume (caves, overhangs, arches) meshed by marching cubes, one node per chunk",
               {"caves.glb"}, true, write_glb});
  w.back().applies = has_volume;
  w.back().needs = "a volume, overhangs or caves stage in the recipe";
  w.push_back({"caves_obj", "caves.obj: the volume mesh as Wavefront OBJ, one object per chunk, vertex colours",
               {"caves.obj"}, false, write_obj});
  w.back().applies = has_volume;
  w.back().needs = "a volume, overhangs or caves stage in the recipe";
  w.push_back({"vdb", "caves.vdb: the volume's surface as an OpenVDB level set (Blender, Houdini)", {"caves.vdb"}, false,
               write_vdb});
  w.back().applies = has_volume;
  w.back().needs = "a volume, overhangs or caves stage in the recipe";
  return w;
}

}  // namespace relief
