#pragma once
// Stage-by-stage pictures (seed 003 §3.1, figure 3): one hillshaded colour image of the terrain
// after each stage, and a contact sheet of them with captions, so a user sees how the terrain was
// built. `relief generate --steps DIR` writes them; the studio can show the same images.
#include <string>
#include <vector>

#include "relief/terrain.hpp"

namespace relief {

struct StepImage {
  std::string file;     // e.g. "03-biomes.png"
  std::string caption;  // e.g. "3. biomes — Voronoi biomes"
  int width = 0, height = 0;
  Layer rgb;  // 3 channels in 0..1, width × height, row 0 = the z-min edge
};

// The terrain as it stands: the "albedo" layer if it has one (else a preview palette on elevation:
// blues below sea level, greens to browns to white above), lit by the hillshade stage's default
// light, area-averaged down to at most max_px + 1 pixels on the longer side; props (points of kind
// "prop") drawn as dots coloured by type. A terrain without a height layer gives a grey picture.
StepImage render_step(const Terrain& t, int max_px = 512);

// "NN-NAME.png" for stage `index` (0-based) named `stage` (characters outside [a-z0-9_-] become '-').
std::string step_file_name(int index, const std::string& stage);

// PNG of one step image (8-bit RGB).
std::string encode_step_png(const StepImage& s);

// A contact sheet: the steps in reading order, `columns` per row, each scaled to fit a
// thumb_px × thumb_px box, captioned below, with `title` on top. Text is set with FreeType in the
// TrueType font `font_file`, "" = kDefaultCaptionFont (DejaVu Sans, Debian's fonts-dejavu-core).
// The library reads no environment variable: the CLI passes $RELIEF_FONT. Throws Error("steps", …)
// when the font cannot be loaded or `steps` is empty.
inline constexpr const char* kDefaultCaptionFont = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
std::string contact_sheet_png(const std::vector<StepImage>& steps, const std::string& title, int columns = 4,
                              int thumb_px = 256, const std::string& font_file = "");

}  // namespace relief
