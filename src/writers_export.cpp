// The export writers' registry entries (glb, fbx, stl, engine, normalmap, splat, hillshade) and the
// engine heightmap profiles. Orientation and unit conventions: see writer_maps.cpp and the README's
// "Engines" section.
#include <cmath>
#include <string>

#include "relief/error.hpp"
#include "relief/export.hpp"
#include "relief/output.hpp"
#include "writers_export.hpp"

namespace relief {
namespace {

void progress(const WriteContext& ctx, std::string_view what, double f) {
  if (ctx.progress) ctx.progress(what, f);
}

std::uint16_t to_u16(float v) {
  double d = v;
  if (!(d > 0.0)) return 0;
  return std::uint16_t((d < 1.0 ? d : 1.0) * 65535.0 + 0.5);
}

// One tile of the height layer: `t` × `t` samples from (i0, j0), optionally rows flipped.
std::vector<float> tile_of(const Terrain& t, int i0, int j0, int w, int d, bool flip_rows) {
  const Layer& h = t.get("height");
  std::vector<float> v(std::size_t(w) * d);
  for (int r = 0; r < d; ++r) {
    const int j = j0 + (flip_rows ? d - 1 - r : r);
    for (int i = 0; i < w; ++i) v[std::size_t(r) * w + i] = h.data[std::size_t(j) * t.frame.nx + i0 + i];
  }
  return v;
}

}  // namespace

void write_engine_files(const Terrain& t, const ExportOptions& o, Output& out) {
  const Frame& f = t.frame;
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != f.count()) throw Error("height", "layer size does not match the frame");
  check_engine_size(o, f.nx, f.nz, recipe_path);  // the CLI checks with its flags' names before writing
  const std::string& e = o.engine;
  const int kx = o.split_x(), kz = o.split_z();
  const int ts = (f.nx - 1) / kx + 1;  // samples per tile side (square)
  const double tile_m = (ts - 1) * f.cell_m();
  const double min_m = f.y_m(0.0), max_m = f.y_m(1.0);
  const bool flip = e == "unity";
  const std::string ext = e == "unity" ? ".raw" : e == "unreal" ? ".png" : o.godot_format == "exr" ? ".exr" : ".r16";

  json tiles = json::array();
  for (int tz = 0; tz < kz; ++tz)
    for (int tx = 0; tx < kx; ++tx) {
      const std::string name =
          e + "_height" + (kx * kz > 1 ? "_x" + std::to_string(tx) + "_y" + std::to_string(tz) : std::string()) + ext;
      const std::vector<float> v = tile_of(t, tx * (ts - 1), tz * (ts - 1), ts, ts, flip);
      std::string bytes;
      if (ext == ".exr") {
        std::vector<float> m(v.size());
        for (std::size_t k = 0; k < v.size(); ++k) m[k] = float(f.y_m(v[k]));
        bytes = encode_exr_gray32(m, ts, ts);
      } else if (ext == ".png") {
        std::vector<std::uint16_t> px(v.size());
        for (std::size_t k = 0; k < v.size(); ++k) px[k] = to_u16(v[k]);
        bytes = encode_png_pixels(px.data(), px.size() * 2, ts, ts, 16, 1);
      } else {
        bytes.resize(v.size() * 2);
        for (std::size_t k = 0; k < v.size(); ++k) {
          const std::uint16_t u = to_u16(v[k]);
          bytes[2 * k] = char(u & 0xFF);  // little-endian whatever the host
          bytes[2 * k + 1] = char(u >> 8);
        }
      }
      out.put(name, std::move(bytes));
      const double x0 = f.x0_m() + tx * tile_m, z0 = f.z0_m() + tz * tile_m;
      json tile = {{"file", name}, {"x", tx}, {"y", tz}, {"x0_m", x0}, {"z0_m", z0}};
      if (e == "unity") tile["unity_position"] = {x0, min_m, -(z0 + tile_m)};
      if (e == "unreal") tile["unreal_location_cm"] = {x0 * 100, z0 * 100};
      if (e == "godot") tile["godot_position"] = {x0, 0.0, z0};
      tiles.push_back(tile);
    }

