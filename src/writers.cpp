// The writer registry: heightmap (PNG + r16 + JSON sidecar), colour/albedo PNGs, OBJ mesh, report,
// then the export writers of writers_export.cpp (glb, fbx, stl, engine, normalmap, splat, hillshade).
//
// OBJ: Wavefront OBJ as documented in "Object Files (.obj)", Alias|Wavefront Advanced Visualizer
// manual, Appendix B1, and MTL in Appendix B2 (indices are 1-based; `vt` v = 0 is the bottom of the
// texture image). Numbers are formatted with std::to_chars into one preallocated buffer, which is
// several times faster than iostreams and independent of the locale.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <charconv>
#include <mutex>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "relief/error.hpp"
#include "relief/output.hpp"
#include "writer_defs.hpp"
#include "writers_water.hpp"
#include "writers_islands.hpp"
#include "writers_export.hpp"

#ifndef RELIEF_VERSION
#define RELIEF_VERSION "0.1.0"  // keep in step with project(VERSION) in CMakeLists.txt
#endif

namespace relief {
namespace {

const Layer* find_layer(const Terrain& t, const std::string& name) {
  auto it = t.layers.find(name);
  return it == t.layers.end() ? nullptr : &it->second;
}

const Layer& need_height(const Terrain& t, const char* writer) {
  const Layer* h = find_layer(t, "height");
  if (!h) throw Error("formats", std::string(writer) + " needs a 'height' layer (no elevation stage in the recipe?)");
  return *h;
}

// A colour layer for a PNG: `first` if present, else `second`; neither is an error naming the writer.
const Layer& colour_layer(const Terrain& t, const std::string& first, const std::string& second, const char* writer) {
  if (const Layer* l = find_layer(t, first)) return *l;
  if (const Layer* l = find_layer(t, second)) return *l;
  throw Error("formats", std::string(writer) + " needs a colour stage in the recipe");
}

void report_progress(const WriteContext& ctx, std::string_view what, double f) {
  if (ctx.progress) ctx.progress(what, f);
}

// ---- heightmap ------------------------------------------------------------------------------

void write_heightmap(const Terrain& t, const WriteContext& ctx, Output& out) {
  const Frame& f = t.frame;
  const Layer& h = need_height(t, "heightmap");
  out.put("height.png", encode_png_gray16(h, f.nx, f.nz));  // validates the size
  report_progress(ctx, "heightmap", 0.5);
  out.put("height.r16", encode_r16(h));

  json s;
  s["format"] = "r16 little-endian unsigned";
  s["file"] = "height.r16";
  s["png"] = "height.png";
  s["width"] = f.nx;   // samples along x (image columns)
  s["height"] = f.nz;  // samples along z (image rows)
  s["byte_order"] = "little-endian";
  s["bytes"] = std::uint64_t(f.count()) * 2;
  s["metres_per_pixel"] = f.cell_m();
  s["width_m"] = f.width_m();
  s["depth_m"] = f.depth_m();
  s["x0_m"] = f.x0_m();
  s["z0_m"] = f.z0_m();
  s["ix0"] = f.ix0;  // window offset in samples on the world grid (tiles)
  s["iz0"] = f.iz0;
  s["world_width_m"] = f.world_width_m;
  s["world_depth_m"] = f.world_depth_m;
  s["min_m"] = f.y_m(0.0);  // value 0
  s["max_m"] = f.y_m(1.0);  // value 65535
  s["height_m"] = f.height_m;
  s["sea_level"] = f.sea_level;
  s["sea_level_m"] = 0.0;
  s["value_to_metres"] = "y_m = min_m + value / 65535 * (max_m - min_m); elevation outside 0..1 is clamped";
  s["layout"] =
      "row-major, x fastest, corners included: image column i, row j is the sample at "
      "x = x0_m + i * metres_per_pixel, z = z0_m + j * metres_per_pixel; row 0 is the z-min (north) edge, "
      "column 0 the x-min (west) edge; x east, z south, y up";
  out.put("height.json", s.dump(2) + "\n");
  report_progress(ctx, "heightmap", 1.0);
}

// ---- OBJ --------------------------------------------------------------------------------------

// Appends into a preallocated buffer; `reserve(n)` guarantees room for n more characters.
class TextBuffer {
 public:
  explicit TextBuffer(std::size_t capacity) { buf_.resize(std::max<std::size_t>(capacity, 4096)); }
  void reserve(std::size_t n) {
    if (used_ + n > buf_.size()) buf_.resize(std::max(buf_.size() * 3 / 2, used_ + n));
  }
  void put(char c) { buf_[used_++] = c; }
  void put(std::string_view s) {
    std::memcpy(buf_.data() + used_, s.data(), s.size());
    used_ += s.size();
  }
  // Fixed-point with `decimals` digits, trailing zeros (and a bare '.') trimmed; "-0" becomes "0".
  // At most 40 characters (values too large for that fall back to the shortest exponent form).
  void fixed(double v, int decimals) {
    char* b = buf_.data() + used_;
    auto r = std::to_chars(b, b + 40, v, std::chars_format::fixed, decimals);
    if (r.ec != std::errc()) r = std::to_chars(b, b + 40, v);
    char* e = r.ptr;
    if (std::find(b, e, '.') != e && std::find(b, e, 'e') == e) {
      while (e[-1] == '0') --e;
      if (e[-1] == '.') --e;
    }
    if (e - b == 2 && b[0] == '-' && b[1] == '0') {
      b[0] = '0';
      e = b + 1;
    }
    used_ += std::size_t(e - b);
  }
  void integer(std::uint64_t v) {
    char* b = buf_.data() + used_;
    used_ += std::size_t(std::to_chars(b, b + 24, v).ptr - b);
  }
  std::string take() {
    buf_.resize(used_);
    return std::move(buf_);
  }

