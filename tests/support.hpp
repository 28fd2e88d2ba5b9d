#pragma once
// Small helpers shared by the tests: running programs (the relief CLI, client tools), scratch
// folders, and small synthetic terrains.
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <system_error>

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

}  // namespace relief::test