  json s;
  s["engine"] = e;
  s["samples_per_tile"] = ts;
  s["tiles_x"] = kx;
  s["tiles_y"] = kz;
  s["overlap_samples"] = 1;
  s["metres_per_sample"] = f.cell_m();
  s["tile_size_m"] = tile_m;
  s["min_m"] = min_m;
  s["max_m"] = max_m;
  s["sea_level_m"] = 0.0;
  s["tiles"] = tiles;
  std::string txt;
  auto line = [&](const std::string& l) { txt += l + "\n"; };
  char buf[512];
  if (e == "unity") {
    s["format"] = "RAW 16-bit unsigned, little-endian (Windows byte order), no header";
    s["value_to_metres"] = "y_m = min_m + value / 65535 * (max_m - min_m)";
    s["orientation"] = "file row 0 = our z-max edge (rows flipped): Unity's RAW import puts row 0 at terrain z = 0; "
                       "Unity z = -our z, Unity x = our x";
    s["rows_flipped"] = true;
    s["unity"] = {{"heightmap_resolution", ts}, {"terrain_width", tile_m}, {"terrain_length", tile_m},
                  {"terrain_height", max_m - min_m}, {"depth", "Bit 16"}, {"byte_order", "Windows"},
                  {"flip_vertically", false}};
    line("Unity: Terrain > Terrain Settings > Import Raw…, one terrain per file.");
    std::snprintf(buf, sizeof buf, "  Depth: Bit 16   Byte Order: Windows   Flip Vertically: off   Resolution: %d", ts);
    line(buf);
    std::snprintf(buf, sizeof buf, "  Terrain Size: width %.3f m, length %.3f m, height %.3f m", tile_m, tile_m, max_m - min_m);
    line(buf);
    std::snprintf(buf, sizeof buf, "  Position each terrain at y = %.3f m (so the sea surface is y = 0); x, z per tile in %s_height.json.",
                  min_m, e.c_str());
    line(buf);
  } else if (e == "unreal") {
    const double zscale = f.height_m * 100.0 * 128.0 / 65535.0;  // cm per 128 steps
    const double loc_z = min_m * 100.0 + 32768.0 * zscale / 128.0;
    s["format"] = "PNG 16-bit greyscale";
    s["value_to_metres"] = "y_m = min_m + value / 65535 * (max_m - min_m)";
    s["orientation"] = "no flip: image column = Unreal +X (our x), image row = Unreal +Y (our z), Unreal Z = our y";
    s["rows_flipped"] = false;
    s["unreal"] = {{"scale_cm", {f.cell_m() * 100, f.cell_m() * 100, zscale}}, {"location_z_cm", loc_z},
                   {"normal_map", "DirectX (green down)"}};
    line("Unreal Engine: Landscape mode > Manage > Import from File, one landscape (or World Partition tile) per file.");
    std::snprintf(buf, sizeof buf, "  Scale: X %.4f  Y %.4f  Z %.6f  (Z: heights span -256..256 m x Z/100)", f.cell_m() * 100,
                  f.cell_m() * 100, zscale);
    line(buf);
    std::snprintf(buf, sizeof buf, "  Location Z: %.4f cm (so the sea surface is Z = 0); X, Y per tile in %s_height.json.", loc_z,
                  e.c_str());
    line(buf);
    if (kx * kz > 1) line("  Tiles are named _x<col>_y<row> as the tiled import expects; neighbours share their border samples.");
  } else {
    const bool exr = ext == ".exr";
    s["format"] = exr ? "OpenEXR, one 32-bit float channel Y, ZIP compression, values in metres (sea = 0)"
                      : "r16: 16-bit unsigned little-endian, no header";
    s["value_to_metres"] = exr ? "y_m = value" : "y_m = min_m + value / 65535 * (max_m - min_m)";
    s["orientation"] = "no flip: image column = Godot +x, image row = Godot +z";
    s["rows_flipped"] = false;
    s["godot"] = {{"vertical_scale", exr ? 1.0 : max_m - min_m}, {"min_height_m", exr ? 0.0 : min_m}, {"cell_size_m", f.cell_m()}};
    line("Godot 4: import with a heightmap terrain plugin (e.g. Heightmap Terrain: Import, or Terrain3D), one terrain per file.");
    if (exr) {
      line("  Format: EXR 32-bit float in metres: vertical scale 1.0 (min/max height are not used for EXR).");
    } else {
      std::snprintf(buf, sizeof buf, "  Format: RAW 16-bit: min height %.3f m, max height %.3f m (vertical scale %.3f).", min_m, max_m,
                    max_m - min_m);
      line(buf);
    }
    std::snprintf(buf, sizeof buf, "  Cell size / map scale: %.4f m per sample, %d samples per side.", f.cell_m(), ts);
    line(buf);
  }
  out.put(e + "_height.json", s.dump(2) + "\n");
  out.put(e + "_import.txt", txt);
}

