// Fuzz target: the world tile store's readers (relief/world.hpp), which read files from a user's
// folder: decode_world_tile, read_world_manifest, verify_world, read_world_window, and build_world's
// reading of an old world.json when it resumes or refuses a folder.
//
// Input: one byte choosing the mode (value modulo 3), then
//   0: a tile file's bytes, given to decode_world_tile;
//   1: two bytes L (little-endian), L bytes of world.json, then the bytes of tiles/x0000_z0000.rtile,
//      written into a temporary folder that read_world_manifest, verify_world and
//      read_world_window (a 2×2 window at the origin) then read;
//   2: the same folder, then build_world of a small noise world (9×9 samples, tiles of 5) into it:
//      it must resume, refuse the folder or rebuild, never crash.
// Passes when each call succeeds or throws relief::Error; a decoded tile must hold window.nx ·
// window.nz · channels values per layer. Anything else is a bug.
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "relief/error.hpp"
#include "relief/recipe.hpp"
#include "relief/world.hpp"

namespace {

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
  const int mode = data[0] % 3;
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  if (mode == 0) {
    try {
      check_tile(relief::decode_world_tile(bytes, "input"));
    } catch (const relief::Error&) {
    }
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
