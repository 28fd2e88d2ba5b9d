#pragma once
// Small helpers shared by the tests: running programs (the relief CLI, client tools), scratch
// folders, PNG decoding, small synthetic terrains and small preset recipes. Test files use these
// rather than defining their own.
#include <gtest/gtest.h>
#include <spng.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "relief/noise.hpp"
#include "relief/recipe.hpp"
#include "relief/terrain.hpp"

namespace relief::test {

struct Shell {
  int code = -1;    // exit code, −1 if the command did not exit normally
  std::string out;  // stdout and stderr, interleaved
};

// Runs `cmd` through /bin/sh with stderr folded into stdout.
inline Shell sh(const std::string& cmd) {
  Shell r;
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// Runs the relief binary under test (RELIEF_BINARY, set by tests/CMakeLists.txt) with `args`.
inline Shell relief_cli(const std::string& args) { return sh(std::string(RELIEF_BINARY) + " " + args); }

// Runs relief with `args` and expects the bad-input exit code (2) with `needle` in what it printed.
inline void expect_cli_error(const std::string& args, const std::string& needle) {
  const Shell r = relief_cli(args);
  EXPECT_EQ(r.code, 2) << args << "\n" << r.out;
  EXPECT_NE(r.out.find(needle), std::string::npos) << args << "\nexpected to find: " << needle << "\ngot: " << r.out;
}

// The whole file as bytes ("" if it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Writes `text` to `p` (replacing it).
inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary) << text;
}

// A fresh, empty folder under the system's temporary directory, named after `prefix`, this
// process and a counter; removed with everything in it when the object goes.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& prefix = "relief-test") {
    static std::atomic<int> n{0};
    path = std::filesystem::temp_directory_path() /
           (prefix + "-" + std::to_string(::getpid()) + "-" + std::to_string(n.fetch_add(1)));
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

// A decoded PNG: its header and the samples in the requested spng format (SPNG_FMT_PNG keeps the
// file's own layout, with 16-bit samples in host order).
struct Png {
  spng_ihdr ihdr{};
  std::vector<std::uint8_t> bytes;
  int width() const { return int(ihdr.width); }
  int height() const { return int(ihdr.height); }
};

// Decodes `png` into `fmt`; a malformed file is a test failure (and an empty result).
inline Png decode_png(const std::string& png, int fmt = SPNG_FMT_PNG) {
  Png d;
  spng_ctx* c = spng_ctx_new(0);
  EXPECT_EQ(spng_set_png_buffer(c, png.data(), png.size()), 0);
  EXPECT_EQ(spng_get_ihdr(c, &d.ihdr), 0);
  std::size_t len = 0;
  EXPECT_EQ(spng_decoded_image_size(c, fmt, &len), 0);
  d.bytes.resize(len);
  if (spng_decode_image(c, d.bytes.data(), len, fmt, 0) != 0) {
    ADD_FAILURE() << "PNG does not decode";
    d = Png{};
  }
  spng_ctx_free(c);
  return d;
}

// An nx × nz frame with `spacing_m` between samples (the world spans the samples, corners
// included), `height_m` from normalised 0 to 1 and one sea level.
inline Frame grid_frame(int nx, int nz, double spacing_m, double height_m, double sea_level) {
  Frame f;
  f.nx = nx;
  f.nz = nz;
  f.spacing_m = spacing_m;
  f.world_width_m = spacing_m * (nx - 1);
  f.world_depth_m = spacing_m * (nz - 1);
  f.height_m = height_m;
  f.sea_level = sea_level;
  return f;
}

// A square world of `world_m` metres sampled with n × n samples over the whole world.
inline Frame square_frame(int n, double world_m, double height_m, double sea_level) {
  Frame f;
  f.world_width_m = f.world_depth_m = world_m;
  f.spacing_m = world_m / (n - 1);
  f.nx = f.nz = n;
  f.height_m = height_m;
  f.sea_level = sea_level;
  return f;
}

// A Terrain over `f` whose height layer is h(i, j) at sample (i, j).
inline Terrain grid_terrain(const Frame& f, const std::function<double(int, int)>& h) {
  Terrain t;
  t.frame = f;
  auto& l = t.layer("height", 1);
  for (int j = 0; j < f.nz; ++j)
    for (int i = 0; i < f.nx; ++i) l.data[std::size_t(j) * f.nx + i] = float(h(i, j));
  return t;
}

// Every noise basis and every cellular return value, for tests that cover them all.
inline constexpr NoiseBasis kAllBases[] = {NoiseBasis::Perlin, NoiseBasis::Simplex, NoiseBasis::Value,
                                           NoiseBasis::Cellular, NoiseBasis::Gradient};
inline constexpr CellularReturn kAllReturns[] = {CellularReturn::F1, CellularReturn::F2, CellularReturn::F2MinusF1,
                                                 CellularReturn::CellValue};

// The basis's recipe name, for failure messages.
inline std::string basis_name(NoiseBasis b) {
  switch (b) {
    case NoiseBasis::Perlin: return "perlin";
    case NoiseBasis::Simplex: return "simplex";
    case NoiseBasis::Value: return "value";
    case NoiseBasis::Cellular: return "cellular";
    case NoiseBasis::Gradient: return "gradient";
  }
  return "?";
}

// True when both vectors hold the same values bit for bit (NaNs and signed zeros included).
template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// FNV-1a over the floats' little-endian bytes: the golden hashes of the noise tests.
inline std::uint64_t fnv1a(const std::vector<float>& v) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (float f : v) {
    std::uint32_t b;
    std::memcpy(&b, &f, 4);
    for (int k = 0; k < 4; ++k) h = (h ^ ((b >> (8 * k)) & 0xFF)) * 0x100000001b3ull;
  }
  return h;
}

// The named preset at size × size samples with `seed`: the small recipes most tests run.
inline Recipe preset_recipe(const std::string& name, int size, std::uint64_t seed) {
  json doc = load_preset(name);
  doc["world"]["size"] = size;
  doc["seed"] = seed;
  return parse_recipe(doc);
}

// A suite whose tests share files made once, by Derived::prepare() (public, static), called by the
// first test that runs rather than from SetUpTestSuite: GoogleTest turns a failure in
// SetUpTestSuite into a skip of every test of the suite, which CTest counts as skipped, not failed.
// Here the first test fails with it, and the others fail at once.
template <class Derived>
class SharedFilesTest : public ::testing::Test {
 protected:
  static inline bool prepared_ = false, prepare_failed_ = false;
  void SetUp() override {
    if (!prepared_) {
      prepared_ = prepare_failed_ = true;  // stays true if prepare() throws
      Derived::prepare();
      prepare_failed_ = HasFailure();
    }
    ASSERT_FALSE(prepare_failed_) << "the suite's shared files could not be made: see the first test's failure";
  }
};

}  // namespace relief::test
