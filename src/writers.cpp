// The writer registry: heightmap (PNG + r16 + JSON sidecar), colour/albedo PNGs, OBJ mesh, report,
// then the export writers of writer_export.cpp (glb, fbx, stl, engine, normalmap, splat, hillshade).
//
// OBJ: Wavefront OBJ as documented in "Object Files (.obj)", Alias|Wavefront Advanced Visualizer
// manual, Appendix B1, and MTL in Appendix B2 (indices are 1-based; `vt` v = 0 is the bottom of the
// texture image). Numbers are formatted with integer arithmetic at a fixed precision (see the OBJ
// section), independent of the locale.
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <charconv>
#include <mutex>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "relief/error.hpp"
#include "relief/output.hpp"
#include "surface.hpp"
#include "writer_defs.hpp"

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
//
// Precision (the contract tests hold us to): positions in metres rounded to 0.1 mm (4 decimals;
// float32, which every client stores, resolves 0.12–0.24 mm at 1–2 km from the origin), normal
// components to 1e-5 (5 decimals), texture coordinates to 1e-5 or finer: `uv_decimals` keeps the
// rounding error under 1/100 of a texel for any grid size. Every number is rounded to the nearest
// multiple of its step (error at most half a step, plus the double rounding of the scaling
// product), trailing zeros and a bare '.' are dropped and −0 is written as 0.
//
// Speed: numbers are formatted with integer arithmetic (one scaling, one rounding, divisions by
// compile-time constants) rather than a general float formatter, and face indices are kept as
// decimal text that is incremented in place. The text is produced in blocks of rows on all
// threads and streamed to the output in order (tbb::parallel_pipeline), so it is never whole in
// memory and the file writes overlap the encoding. The bytes do not depend on scheduling.

// A growable buffer written through cursor()/advance_to(); `reserve(n)` guarantees room for n more
// characters (the fixed-size copies below write up to 64 bytes past the text they place, which
// the 128 bytes of slack per row cover). It keeps its capacity across clear(), so a pool of them
// is reused from block to block.
class TextBuffer {
 public:
  void reserve(std::size_t n) {
    if (used_ + n > buf_.size()) buf_.resize(std::max(buf_.size() * 3 / 2, used_ + n));
  }
  char* cursor() { return buf_.data() + used_; }
  void advance_to(char* p) { used_ = std::size_t(p - buf_.data()); }
  std::string_view view() const { return {buf_.data(), used_}; }
  void clear() { used_ = 0; }

 private:
  std::string buf_;
  std::size_t used_ = 0;
};

constexpr std::uint64_t pow10(int d) { return d == 0 ? 1 : 10 * pow10(d - 1); }

// `v` rounded to a multiple of 10^−Decimals, as [-]int[.frac] with trailing zeros dropped and no
// "-0". Writes at most 40 characters. Integer path for |v|·10^Decimals < 2^52; beyond that (over
// 4·10^11 m for positions: not a terrain) the shortest round-trip form.
template <int Decimals>
char* put_fixed(char* p, double v) {
  constexpr std::uint64_t kScale = pow10(Decimals);
  const double s = v * double(kScale);
  if (!(std::fabs(s) < 0x1p52)) return std::to_chars(p, p + 40, v).ptr;
  // Round to nearest, ties to even (as std::to_chars and printf do with the exact value): adding
  // and subtracting 2^52 leaves no fraction bits, so the FPU's rounding does it in two additions.
  const auto q = std::int64_t(s >= 0 ? (s + 0x1p52) - 0x1p52 : (s - 0x1p52) + 0x1p52);
  if (q < 0) *p++ = '-';  // q == 0 has no sign: −0.00004 is written "0"
  const std::uint64_t u = q < 0 ? std::uint64_t(-q) : std::uint64_t(q);
  p = std::to_chars(p, p + 20, u / kScale).ptr;
  std::uint64_t frac = u % kScale;
  if (frac == 0) return p;
  int digits = Decimals;
  while (frac % 10 == 0) frac /= 10, --digits;
  *p = '.';
  char* e = p + 1 + digits;
  for (char* d = e; d > p + 1; frac /= 10) *--d = char('0' + frac % 10);
  return e;
}

