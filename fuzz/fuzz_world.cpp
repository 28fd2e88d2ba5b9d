// Fuzz target: the world tile store's readers (relief/world.hpp), which read files from a user's
// folder: decode_world_tile, read_world_manifest, verify_world, read_world_window, and build_world's
// reading of an old world.json when it resumes or refuses a folder.
//
// Input: one byte choosing the mode (value modulo 4), then
//   0: a tile file's bytes, given to decode_world_tile, and to the partial readers world algorithms
//      use (src/world_internal.hpp): parse_tile (no plane inflated), decode_tile_part of each layer
//      alone (it must equal the whole decode's layer), and assemble_tile of the parsed parts, the
//      file build_world's WorldStageIO::update writes from copied planes (it must decode to the
//      same layers);
//   1: two bytes L (little-endian), L bytes of world.json, then the bytes of tiles/x0000_z0000.rtile,
//      written into a temporary folder that read_world_manifest, verify_world and
//      read_world_window (a 2×2 window at the origin) then read;
//   2: the same folder, then build_world of a small noise world (9×9 samples, tiles of 5) into it:
//      it must resume, refuse the folder or rebuild, never crash;
//   3: a point file's bytes (points/p{K}/x…_z….json, relief/world_points.hpp), given to
//      decode_world_points; points it reads must encode and read back to the same values.
// Passes when each call succeeds or throws relief::Error; a decoded tile must hold window.nx ·
// window.nz · channels values per layer. Anything else is a bug.
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "relief/error.hpp"
#include "relief/recipe.hpp"
#include "relief/world_points.hpp"
#include "relief/world.hpp"
#include "../src/world_internal.hpp"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "fuzz_world: %s\n", what);
  std::abort();
}

bool same_layer(const relief::Layer& a, const relief::Layer& b) {
  return a.channels == b.channels && a.data.size() == b.data.size() &&
         (a.data.empty() || std::memcmp(a.data.data(), b.data.data(), a.data.size() * 4) == 0);
}

