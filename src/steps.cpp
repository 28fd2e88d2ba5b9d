// Stage-by-stage pictures and their contact sheet (relief/steps.hpp).
//
// Captions are rasterised with FreeType 2 (The FreeType Project, freetype.org): FT_Load_Char with
// FT_LOAD_RENDER gives 8-bit coverage bitmaps that are blended over the sheet; pen advances use the
// glyph metrics plus pair kerning where the font has it.
#include "relief/steps.hpp"

#include <ft2build.h>
#include FT_FREETYPE_H

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "surface.hpp"
#include "parallel.hpp"
#include "relief/error.hpp"
#include "relief/output.hpp"
#include "relief/random.hpp"

namespace relief {
namespace {

struct Rgbf {
  float r, g, b;
};

Rgbf lerp(const Rgbf& a, const Rgbf& b, double t) {
  t = std::clamp(t, 0.0, 1.0);
  return Rgbf{float(a.r + (b.r - a.r) * t), float(a.g + (b.g - a.g) * t), float(a.b + (b.b - a.b) * t)};
}

// Preview palette for stages before any colour exists.
Rgbf preview_color(double e, double sea) {
  if (e <= sea) {
    const double d = sea > 0 ? (sea - e) / sea : 0.0;
    return lerp(Rgbf{0.30f, 0.58f, 0.74f}, Rgbf{0.07f, 0.20f, 0.40f}, d * 2.5);
  }
  const double u = (e - sea) / std::max(1e-9, 1.0 - sea);
  if (u < 0.02) return Rgbf{0.86f, 0.80f, 0.60f};
  if (u < 0.35) return lerp(Rgbf{0.50f, 0.68f, 0.36f}, Rgbf{0.35f, 0.52f, 0.28f}, (u - 0.02) / 0.33);
  if (u < 0.7) return lerp(Rgbf{0.35f, 0.52f, 0.28f}, Rgbf{0.52f, 0.47f, 0.42f}, (u - 0.35) / 0.35);
  return lerp(Rgbf{0.52f, 0.47f, 0.42f}, Rgbf{0.96f, 0.96f, 0.97f}, (u - 0.7) / 0.3);
}

Rgbf prop_color(const std::string& type) {
  static const Rgbf palette[] = {{0.05f, 0.25f, 0.08f}, {0.02f, 0.16f, 0.10f}, {0.30f, 0.38f, 0.08f},
                                 {0.35f, 0.33f, 0.31f}, {0.55f, 0.62f, 0.10f}, {0.75f, 0.12f, 0.10f},
                                 {0.45f, 0.20f, 0.45f}, {0.10f, 0.10f, 0.10f}};
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : type) h = (h ^ c) * 0x100000001b3ull;
  // Common names get fixed colours so pictures read alike across recipes.
  if (type == "tree") return palette[0];
  if (type == "pine") return palette[1];
  if (type == "bush") return palette[2];
  if (type == "rock") return palette[3];
  if (type == "cactus") return palette[4];
  if (type == "mushroom") return palette[5];
  return palette[mix64(h) % 8];
}

// ---- text ------------------------------------------------------------------------------------

struct Font {
  FT_Library lib = nullptr;
  FT_Face face = nullptr;
  explicit Font(const std::string& file) {
    const std::string path = file.empty() ? std::string(kDefaultCaptionFont) : file;
    if (FT_Init_FreeType(&lib)) throw Error("steps", "cannot initialise FreeType");
    if (FT_New_Face(lib, path.c_str(), 0, &face)) {
      FT_Done_FreeType(lib);
      throw Error("steps", "cannot load the caption font '" + path +
                               "' (install fonts-dejavu-core, or name another TrueType file: relief reads $RELIEF_FONT)");
    }
  }
  ~Font() {
    FT_Done_Face(face);
    FT_Done_FreeType(lib);
  }
  Font(const Font&) = delete;
  Font& operator=(const Font&) = delete;
};

std::vector<std::uint32_t> utf8(const std::string& s) {
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < s.size();) {
    const unsigned char c = s[i];
    int n = c < 0x80 ? 1 : (c >> 5) == 6 ? 2 : (c >> 4) == 14 ? 3 : (c >> 3) == 30 ? 4 : 1;
    std::uint32_t cp = n == 1 ? c : n == 2 ? (c & 0x1f) : n == 3 ? (c & 0x0f) : (c & 0x07);
    if (i + n > s.size()) n = 1, cp = '?';
    for (int k = 1; k < n; ++k) cp = (cp << 6) | (std::uint32_t(static_cast<unsigned char>(s[i + k])) & 0x3f);
    out.push_back(cp);
    i += std::size_t(n);
  }
  return out;
}