 private:
  std::string buf_;
  std::size_t used_ = 0;
};

void write_obj(const Terrain& t, const WriteContext& ctx, Output& out) {
  const Frame& f = t.frame;
  const Layer& h = need_height(t, "obj");
  const int nx = f.nx, nz = f.nz;
  if (nx < 2 || nz < 2) throw Error("obj", "a mesh needs at least 2x2 samples, got " + std::to_string(nx) + "x" + std::to_string(nz));
  if (h.channels != 1 || h.data.size() != f.count())
    throw Error("height", "layer has " + std::to_string(h.data.size()) + " values in " + std::to_string(h.channels) +
                              " channel(s), expected " + std::to_string(f.count()) + " in 1");

  // Metric heights once (the normals need neighbours).
  std::vector<double> y(f.count());
  for (std::size_t k = 0; k < y.size(); ++k) {
    if (!std::isfinite(h.data[k]))
      throw Error("height", "non-finite elevation at sample (" + std::to_string(k % nx) + ", " + std::to_string(k / nx) + ")");
    y[k] = f.y_m(h.data[k]);
  }
  // Optional vertex jiggle: a two-channel layer "offset" (dx_m, dz_m per sample).
  const Layer* off = find_layer(t, "offset");
  if (off && (off->channels != 2 || off->data.size() != f.count() * 2))
    throw Error("offset", "layer must have 2 channels (dx_m, dz_m) and " + std::to_string(f.count()) + " samples");
  if (off)
    for (float v : off->data)
      if (!std::isfinite(v)) throw Error("offset", "non-finite vertex offset");
  const double dx = f.cell_m(), dz = f.cell_m();  // square cells
  auto Y = [&](int i, int j) { return y[std::size_t(j) * nx + i]; };

  // Capacity: an `f` line is at most 3·(3·digits+2)+4 characters; v+vn+vt lines take about 75 per
  // vertex with metre-scale values (more is possible: `reserve` grows the buffer if needed).
  const std::size_t nv = f.count(), nf = 2 * std::size_t(nx - 1) * std::size_t(nz - 1);
  const std::size_t digits = std::to_string(nv).size();
  TextBuffer b(nv * 78 + nf * (3 * (3 * digits + 2) + 4) + 512);
  b.reserve(256);
  b.put("# Relief terrain mesh: ");
  b.integer(std::uint64_t(nx));
  b.put('x');
  b.integer(std::uint64_t(nz));
  b.put(" samples, Y up, metres, sea surface at y = 0\n# seed ");
  b.integer(ctx.seed);
  b.put("\nmtllib terrain.mtl\no terrain\n");

  // Each section (v, vn, vt, f) is encoded in blocks of rows in parallel, each block into its own
  // buffer, then the blocks are appended in order: the text never depends on scheduling.
  constexpr int kRowsPerBlock = 16;
  std::atomic<int> rows_done{0};
  const int total_rows = 4 * nz;
  std::mutex progress_mutex;
  double reported = 0.0;
  auto tick = [&](int rows) {
    const double fraction = double(rows_done += rows) / total_rows;
    std::lock_guard<std::mutex> lock(progress_mutex);
    if (fraction - reported < 0.02) return;
    reported = fraction;
    report_progress(ctx, "obj", fraction);
  };
  auto section = [&](int rows, std::size_t bytes_per_row, auto&& emit) {
    const int blocks = (rows + kRowsPerBlock - 1) / kRowsPerBlock;
    std::vector<std::string> parts(static_cast<std::size_t>(blocks));
    tbb::parallel_for(0, blocks, [&](int blk) {
      const int j0 = blk * kRowsPerBlock, j1 = std::min(rows, j0 + kRowsPerBlock);
      TextBuffer tb(bytes_per_row * std::size_t(j1 - j0) + 256);
      for (int j = j0; j < j1; ++j) emit(tb, j);
      parts[std::size_t(blk)] = tb.take();
      tick(j1 - j0);
    });
    for (auto& part : parts) {
      b.reserve(part.size());
      b.put(part);
      std::string().swap(part);
    }
  };
  section(nz, std::size_t(nx) * 40, [&](TextBuffer& tb, int j) {
    for (int i = 0; i < nx; ++i) {
      tb.reserve(160);
      const std::size_t k = std::size_t(j) * nx + i;
      tb.put("v ");
      tb.fixed(f.x_m(i) + (off ? double(off->data[2 * k]) : 0.0), 4);
      tb.put(' ');
      tb.fixed(Y(i, j), 4);
      tb.put(' ');
      tb.fixed(f.z_m(j) + (off ? double(off->data[2 * k + 1]) : 0.0), 4);
      tb.put('\n');
    }
  });
  section(nz, std::size_t(nx) * 32, [&](TextBuffer& tb, int j) {
    const int j0 = j > 0 ? j - 1 : j, j1 = j + 1 < nz ? j + 1 : j;
    for (int i = 0; i < nx; ++i) {
      const int i0 = i > 0 ? i - 1 : i, i1 = i + 1 < nx ? i + 1 : i;
      // Central differences, one-sided at the borders. Surface y = h(x, z) ⇒ normal ∝ (−h_x, 1, −h_z).
      const double hx = (Y(i1, j) - Y(i0, j)) / ((i1 - i0) * dx);
      const double hz = (Y(i, j1) - Y(i, j0)) / ((j1 - j0) * dz);
      const double inv = 1.0 / std::sqrt(hx * hx + 1.0 + hz * hz);
      tb.reserve(128);
      tb.put("vn ");
      tb.fixed(-hx * inv, 5);
      tb.put(' ');
      tb.fixed(inv, 5);
      tb.put(' ');
      tb.fixed(-hz * inv, 5);
      tb.put('\n');
    }
  });
  section(nz, std::size_t(nx) * 20, [&](TextBuffer& tb, int j) {
    // Image row 0 (z-min) is the top of albedo.png; OBJ v = 0 is the image bottom.
    const double v = 1.0 - double(j) / (nz - 1);
    for (int i = 0; i < nx; ++i) {
      tb.reserve(96);
      tb.put("vt ");
      tb.fixed(double(i) / (nx - 1), 5);
      tb.put(' ');
      tb.fixed(v, 5);
      tb.put('\n');
    }
  });
  b.reserve(64);
  b.put("usemtl terrain\n");
  section(nz - 1, std::size_t(nx) * 2 * (3 * (3 * digits + 2) + 4), [&](TextBuffer& tb, int j) {
    // "k/k/k": the index is formatted once and copied three times.
    auto corner = [&](std::uint64_t k) {
      char num[24];
      const auto len = std::size_t(std::to_chars(num, num + sizeof num, k).ptr - num);
      tb.put(std::string_view(num, len));
      tb.put('/');
      tb.put(std::string_view(num, len));
      tb.put('/');
      tb.put(std::string_view(num, len));
    };
    for (int i = 0; i + 1 < nx; ++i) {
      // 1-based indices of the cell's corners.
      const std::uint64_t a = std::uint64_t(j) * nx + i + 1;  // (i,   j)
      const std::uint64_t c = a + 1;                          // (i+1, j)
      const std::uint64_t d = a + nx;                         // (i,   j+1)
      const std::uint64_t e = d + 1;                          // (i+1, j+1)
      // Counter-clockwise seen from +Y (x east, z south): (i,j) → (i,j+1) → (i+1,j) has
      // (d−a)×(c−a) = (0,0,dz)×(dx,0,0) = (0, dz·dx, 0), i.e. +Y. Same for the second triangle.
      tb.reserve(512);
      tb.put("f ");
      corner(a);
      tb.put(' ');
      corner(d);
      tb.put(' ');
      corner(c);
      tb.put("\nf ");
      corner(c);
      tb.put(' ');
      corner(d);
      tb.put(' ');
      corner(e);
      tb.put('\n');
    }
  });
  out.put("terrain.obj", b.take());
  out.put("terrain.mtl",
          "# Relief terrain material. albedo.png is written by the 'albedo' writer (--formats albedo);\n"
          "# its row 0 is the z-min edge, which the mesh's v coordinates account for.\n"
          "newmtl terrain\n"
          "Ka 0 0 0\n"
          "Kd 1 1 1\n"
          "Ks 0 0 0\n"
          "d 1\n"
          "illum 1\n"
          "map_Kd albedo.png\n");
  report_progress(ctx, "obj", 1.0);
}

// ---- report -----------------------------------------------------------------------------------

void write_report(const Terrain&, const WriteContext& ctx, Output& out) {
  json r;
  r["relief_version"] = RELIEF_VERSION;
  r["seed"] = ctx.seed;
  r["recipe"] = ctx.recipe;
  if (ctx.report.is_object())
    for (auto it = ctx.report.begin(); it != ctx.report.end(); ++it) r[it.key()] = it.value();
  out.put("report.json", r.dump(2) + "\n");
}

std::vector<WriterDef> make_registry() {
  std::vector<WriterDef> w;
  w.push_back({"heightmap", "16-bit greyscale PNG and little-endian r16 of the elevation, with a JSON sidecar",
               {"height.png", "height.r16", "height.json"}, true, write_heightmap});
  w.push_back({"color", "8-bit RGB PNG of the colour layer (falls back to the albedo layer)", {"color.png"}, true,
               [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 const Layer& l = colour_layer(t, "color", "albedo", "color");
                 out.put("color.png", encode_png_rgb8(l, t.frame.nx, t.frame.nz));
                 report_progress(ctx, "color", 1.0);
               }});
  w.push_back({"albedo", "8-bit RGB PNG of the albedo layer (falls back to the colour layer); the OBJ's texture",
               {"albedo.png"}, true, [](const Terrain& t, const WriteContext& ctx, Output& out) {
                 const Layer& l = colour_layer(t, "albedo", "color", "albedo");
                 out.put("albedo.png", encode_png_rgb8(l, t.frame.nx, t.frame.nz));
                 report_progress(ctx, "albedo", 1.0);
               }});
  w.push_back({"obj", "Wavefront OBJ mesh (Y up, metres) with normals and UVs, plus its MTL using albedo.png",
               {"terrain.obj", "terrain.mtl"}, true, write_obj});
  for (auto& ww : water_writers()) w.push_back(std::move(ww));
  w.push_back(detail::biomes_writer());
  w.push_back(detail::features_writer());
  w.push_back(detail::props_writer());
  w.push_back({"report", "report.json: version, seed, resolved recipe, timings and peak memory", {"report.json"}, true,
               write_report});
  w.push_back(writers::tilemap());
  for (WriterDef& d : export_writers()) w.push_back(std::move(d));
  return w;
}

}  // namespace

const std::vector<WriterDef>& writer_registry() {
  static const std::vector<WriterDef> registry = make_registry();
  return registry;
}

const WriterDef* find_writer(std::string_view name) {
  for (const WriterDef& w : writer_registry())
    if (w.name == name) return &w;
  return nullptr;
}

}  // namespace relief