// put_fixed<5> for |v| < 1 (normal components), the same text: "0.", five digits from a table of
// digit pairs, trailing zeros dropped. Larger values go to put_fixed<5>.
char* put_unit5(char* p, double v) {
  static constexpr char kPairs[] =
      "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
      "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
      "8081828384858687888990919293949596979899";
  if (!(std::fabs(v) < 1.0)) return put_fixed<5>(p, v);
  const double s = v * 1e5;
  auto q = std::int64_t(s >= 0 ? (s + 0x1p52) - 0x1p52 : (s - 0x1p52) + 0x1p52);  // ties to even, as put_fixed
  if (q < 0) *p++ = '-', q = -q;
  if (q == 0 || q == 100000) {  // a lone '-' was not written for 0: q < 0 means q ≠ 0
    *p = q ? '1' : '0';
    return p + 1;
  }
  const auto u = std::uint32_t(q);
  p[0] = '0';
  p[1] = '.';
  std::memcpy(p + 2, kPairs + 2 * (u / 1000), 2);
  std::memcpy(p + 4, kPairs + 2 * (u / 10 % 100), 2);
  p[6] = char('0' + u % 10);
  char* e = p + 7;
  while (e[-1] == '0') --e;  // u > 0: a non-zero digit stops it
  return e;
}

char* put_fixed_runtime(char* p, double v, int decimals) {
  switch (decimals) {
    case 5: return put_fixed<5>(p, v);
    case 6: return put_fixed<6>(p, v);
    case 7: return put_fixed<7>(p, v);
    default: return put_fixed<8>(p, v);
  }
}

// Decimals for texture coordinates i/(n−1): rounding error ≤ 0.5·10^−d ≤ 1/100 texel ⇔
// 10^d ≥ 50·(n−1); at least 5 (the precision of earlier files), at most 8.
int uv_decimals(int n) {
  int d = 5;
  while (d < 8 && double(pow10(d)) < 50.0 * double(n - 1)) ++d;
  return d;
}

// A formatted number (put_fixed writes at most 40 characters), copied with one fixed-size move.
struct NumberText {
  char text[48];
  std::size_t len = 0;
  void set(std::ptrdiff_t n) { len = std::size_t(n); }
  char* copy_to(char* p) const {  // the caller's buffer has room for 48 bytes at p
    std::memcpy(p, text, sizeof text);
    return p + len;
  }
};

// "k/k/k" for a 1-based index k, kept as text: increment() rewrites the last digit of the three
// copies in place (nine times out of ten) instead of reformatting the number.
class CornerText {
 public:
  explicit CornerText(std::uint64_t k) { set(k); }
  void increment() {
    ++k_;
    if (text_[digits_ - 1] != '9') {
      ++text_[digits_ - 1];
      ++text_[2 * digits_];
      ++text_[3 * digits_ + 1];
    } else {
      set(k_);
    }
  }
  // Copies a fixed 64 bytes (two or four vector moves, no call) and returns the end of the text;
  // the caller's buffer has room for it.
  char* copy_to(char* p) const {
    std::memcpy(p, text_, sizeof text_);
    return p + len_;
  }

 private:
  void set(std::uint64_t k) {
    k_ = k;
    char num[24];
    digits_ = int(std::to_chars(num, num + sizeof num, k).ptr - num);
    char* p = text_;
    for (int c = 0; c < 3; ++c) {
      if (c) *p++ = '/';
      std::memcpy(p, num, std::size_t(digits_));
      p += digits_;
    }
    len_ = int(p - text_);
  }
  std::uint64_t k_ = 0;
  int digits_ = 0, len_ = 0;
  char text_[64] = {};  // 3·20 + 2 characters at most
};