// Lays `text` out from pen position `pen` with kerning, loading each glyph with `load_flags`: calls
// glyph(pen) for every glyph that loads (it is f.face->glyph), then advances. Returns the final pen.
template <class G>
int lay_out(Font& f, const std::vector<std::uint32_t>& text, int pen, FT_Int32 load_flags, G&& glyph) {
  FT_UInt prev = 0;
  for (std::uint32_t cp : text) {
    const FT_UInt gi = FT_Get_Char_Index(f.face, cp);
    if (prev && gi && FT_HAS_KERNING(f.face)) {
      FT_Vector k;
      FT_Get_Kerning(f.face, prev, gi, FT_KERNING_DEFAULT, &k);
      pen += int(k.x >> 6);
    }
    prev = gi;
    if (FT_Load_Glyph(f.face, gi, load_flags)) continue;
    glyph(pen);
    pen += int(f.face->glyph->advance.x >> 6);
  }
  return pen;
}

// Width in pixels of `text` at the face's current size.
int text_width(Font& f, const std::vector<std::uint32_t>& text) { return lay_out(f, text, 0, FT_LOAD_DEFAULT, [](int) {}); }

// Draws `text` with its baseline at y, starting at x, clipped to max_width (ending in "…" if cut).
void draw_text(Font& f, std::vector<std::uint8_t>& img, int W, int H, int x, int y, const std::string& s, Rgbf color,
               int px, int max_width) {
  FT_Set_Pixel_Sizes(f.face, 0, FT_UInt(px));
  std::vector<std::uint32_t> text = utf8(s);
  if (text_width(f, text) > max_width) {
    const std::vector<std::uint32_t> ell = {0x2026};
    while (!text.empty()) {
      text.pop_back();
      std::vector<std::uint32_t> t2 = text;
      t2.push_back(0x2026);
      if (text_width(f, t2) <= max_width) break;
    }
    text.insert(text.end(), ell.begin(), ell.end());
  }
  lay_out(f, text, x, FT_LOAD_RENDER, [&](int pen) {
    const FT_GlyphSlot g = f.face->glyph;
    const FT_Bitmap& bm = g->bitmap;
    for (unsigned r = 0; r < bm.rows; ++r)
      for (unsigned c = 0; c < bm.width; ++c) {
        const int X = pen + g->bitmap_left + int(c), Y = y - g->bitmap_top + int(r);
        if (X < 0 || Y < 0 || X >= W || Y >= H) continue;
        const double a = bm.buffer[r * unsigned(bm.pitch) + c] / 255.0;
        std::uint8_t* p = &img[(std::size_t(Y) * W + X) * 3];
        const float col[3] = {color.r, color.g, color.b};
        for (int ch = 0; ch < 3; ++ch) p[ch] = std::uint8_t(std::lround(p[ch] * (1.0 - a) + col[ch] * 255.0 * a));
      }
  });
}

}  // namespace

std::string step_file_name(int index, const std::string& stage) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%02d-", index + 1);
  std::string s = buf;
  for (char c : stage) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    s += ok ? c : (c >= 'A' && c <= 'Z') ? char(c - 'A' + 'a') : '-';
  }
  return s + ".png";
}

StepImage render_step(const Terrain& t, int max_px) {
  const Frame& fr = t.frame;
  StepImage out;
  const int f = std::max(1, int(std::ceil(double(std::max(fr.nx, fr.nz) - 1) / std::max(1, max_px))));
  out.width = (fr.nx + f - 1) / f;
  out.height = (fr.nz + f - 1) / f;
  out.rgb.channels = 3;
  out.rgb.data.assign(std::size_t(out.width) * out.height * 3, 0.5f);
  auto hit = t.layers.find("height");
  if (hit == t.layers.end() || hit->second.channels != 1 || hit->second.data.size() != fr.count()) return out;
  const Layer& h = hit->second;
  const Layer* albedo = nullptr;
  Layer preview;
  if (auto a = t.layers.find("albedo"); a != t.layers.end() && a->second.channels == 3 && a->second.data.size() == 3 * fr.count()) {
    albedo = &a->second;
  } else {
    preview.channels = 3;
    preview.data.resize(3 * fr.count());
    detail::parallel_rows(fr.nz, [&](int j) {
      for (int i = 0; i < fr.nx; ++i) {
        const std::size_t k = std::size_t(j) * fr.nx + i;
        const Rgbf c = preview_color(h.data[k], fr.sea_level);
        preview.data[3 * k] = c.r, preview.data[3 * k + 1] = c.g, preview.data[3 * k + 2] = c.b;
      }
    });
    albedo = &preview;
  }
  Layer color;
  detail::hillshade(fr, h, albedo, detail::Light{}, nullptr, &color);
  detail::parallel_rows(out.height, [&](int b) {
    for (int a = 0; a < out.width; ++a) {
      double s[3] = {0, 0, 0};
      int n = 0;
      for (int j = b * f; j < std::min(fr.nz, b * f + f); ++j)
        for (int i = a * f; i < std::min(fr.nx, a * f + f); ++i, ++n)
          for (int c = 0; c < 3; ++c) s[c] += color.data[(std::size_t(j) * fr.nx + i) * 3 + c];
      for (int c = 0; c < 3; ++c) out.rgb.data[(std::size_t(b) * out.width + a) * 3 + c] = float(s[c] / n);
    }
  });
  const double px_m = fr.cell_m() * f;
  const int dot = std::max(1, out.width / 400);
  for (const Point& p : t.points) {
    if (p.kind != "prop") continue;
    const int a = int(std::floor((p.x_m - fr.x0_m()) / px_m + 0.5 / f)), b = int(std::floor((p.z_m - fr.z0_m()) / px_m + 0.5 / f));
    const Rgbf c = prop_color(p.type);
    for (int db = 0; db < dot; ++db)
      for (int da = 0; da < dot; ++da) {
        const int x = a + da, y = b + db;
        if (x < 0 || y < 0 || x >= out.width || y >= out.height) continue;
        float* q = &out.rgb.data[(std::size_t(y) * out.width + x) * 3];
        q[0] = c.r, q[1] = c.g, q[2] = c.b;
      }
  }
  return out;
}