// The partial readers agree with decode_world_tile: each part alone decodes to the whole decode's
// layer, and a tile assembled from the parts' coded planes decodes to the same layers.
void check_parts(std::string_view bytes) {
  relief::WorldTile whole;
  bool whole_ok = true;
  try {
    whole = relief::decode_world_tile(bytes, "input");
  } catch (const relief::Error&) {
    whole_ok = false;
  }
  relief::detail::TileParts parts;
  try {
    parts = relief::detail::parse_tile(bytes, "input");
  } catch (const relief::Error&) {
    if (whole_ok) fail("parse_tile refused a file decode_world_tile read");
    return;
  }
  bool unique = true;  // a header may name a layer twice; the whole decode then keeps the last
  for (std::size_t a = 0; a < parts.parts.size(); ++a)
    for (std::size_t b = a + 1; b < parts.parts.size(); ++b) unique = unique && parts.parts[a].name != parts.parts[b].name;
  bool all_parts = true;
  for (std::size_t k = 0; k < parts.parts.size(); ++k) {
    const relief::detail::TileParts::Part& p = parts.parts[k];
    if (p.offset < 12 || p.offset + p.size > bytes.size() - 4) fail("a part lies outside the payload");
    try {
      const relief::Layer l = relief::detail::decode_tile_part(bytes, parts, k, "input");
      if (whole_ok && unique && (!whole.layers.count(p.name) || !same_layer(l, whole.layers.at(p.name))))
        fail("a part decoded alone differs from the whole decode's layer");
    } catch (const relief::Error&) {
      if (whole_ok) fail("decode_tile_part refused a part decode_world_tile read");
      all_parts = false;
    }
  }
  if (!whole_ok || !all_parts || !unique) return;
  // Spliced: the parts' coded planes copied into a new file, in ascending name order.
  std::vector<relief::detail::RawPart> raw;
  for (const auto& p : parts.parts) raw.push_back({p.name, p.channels, bytes.substr(p.offset, p.size)});
  std::sort(raw.begin(), raw.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  const std::string spliced = relief::detail::assemble_tile(parts.tile, raw);
  relief::WorldTile again;
  try {
    again = relief::decode_world_tile(spliced, "spliced");
  } catch (const relief::Error&) {
    fail("a tile assembled from valid parts does not decode");
  }
  if (again.layers.size() != whole.layers.size()) fail("the spliced tile has other layers");
  for (const auto& [name, l] : whole.layers)
    if (!again.layers.count(name) || !same_layer(l, again.layers.at(name))) fail("the spliced tile decodes to other values");
}

void check_tile(const relief::WorldTile& t) {
  const std::size_t n = std::size_t(t.window.nx) * std::size_t(t.window.nz);
  for (const auto& [name, l] : t.layers)
    if (l.channels < 1 || l.data.size() != n * std::size_t(l.channels)) {
      std::fprintf(stderr, "fuzz_world: layer '%s' holds %zu values for %zu samples x %d channels\n", name.c_str(), l.data.size(), n,
                   l.channels);
      std::abort();
    }
}

struct TempDir {  // this process's folder, removed at exit
  std::filesystem::path path = std::filesystem::temp_directory_path() / ("relief-fuzz-world-" + std::to_string(::getpid()));
  TempDir() { std::filesystem::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const int mode = data[0] % 4;
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  if (mode == 3) {
    try {
      const std::vector<relief::Point> pts = relief::decode_world_points(bytes, "fuzz-p0", 0, 0, "input");
      const std::vector<relief::Point> again =
          relief::decode_world_points(relief::encode_world_points("fuzz-p0", 0, 0, pts), "fuzz-p0", 0, 0, "again");
      bool same = again.size() == pts.size();
      for (std::size_t i = 0; same && i < pts.size(); ++i)
        same = again[i].kind == pts[i].kind && again[i].type == pts[i].type && again[i].x_m == pts[i].x_m &&
               again[i].y_m == pts[i].y_m && again[i].z_m == pts[i].z_m && again[i].rotation_deg == pts[i].rotation_deg &&
               again[i].scale == pts[i].scale;
      if (!same) {
        std::fprintf(stderr, "fuzz_world: a point file does not read back to the same points\n");
        std::abort();
      }
    } catch (const relief::Error&) {
    }
    return 0;
  }
  if (mode == 0) {
    try {
      check_tile(relief::decode_world_tile(bytes, "input"));
    } catch (const relief::Error&) {
    }
    check_parts(bytes);
    return 0;
  }
  if (bytes.size() < 2) return 0;
  const std::size_t len = std::min<std::size_t>(std::uint8_t(bytes[0]) | std::size_t(std::uint8_t(bytes[1])) << 8, bytes.size() - 2);
  static const TempDir temp;
  const std::filesystem::path dir = temp.path / "world";
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::create_directories(dir / "tiles");
  std::ofstream(dir / "world.json", std::ios::binary | std::ios::trunc).write(bytes.data() + 2, std::streamsize(len));
  std::ofstream(dir / relief::world_tile_path(0, 0), std::ios::binary | std::ios::trunc)
      .write(bytes.data() + 2 + len, std::streamsize(bytes.size() - 2 - len));
  if (mode == 1) {
    try {
      relief::read_world_manifest(dir.string());
    } catch (const relief::Error&) {
    }
    try {
      relief::verify_world(dir.string());
    } catch (const relief::Error&) {
    }
    try {
      const relief::Terrain t = relief::read_world_window(dir.string(), 0, 0, 2, 2);
      for (const auto& [name, l] : t.layers)
        if (l.data.size() != 4 * std::size_t(l.channels)) {
          std::fprintf(stderr, "fuzz_world: window layer '%s' holds %zu values\n", name.c_str(), l.data.size());
          std::abort();
        }
    } catch (const relief::Error&) {
    }
    return 0;
  }
  try {
    static const relief::Recipe recipe = relief::parse_recipe_text(
        R"({"name": "fuzz-world", "seed": 7, "world": {"size": 9, "width_m": 80},
            "stages": [{"stage": "noise", "basis": "gradient", "octaves": 2}, {"stage": "slope"}]})");
    relief::WorldSettings s;
    s.recipe = recipe;
    s.tile = 5;
    s.out_dir = dir.string();
    s.threads = 1;
    s.disk_free_bytes = std::uint64_t(1) << 30;
    relief::build_world(s);
  } catch (const relief::Error&) {
  }
  return 0;
}
