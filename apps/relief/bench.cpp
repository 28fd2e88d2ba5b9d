// `relief bench`: timings as medians of several runs, with libnoise (the peer) measured in the
// same run so that a ratio, not an absolute time, carries the claim. Machines are shared and
// noisy: never a pass/fail threshold here or in the tests. This file runs the chosen case groups
// and writes the table and the JSON file; each group is in bench_GROUP.cpp.
#include <fstream>
#include <thread>

#include "bench_common.hpp"
#include "relief/noise.hpp"
#include "relief/output.hpp"

namespace relief::cli {

// bench_volume.cpp: meshing against OpenVDB volumeToMesh (declared here: bench_common.hpp lists the
// older groups).
void bench_volume(const BenchSettings& s, json& entries);
void bench_world(const BenchSettings& s, json& entries);  // bench_world.cpp: whole map against tiles

namespace {
// The case groups in the order they run; `--cases` picks among them.
struct Group {
  const char* name;
  void (*run)(const BenchSettings&, json&);
};
const Group kGroups[] = {{"noise", bench_noise},     {"stages", bench_stages},   {"regenerate", bench_regenerate},
                         {"presets", bench_presets}, {"tilemap", bench_tilemap}, {"erosion", bench_erosion},
                         {"islands", bench_islands}, {"export", bench_export},   {"dem", bench_dem},
                         {"volume", bench_volume}, {"world", bench_world}};
}  // namespace

bool is_bench_group(const std::string& name) {
  return std::any_of(std::begin(kGroups), std::end(kGroups), [&](const Group& g) { return name == g.name; });
}

std::string bench_group_list() {
  std::string out;
  for (auto& g : kGroups) out += (out.empty() ? "" : ", ") + std::string(g.name);
  return out;
}

// The processor's name as the kernel reports it ("model name" in /proc/cpuinfo), or "unknown":
// figures differ several-fold between machines (SIMD width, how wide the vector units really
// are), so every table and JSON file says where it was measured.
std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos && colon + 2 <= line.size()) return line.substr(colon + 2);
    }
  return "unknown";
}

void print_row(const json& e) {
  std::printf("%-28s %6s %3d %10.2f %10.2f %10.2f %9.1f", e["name"].get<std::string>().c_str(),
              (std::to_string(e["size"][0].get<int>()) + "²").c_str(), e["threads"].get<int>(), e["median_ms"].get<double>(),
              e["min_ms"].get<double>(), e["max_ms"].get<double>(), e["msamples_per_s"].get<double>());
  if (e.contains("cpu_median_ms")) std::printf(" %8.2f", e["cpu_median_ms"].get<double>());
  else std::printf(" %8s", "");
  if (e.contains("peer")) {
    std::printf("   %-22s %9.1f  %7.1fx %7.1fx", e["peer"]["name"].get<std::string>().c_str(),
                e["peer"]["msamples_per_s"].get<double>(), e["ratio"].get<double>(), e["cpu_ratio"].get<double>());
  }
  std::printf("\n");
  std::fflush(stdout);
}

int run_bench(const BenchSettings& s) {
  json entries = json::array();
  const std::string cpu = cpu_model(), simd = noise_simd_target();
  std::printf("machine: %s, %u hardware threads, SIMD target %s\n", cpu.c_str(), std::thread::hardware_concurrency(),
              simd.c_str());
  std::printf("%-28s %6s %3s %10s %10s %10s %9s %8s   %-22s %9s  %8s %8s\n", "case", "size", "thr", "median ms", "min ms",
              "max ms", "Msamp/s", "cpu ms", "peer (libnoise)", "Msamp/s", "ratio", "cpu ratio");

  for (const Group& g : kGroups)
    if (s.cases.empty() || std::find(s.cases.begin(), s.cases.end(), g.name) != s.cases.end()) g.run(s, entries);
  std::printf("peak memory %.1f MiB\n", double(peak_rss_bytes()) / (1 << 20));
  if (!s.json_path.empty()) {
    json doc;
    doc["runs"] = s.runs;
    doc["hardware_threads"] = int(std::thread::hardware_concurrency());
    doc["cpu"] = cpu;
    doc["simd_target"] = simd;
    doc["entries"] = entries;
    doc["peak_memory_bytes"] = peak_rss_bytes();
    write_file_atomic(s.json_path, doc.dump(2) + "\n");
    std::printf("wrote %s\n", s.json_path.c_str());
  }
  return 0;
}

}  // namespace relief::cli