std::string encode_step_png(const StepImage& s) { return encode_png_rgb8(s.rgb, s.width, s.height); }

std::string contact_sheet_png(const std::vector<StepImage>& steps, const std::string& title, int columns, int thumb_px,
                              const std::string& font_file) {
  if (steps.empty()) throw Error("steps", "no stage pictures to put on a contact sheet");
  Font font(font_file);
  columns = std::clamp(columns, 1, int(steps.size()));
  const int rows = (int(steps.size()) + columns - 1) / columns;
  const int margin = 14, caption_h = 24, title_h = 40;
  const int W = margin + columns * (thumb_px + margin);
  const int H = title_h + rows * (thumb_px + caption_h + margin) + margin / 2;
  std::vector<std::uint8_t> img(std::size_t(W) * H * 3);
  for (std::size_t k = 0; k < img.size(); k += 3) img[k] = 244, img[k + 1] = 241, img[k + 2] = 234;
  draw_text(font, img, W, H, margin, 27, title, Rgbf{0.12f, 0.12f, 0.12f}, 18, W - 2 * margin);
  for (std::size_t n = 0; n < steps.size(); ++n) {
    const StepImage& s = steps[n];
    const int col = int(n) % columns, row = int(n) / columns;
    const int x0 = margin + col * (thumb_px + margin), y0 = title_h + row * (thumb_px + caption_h + margin);
    // Fit the picture in the box, area-sampled (box filter over the source pixels it covers).
    const double sc = double(thumb_px) / std::max(s.width, s.height);
    const int tw = std::max(1, int(std::lround(s.width * sc))), th = std::max(1, int(std::lround(s.height * sc)));
    const int ox = x0 + (thumb_px - tw) / 2, oy = y0 + (thumb_px - th) / 2;
    for (int y = 0; y < th; ++y)
      for (int x = 0; x < tw; ++x) {
        const int sx0 = int(x / sc), sx1 = std::max(sx0 + 1, std::min(s.width, int((x + 1) / sc)));
        const int sy0 = int(y / sc), sy1 = std::max(sy0 + 1, std::min(s.height, int((y + 1) / sc)));
        double acc[3] = {0, 0, 0};
        int cnt = 0;
        for (int sy = sy0; sy < std::min(sy1, s.height); ++sy)
          for (int sx = sx0; sx < std::min(sx1, s.width); ++sx, ++cnt)
            for (int c = 0; c < 3; ++c) acc[c] += s.rgb.data[(std::size_t(sy) * s.width + sx) * 3 + c];
        std::uint8_t* p = &img[(std::size_t(oy + y) * W + (ox + x)) * 3];
        for (int c = 0; c < 3; ++c)
          p[c] = std::uint8_t(std::lround(std::clamp(cnt ? acc[c] / cnt : 0.5, 0.0, 1.0) * 255.0));
      }
    draw_text(font, img, W, H, x0, y0 + thumb_px + 17, s.caption, Rgbf{0.15f, 0.15f, 0.15f}, 13, thumb_px);
  }
  Layer l;
  l.channels = 3;
  l.data.resize(img.size());
  for (std::size_t k = 0; k < img.size(); ++k) l.data[k] = float(img[k]) / 255.0f;
  return encode_png_rgb8(l, W, H);
}

}  // namespace relief