void write_obj(const Terrain& t, const WriteContext& ctx, Output& out) {
  const Frame& f = t.frame;
  const Layer& h = need_height(t, "obj");
  const int nx = f.nx, nz = f.nz;
  if (nx < 2 || nz < 2) throw Error("obj", "a mesh needs at least 2x2 samples, got " + std::to_string(nx) + "x" + std::to_string(nz));
  if (h.channels != 1 || h.data.size() != f.count())
    throw Error("height", "layer has " + std::to_string(h.data.size()) + " values in " + std::to_string(h.channels) +
                              " channel(s), expected " + std::to_string(f.count()) + " in 1");
  for (std::size_t k = 0; k < h.data.size(); ++k)
    if (!std::isfinite(h.data[k]))
      throw Error("height", "non-finite elevation at sample (" + std::to_string(k % nx) + ", " + std::to_string(k / nx) + ")");
  // Optional vertex jiggle: a two-channel layer "offset" (dx_m, dz_m per sample).
  const Layer* off = find_layer(t, "offset");
  if (off && (off->channels != 2 || off->data.size() != f.count() * 2))
    throw Error("offset", "layer must have 2 channels (dx_m, dz_m) and " + std::to_string(f.count()) + " samples");
  if (off)
    for (float v : off->data)
      if (!std::isfinite(v)) throw Error("offset", "non-finite vertex offset");
  auto Y = [&](int i, int j) { return f.y_m(h.data[std::size_t(j) * nx + i]); };
  const int uv_d = uv_decimals(std::max(nx, nz));

  // Sections, each a run of rows: positions, normals, uvs (nz rows each), then faces (nz − 1
  // rows). Bytes per row at most (a v line ≤ 3·41 + 5, vn ≤ 3·41 + 6, vt ≤ 2·41 + 5; an f line
  // ≤ 2 + 3·(3·20 + 2) + 3 per triangle, two per cell) decide the block size: about 256 KiB per
  // block keeps a block in cache from its encoding to its write.
  const std::size_t nv = f.count(), cells = std::size_t(nx - 1) * std::size_t(nz - 1);
  const int digits = int(std::to_string(nv).size());
  const std::size_t face_line = 2 + 3 * std::size_t(3 * digits + 2) + 3;
  struct Section {
    int rows;
    std::size_t max_bytes_per_row;  // bound, for reserve()
  };
  const Section sections[4] = {{nz, std::size_t(nx) * 128}, {nz, std::size_t(nx) * 130},
                               {nz, std::size_t(nx) * 88}, {nz - 1, std::size_t(nx - 1) * 2 * face_line}};
  struct Block {
    int section, j0, j1;
  };
  std::vector<Block> blocks;
  for (int s = 0; s < 4; ++s) {
    const std::size_t typical = s == 3 ? sections[s].max_bytes_per_row : sections[s].max_bytes_per_row / 3;
    // At least 16 blocks per section, so that progress advances in small steps on small grids.
    const std::size_t by_bytes = (std::size_t(256) << 10) / std::max<std::size_t>(typical, 1);
    const int rows = int(std::clamp<std::size_t>(std::min<std::size_t>(by_bytes, std::size_t(sections[s].rows) / 16), 1, 64));
    for (int j0 = 0; j0 < sections[s].rows; j0 += rows) blocks.push_back({s, j0, std::min(sections[s].rows, j0 + rows)});
  }

  // Numbers that repeat in every row, formatted once: u per column, and x per column when there
  // is no jiggle.
  std::vector<NumberText> u_text(static_cast<std::size_t>(nx)), x_text(off ? 0 : static_cast<std::size_t>(nx));
  for (int i = 0; i < nx; ++i) {
    NumberText& u = u_text[std::size_t(i)];
    u.set(put_fixed_runtime(u.text, double(i) / (nx - 1), uv_d) - u.text);
    if (!off) x_text[std::size_t(i)].set(put_fixed<4>(x_text[std::size_t(i)].text, f.x_m(i)) - x_text[std::size_t(i)].text);
  }

  auto encode = [&](const Block& blk, TextBuffer& tb) {
    tb.clear();
    for (int j = blk.j0; j < blk.j1; ++j) {
      tb.reserve(sections[blk.section].max_bytes_per_row + 128);
      char* p = tb.cursor();
      switch (blk.section) {
        case 0:
          if (off) {
            for (int i = 0; i < nx; ++i) {
              const std::size_t k = std::size_t(j) * nx + i;
              *p++ = 'v';
              *p++ = ' ';
              p = put_fixed<4>(p, f.x_m(i) + double(off->data[2 * k]));
              *p++ = ' ';
              p = put_fixed<4>(p, Y(i, j));
              *p++ = ' ';
              p = put_fixed<4>(p, f.z_m(j) + double(off->data[2 * k + 1]));
              *p++ = '\n';
            }
          } else {
            // Without jiggle, x depends on the column only and z on the row only.
            NumberText z;
            z.set(put_fixed<4>(z.text, f.z_m(j)) - z.text);
            for (int i = 0; i < nx; ++i) {
              *p++ = 'v';
              *p++ = ' ';
              p = x_text[std::size_t(i)].copy_to(p);
              *p++ = ' ';
              p = put_fixed<4>(p, Y(i, j));
              *p++ = ' ';
              p = z.copy_to(p);
              *p++ = '\n';
            }
          }
          break;
        case 1: {
          for (int i = 0; i < nx; ++i) {
            // The surface normal (surface.hpp): central differences, one-sided at the borders.
            const detail::Normal n = detail::normal_at(f, h, i, j);
            std::memcpy(p, "vn ", 3);
            p = put_unit5(p + 3, n.x);
            *p++ = ' ';
            p = put_unit5(p, n.y);
            *p++ = ' ';
            p = put_unit5(p, n.z);
            *p++ = '\n';
          }
          break;
        }
        case 2: {
          // Image row 0 (z-min) is the top of albedo.png; OBJ v = 0 is the image bottom. The v text
          // is the same for the whole row.
          NumberText v;
          v.set(put_fixed_runtime(v.text, 1.0 - double(j) / (nz - 1), uv_d) - v.text);
          for (int i = 0; i < nx; ++i) {
            std::memcpy(p, "vt ", 3);
            p = u_text[std::size_t(i)].copy_to(p + 3);
            *p++ = ' ';
            p = v.copy_to(p);
            *p++ = '\n';
          }
          break;
        }
        default: {
          // 1-based indices of the cell's corners: a = (i, j), c = (i+1, j), d = (i, j+1), e = (i+1, j+1).
          // Counter-clockwise seen from +Y (x east, z south): (i,j) → (i,j+1) → (i+1,j) has
          // (d−a)×(c−a) = (0,0,dz)×(dx,0,0) = (0, dz·dx, 0), i.e. +Y. Same for the second triangle.
          CornerText a(std::uint64_t(j) * nx + 1), d(std::uint64_t(j + 1) * nx + 1);
          CornerText c = a, e = d;
          for (int i = 0; i + 1 < nx; ++i) {
            c.increment();
            e.increment();
            *p++ = 'f';
            *p++ = ' ';
            p = a.copy_to(p);
            *p++ = ' ';
            p = d.copy_to(p);
            *p++ = ' ';
            p = c.copy_to(p);
            std::memcpy(p, "\nf ", 3);
            p = c.copy_to(p + 3);
            *p++ = ' ';
            p = d.copy_to(p);
            *p++ = ' ';
            p = e.copy_to(p);
            *p++ = '\n';
            a = c;
            d = e;
          }
        }
      }
      tb.advance_to(p);
    }
  };

  // Text before the faces' first block ("usemtl") and before the first block at all (header).
  std::string header = "# Relief terrain mesh: " + std::to_string(nx) + "x" + std::to_string(nz) +
                       " samples, Y up, metres, sea surface at y = 0\n# seed " + std::to_string(ctx.seed) +
                       "\nmtllib terrain.mtl\no terrain\n";
  std::size_t estimate = header.size() + 16 + nv * 80 + cells * 2 * face_line;
  auto stream = out.open("terrain.obj", estimate);
  stream->write(header);

  // Each block is encoded on any thread into a buffer from a small pool; the in-order stage writes
  // it and returns the buffer. At most `tokens` blocks are in flight (bounded memory). `buffers`
  // owns every buffer (also those in flight when an Error cancels the pipeline). The pipeline's
  // tokens are block indices (held in place: oneTBB leaks heap-held tokens of a cancelled pipeline);
  // `text_of[blk]` is the buffer holding block blk's text between the two stages.
  const std::size_t tokens = 4 * std::size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
  std::vector<std::unique_ptr<TextBuffer>> buffers;
  std::vector<TextBuffer*> free_buffers;
  std::mutex pool_mutex;
  std::size_t next = 0;
  const double total_rows = 3.0 * nz + (nz - 1);
  double rows_written = 0, reported = 0;
  std::vector<TextBuffer*> text_of(blocks.size(), nullptr);
  tbb::parallel_pipeline(
      tokens,
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& fc) -> std::size_t {
                                            if (next == blocks.size()) fc.stop();
                                            return next++;
                                          }) &
          tbb::make_filter<std::size_t, std::size_t>(tbb::filter_mode::parallel,
                                               [&](std::size_t blk) {
                                                 TextBuffer* tb;
                                                 {
                                                   std::lock_guard<std::mutex> lock(pool_mutex);
                                                   if (free_buffers.empty()) {
                                                     buffers.push_back(std::make_unique<TextBuffer>());
                                                     free_buffers.push_back(buffers.back().get());
                                                   }
                                                   tb = free_buffers.back();
                                                   free_buffers.pop_back();
                                                 }
                                                 encode(blocks[blk], *tb);
                                                 text_of[blk] = tb;
                                                 return blk;
                                               }) &
          tbb::make_filter<std::size_t, void>(tbb::filter_mode::serial_in_order, [&](std::size_t at) {
            const Block& blk = blocks[at];
            if (blk.section == 3 && blk.j0 == 0) stream->write("usemtl terrain\n");
            stream->write(text_of[at]->view());
            {
              std::lock_guard<std::mutex> lock(pool_mutex);
              free_buffers.push_back(text_of[at]);
            }
            rows_written += blk.j1 - blk.j0;
            if (rows_written / total_rows - reported >= 0.02) {
              reported = rows_written / total_rows;
              report_progress(ctx, "obj", reported);
            }
          }));
  // A pipeline cancelled from outside (an Error in a writer running beside this one) returns
  // early: never close a truncated file.
  if (rows_written != total_rows) throw Error("obj", "cancelled before the mesh was complete");
  stream->close();
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
  w.back().implies = {"albedo"};  // terrain.mtl names albedo.png
  for (auto& ww : water_writers()) w.push_back(std::move(ww));
  w.push_back(detail::biomes_writer());
  w.push_back(detail::features_writer());
  w.push_back(detail::props_writer());
  w.push_back({"report", "report.json: version, seed, resolved recipe, timings and peak memory", {"report.json"}, true,
               write_report});
  w.push_back(writers::tilemap());
  for (WriterDef& d : export_writers()) w.push_back(std::move(d));
  w.push_back(detail::geotiff_writer());
  for (WriterDef& d : volume_writers()) w.push_back(std::move(d));
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