std::vector<WriterDef> export_writers() {
  std::vector<WriterDef> w;
  w.push_back({"glb", "glTF 2.0 binary: chunked terrain with normals, UVs and embedded albedo, props; LOD chain with --lod-levels",
               {"terrain.glb", "terrain_lod1.glb …"}, false, [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 GlbFiles g = encode_glb(t, ctx.options);
                 out.put("terrain.glb", std::move(g.base));
                 for (std::size_t k = 0; k < g.lods.size(); ++k) out.put("terrain_lod" + std::to_string(k + 1) + ".glb", std::move(g.lods[k]));
                 progress(ctx, "glb", 1.0);
               }});
  w.push_back({"fbx", "binary FBX 7.4 (metres, Y up): terrain with UVs and embedded albedo, props as nodes", {"terrain.fbx"}, false,
               [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 out.put("terrain.fbx", encode_fbx(t, ctx.options));
                 progress(ctx, "fbx", 1.0);
               }});
  w.push_back({"stl", "binary STL of a closed printable relief (mm): --stl-size-mm, --stl-exaggeration, --stl-base-mm",
               {"terrain.stl"}, false, [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 out.put("terrain.stl", encode_stl(t, ctx.options));
                 progress(ctx, "stl", 1.0);
               }});
  w.push_back({"engine", "engine heightmap (--engine unity|unreal|godot, --split NxM) with sidecar JSON and import settings",
               {"<engine>_height.*", "<engine>_height.json", "<engine>_import.txt"}, false,
               [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 write_engine_files(t, ctx.options, out);
                 progress(ctx, "engine", 1.0);
               }});
  w.push_back({"normalmap", "tangent-space normal map PNG (8/16-bit, OpenGL green up; DirectX for unreal)", {"normal.png"}, false,
               [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 out.put("normal.png", encode_normal_map(t, ctx.options.normal_bits, ctx.options.directx_normals()));
                 progress(ctx, "normalmap", 1.0);
               }});
  w.push_back({"splat", "RGBA weight maps (4 layers per image, summing to 255) from the biome layer or height/slope rules",
               {"splat0.png …", "splat.json"}, false, [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 SplatMaps s = encode_splat(t, ctx.options);
                 for (std::size_t k = 0; k < s.images.size(); ++k) out.put("splat" + std::to_string(k) + ".png", std::move(s.images[k]));
                 out.put("splat.json", s.description.dump(2) + "\n");
                 progress(ctx, "splat", 1.0);
               }});
  w.push_back({"hillshade", "8-bit greyscale hillshade PNG (--hillshade-azimuth-deg, --hillshade-altitude-deg)", {"hillshade.png"}, false,
               [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 out.put("hillshade.png", encode_hillshade(t, ctx.options.hillshade_azimuth_deg, ctx.options.hillshade_altitude_deg));
                 progress(ctx, "hillshade", 1.0);
               }});
  return w;
}

}  // namespace relief
