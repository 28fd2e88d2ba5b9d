// The export writers' registry entries (glb, fbx, stl, engine, normalmap, splat, hillshade) and the
// engine heightmap profiles. Orientation and unit conventions: see writer_maps.cpp and the README's
// "Engines" section.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "relief/error.hpp"
#include "relief/export.hpp"
#include "relief/output.hpp"
#include "relief/world_engine.hpp"
#include "writer_defs.hpp"

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

}  // namespace

int engine_tile_overlap(Engine e) { return e == Engine::Unreal ? 0 : 1; }

std::string EngineTiling::extension() const {
  return engine == Engine::Unity    ? ".raw"
         : engine == Engine::Unreal ? ".png"
         : godot_format == GodotFormat::Exr ? ".exr"
                                            : ".r16";
}

std::string EngineTiling::file_name(int X, int Y) const {
  return to_string(engine) + "_height" +
         (tiles_x * tiles_z > 1 ? "_x" + std::to_string(X) + "_y" + std::to_string(Y) : std::string()) + extension();
}

EngineTiling engine_tiling(const ExportOptions& o, int nx, int nz, const OptionPath& path_of, const std::string& size_path) {
  check_engine_size(o, nx, nz, path_of, size_path);
  EngineTiling t;
  t.engine = o.engine;
  t.godot_format = o.godot_format;
  t.tiles_x = o.split_x();
  t.tiles_z = o.split_z();
  const int ov = engine_tile_overlap(o.engine);
  t.tile = (nx - ov) / t.tiles_x + ov;
  t.stride = t.tile - ov;
  return t;
}

std::string encode_engine_tile(const EngineTiling& tiling, const Frame& f, const float* h) {
  const int ts = tiling.tile;
  const std::size_t n = std::size_t(ts) * ts;
  const bool flip = tiling.engine == Engine::Unity;  // file row 0 = the tile's z-max row
  auto at = [&](std::size_t k) {
    if (!flip) return h[k];
    const std::size_t r = k / ts, i = k % ts;
    return h[(ts - 1 - r) * std::size_t(ts) + i];
  };
  if (tiling.engine == Engine::Godot && tiling.godot_format == GodotFormat::Exr) {
    std::vector<float> m(n);
    for (std::size_t k = 0; k < n; ++k) m[k] = float(f.y_m(at(k)));
    return encode_exr_gray32(m, ts, ts);
  }
  if (tiling.engine == Engine::Unreal) {
    std::vector<std::uint16_t> px(n);
    for (std::size_t k = 0; k < n; ++k) px[k] = to_u16(at(k));
    return encode_png_pixels(px.data(), px.size() * 2, ts, ts, 16, 1);
  }
  std::string bytes(n * 2, '\0');
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint16_t u = to_u16(at(k));
    bytes[2 * k] = char(u & 0xFF);  // little-endian whatever the host
    bytes[2 * k + 1] = char(u >> 8);
  }
  return bytes;
}

