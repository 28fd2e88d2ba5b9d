// relief_png_settings: measures PNG compression settings (zlib level × strategy × row filter) on
// the images `relief generate` writes by default (height.png 16-bit grey, color.png and
// albedo.png 8-bit RGB) for the four core presets at 1025², and prints one table row per setting:
// size in bytes and the median encoding time in CPU milliseconds of the encoding thread (thread
// CPU time, so that a busy machine disturbs the figures less than wall time would).
//
// This is how the settings in src/output.cpp were chosen; rerun it when libspng, zlib or the
// presets change:  relief_png_settings [--size N] [--runs R] [--quick]
// The encoder is the one the writers use (libspng over zlib), driven with explicit options.
#include <spng.h>
#include <time.h>
#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

using namespace relief;

namespace {

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

struct Image {
  std::string name;
  std::vector<unsigned char> bytes;
  int width, height, bit_depth, color_type;
};

std::size_t encode(const Image& im, int level, int strategy, int filter) {
  std::unique_ptr<spng_ctx, decltype(&spng_ctx_free)> ctx(spng_ctx_new(SPNG_CTX_ENCODER), &spng_ctx_free);
  spng_set_option(ctx.get(), SPNG_ENCODE_TO_BUFFER, 1);
  spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_LEVEL, level);
  spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_STRATEGY, strategy);
  spng_set_option(ctx.get(), SPNG_FILTER_CHOICE, filter);
  spng_ihdr ihdr{};
  ihdr.width = std::uint32_t(im.width);
  ihdr.height = std::uint32_t(im.height);
  ihdr.bit_depth = std::uint8_t(im.bit_depth);
  ihdr.color_type = std::uint8_t(im.color_type);
  spng_set_ihdr(ctx.get(), &ihdr);
  if (int r = spng_encode_image(ctx.get(), im.bytes.data(), im.bytes.size(), SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE)) {
    std::fprintf(stderr, "encode failed: %s\n", spng_strerror(r));
    std::exit(1);
  }
  std::size_t len = 0;
  int err = 0;
  void* buf = spng_get_png_buffer(ctx.get(), &len, &err);
  std::free(buf);
  return len;
}

// The writers' pixel conversion (src/output.cpp): clamp to 0..1, round.
double unit(float v) { return !(double(v) > 0.0) ? 0.0 : double(v) < 1.0 ? double(v) : 1.0; }

}  // namespace

int main(int argc, char** argv) {
  int size = 1025, runs = 3;
  bool quick = false;
  for (int k = 1; k < argc; ++k) {
    if (!std::strcmp(argv[k], "--size") && k + 1 < argc) size = std::atoi(argv[++k]);
    else if (!std::strcmp(argv[k], "--runs") && k + 1 < argc) runs = std::atoi(argv[++k]);
    else if (!std::strcmp(argv[k], "--quick")) quick = true;
    else {
      std::fprintf(stderr, "usage: relief_png_settings [--size N] [--runs R] [--quick]\n");
      return 2;
    }
  }
  std::vector<Image> images;
  for (const char* preset : {"island", "hills", "mountains", "desert"}) {
    json doc = load_preset(preset);
    doc["world"]["size"] = size;
    doc["seed"] = 7;
    RunResult res = run(parse_recipe(doc), RunOptions{});
    const Terrain& t = res.terrain;
    const int nx = t.frame.nx, nz = t.frame.nz;
    Image h{std::string(preset) + " height", {}, nx, nz, 16, SPNG_COLOR_TYPE_GRAYSCALE};
    h.bytes.resize(std::size_t(nx) * nz * 2);
    const auto& hd = t.layers.at("height").data;
    for (std::size_t k = 0; k < hd.size(); ++k) {
      const std::uint16_t v = std::uint16_t(unit(hd[k]) * 65535.0 + 0.5);
      std::memcpy(&h.bytes[2 * k], &v, 2);  // host order, as SPNG_FMT_PNG expects
    }
    images.push_back(std::move(h));
    for (const char* layer : {"color", "albedo"}) {
      Image c{std::string(preset) + " " + layer, {}, nx, nz, 8, SPNG_COLOR_TYPE_TRUECOLOR};
      const auto& cd = t.layers.at(layer).data;
      c.bytes.resize(cd.size());
      for (std::size_t k = 0; k < cd.size(); ++k) c.bytes[k] = std::uint8_t(unit(cd[k]) * 255.0 + 0.5);
      images.push_back(std::move(c));
    }
  }
  struct Named {
    const char* name;
    int value;
  };
  const std::vector<Named> levels = quick ? std::vector<Named>{{"1", 1}, {"4", 4}}
                                          : std::vector<Named>{{"1", 1}, {"2", 2}, {"3", 3}, {"4", 4}, {"6", 6}};
  const std::vector<Named> strategies = {{"default", Z_DEFAULT_STRATEGY}, {"filtered", Z_FILTERED}, {"rle", Z_RLE}};
  const std::vector<Named> filters = {{"none", SPNG_FILTER_CHOICE_NONE}, {"sub", SPNG_FILTER_CHOICE_SUB},
                                      {"up", SPNG_FILTER_CHOICE_UP},     {"avg", SPNG_FILTER_CHOICE_AVG},
                                      {"paeth", SPNG_FILTER_CHOICE_PAETH}, {"adaptive", SPNG_FILTER_CHOICE_ALL}};
  std::printf("%-18s %-6s %-9s %-9s %10s %9s\n", "image", "level", "strategy", "filter", "bytes", "cpu_ms");
  for (const Image& im : images)
    for (const Named& l : levels)
      for (const Named& s : strategies)
        for (const Named& f : filters) {
          std::vector<double> ms;
          std::size_t bytes = 0;
          for (int r = 0; r < runs; ++r) {
            const double t0 = thread_cpu_ms();
            bytes = encode(im, l.value, s.value, f.value);
            ms.push_back(thread_cpu_ms() - t0);
          }
          std::sort(ms.begin(), ms.end());
          std::printf("%-18s %-6s %-9s %-9s %10zu %9.1f\n", im.name.c_str(), l.name, s.name, f.name, bytes, ms[ms.size() / 2]);
          std::fflush(stdout);
        }
  return 0;
}