namespace {

// The sidecar's contents and the import text, built together (they state the same settings).
std::pair<json, std::string> engine_description(const EngineTiling& tl, const Frame& f) {
  const Engine engine = tl.engine;
  const std::string& e = to_string(engine);
  const int kx = tl.tiles_x, kz = tl.tiles_z, ts = tl.tile;
  const double tile_m = (ts - 1) * f.cell_m();   // one tile's extent, first to last sample
  const double stride_m = tl.stride * f.cell_m();  // from one tile's first sample to the next tile's
  const double min_m = f.y_m(0.0), max_m = f.y_m(1.0);
  const bool exr = engine == Engine::Godot && tl.godot_format == GodotFormat::Exr;
  auto name_or_null = [&](int X, int Y) -> json {
    if (X < 0 || Y < 0 || X >= kx || Y >= kz) return nullptr;
    return tl.file_name(X, Y);
  };

  json tiles = json::array();
  for (int tz = 0; tz < kz; ++tz)
    for (int tx = 0; tx < kx; ++tx) {
      const double x0 = f.x0_m() + tx * stride_m, z0 = f.z0_m() + tz * stride_m;
      json tile = {{"file", tl.file_name(tx, tz)}, {"x", tx}, {"y", tz}, {"x0_m", x0}, {"z0_m", z0}};
      if (engine == Engine::Unity) {
        tile["unity_position"] = {x0, min_m, -(z0 + tile_m)};
        // Terrain.SetNeighbors(left, top, right, bottom): Unity +z is our -z (rows flipped).
        tile["neighbors"] = {{"left", name_or_null(tx - 1, tz)}, {"top", name_or_null(tx, tz - 1)},
                             {"right", name_or_null(tx + 1, tz)}, {"bottom", name_or_null(tx, tz + 1)}};
      }
      if (engine == Engine::Unreal) tile["unreal_location_cm"] = {x0 * 100, z0 * 100};
      if (engine == Engine::Godot) tile["godot_position"] = {x0, 0.0, z0};
      tiles.push_back(tile);
    }

  json s;
  s["engine"] = e;
  s["samples_per_tile"] = ts;
  s["tiles_x"] = kx;
  s["tiles_y"] = kz;
  s["overlap_samples"] = engine_tile_overlap(engine);
  s["metres_per_sample"] = f.cell_m();
  s["tile_size_m"] = tile_m;
  s["tile_stride_m"] = stride_m;
  s["min_m"] = min_m;
  s["max_m"] = max_m;
  s["sea_level_m"] = 0.0;
  s["tiles"] = tiles;
  std::string txt;
  auto line = [&](const std::string& l) { txt += l + "\n"; };
  char buf[512];
  if (engine == Engine::Unity) {
    s["format"] = "RAW 16-bit unsigned, little-endian (Windows byte order), no header";
    s["value_to_metres"] = "y_m = min_m + value / 65535 * (max_m - min_m)";
    s["orientation"] = "file row 0 = our z-max edge (rows flipped): Unity's RAW import puts row 0 at terrain z = 0; "
                       "Unity z = -our z, Unity x = our x";
    s["rows_flipped"] = true;
    s["unity"] = {{"heightmap_resolution", ts}, {"terrain_width", tile_m}, {"terrain_length", tile_m},
                  {"terrain_height", max_m - min_m}, {"depth", "Bit 16"}, {"byte_order", "Windows"},
                  {"flip_vertically", false}};
    if (kx * kz > 1)
      s["unity"]["terrain_group"] = {{"grouping_id", 0}, {"allow_auto_connect", true}, {"columns", kx}, {"rows", kz},
                                     {"shared_edges", "neighbours hold the same border samples (overlap 1)"}};
    line("Unity: Terrain > Terrain Settings > Import Raw…, one terrain per file.");
    std::snprintf(buf, sizeof buf, "  Depth: Bit 16   Byte Order: Windows   Flip Vertically: off   Resolution: %d", ts);
    line(buf);
    std::snprintf(buf, sizeof buf, "  Terrain Size: width %.3f m, length %.3f m, height %.3f m", tile_m, tile_m, max_m - min_m);
    line(buf);
    std::snprintf(buf, sizeof buf, "  Position each terrain at y = %.3f m (so the sea surface is y = 0); x, z per tile in %s_height.json.",
                  min_m, e.c_str());
    line(buf);
    if (kx * kz > 1)
      line("  Terrain group: the same Grouping ID and Auto Connect on every tile (or Terrain.SetNeighbors with each tile's "
           "\"neighbors\" in the sidecar); neighbours share their border samples.");
  } else if (engine == Engine::Unreal) {
    const double zscale = f.height_m * 100.0 * 128.0 / 65535.0;  // cm per 128 steps
    const double loc_z = min_m * 100.0 + 32768.0 * zscale / 128.0;
    s["format"] = "PNG 16-bit greyscale";
    s["value_to_metres"] = "y_m = min_m + value / 65535 * (max_m - min_m)";
    s["orientation"] = "no flip: image column = Unreal +X (our x), image row = Unreal +Y (our z), Unreal Z = our y";
    s["rows_flipped"] = false;
    s["unreal"] = {{"scale_cm", {f.cell_m() * 100, f.cell_m() * 100, zscale}}, {"location_z_cm", loc_z},
                   {"normal_map", "DirectX (green down)"}, {"landscape_samples", {kx * ts, kz * ts}}};
    line("Unreal Engine: Landscape mode > Manage > Import from File, one landscape (or World Partition tile) per file.");
    std::snprintf(buf, sizeof buf, "  Scale: X %.4f  Y %.4f  Z %.6f  (Z: heights span -256..256 m x Z/100)", f.cell_m() * 100,
                  f.cell_m() * 100, zscale);
    line(buf);
    std::snprintf(buf, sizeof buf, "  Location Z: %.4f cm (so the sea surface is Z = 0); X, Y per tile in %s_height.json.", loc_z,
                  e.c_str());
    line(buf);
    if (kx * kz > 1) {
      line("  Tiles are named _x<col>_y<row> for the tiled import: pick any one file and accept the tiled image path.");
      std::snprintf(buf, sizeof buf,
                    "  Unreal places tile (X, Y) at X*%d, Y*%d samples, edge to edge: tiles do not share samples; "
                    "the landscape is %dx%d samples.", ts, ts, kx * ts, kz * ts);
      line(buf);
    }
  } else {
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
  return {std::move(s), std::move(txt)};
}

}  // namespace

std::string engine_sidecar(const EngineTiling& tiling, const Frame& world) {
  return engine_description(tiling, world).first.dump(2) + "\n";
}
std::string engine_import_text(const EngineTiling& tiling, const Frame& world) { return engine_description(tiling, world).second; }

void write_engine_files(const Terrain& t, const ExportOptions& o, Output& out, const OptionPath& path_of) {
  const Frame& f = t.frame;
  const Layer& h = t.get("height");
  if (h.channels != 1 || h.data.size() != f.count()) throw Error("height", "layer size does not match the frame");
  const EngineTiling tl = engine_tiling(o, f.nx, f.nz, path_of);
  const int ts = tl.tile;
  std::vector<float> v(std::size_t(ts) * ts);
  for (int tz = 0; tz < tl.tiles_z; ++tz)
    for (int tx = 0; tx < tl.tiles_x; ++tx) {
      const int i0 = tx * tl.stride, j0 = tz * tl.stride;
      for (int r = 0; r < ts; ++r)
        std::copy_n(h.data.data() + std::size_t(j0 + r) * f.nx + i0, ts, v.data() + std::size_t(r) * ts);
      out.put(tl.file_name(tx, tz), encode_engine_tile(tl, f, v.data()));
    }
  auto [sidecar, txt] = engine_description(tl, f);
  out.put(to_string(tl.engine) + "_height.json", sidecar.dump(2) + "\n");
  out.put(to_string(tl.engine) + "_import.txt", std::move(txt));
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
  w.back().implies = {"albedo"};  // the FBX's texture names albedo.png
  w.push_back({"stl", "binary STL of a closed printable relief (mm): --stl-size-mm, --stl-exaggeration, --stl-base-mm",
               {"terrain.stl"}, false, [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 out.put("terrain.stl", encode_stl(t, ctx.options));
                 progress(ctx, "stl", 1.0);
               }});
  w.push_back({"engine", "engine heightmap (--engine unity|unreal|godot, --split NxM) with sidecar JSON and import settings",
               {"<engine>_height.*", "<engine>_height.json", "<engine>_import.txt"}, false,
               [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 write_engine_files(t, ctx.options, out, ctx.option_path);
                 progress(ctx, "engine", 1.0);
               }});
  w.push_back({"normalmap", "tangent-space normal map PNG (8/16-bit, OpenGL green up; DirectX for unreal)", {"normal.png"}, false,
               [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 out.put("normal.png", encode_normal_map(t, ctx.options.normal_bits, ctx.options.directx_normals()));
                 progress(ctx, "normalmap", 1.0);
               }});
  w.push_back({"splat", "RGBA weight maps (4 layers per image, summing to 255) from the biome layer or height/slope rules",
               {"splat0.png …", "splat.json"}, false, [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 SplatMaps s = encode_splat(t, ctx.options, ctx.option_path);
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
