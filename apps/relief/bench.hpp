#pragma once
#include <string>
#include <vector>

namespace relief::cli {

struct BenchSettings {
  int runs = 5;                       // timed runs per case (median, min, max reported)
  int noise_size = 4096;              // noise cases: size² samples into a reused buffer
  int peer_size = 1024;               // libnoise cases (slower): size², compared per sample
  std::vector<int> threads = {1, 2};  // thread counts to measure
  std::vector<int> preset_sizes = {1025, 4097};
  int erosion_size = 1024;            // hydraulic, thermal and stream-power cases: size² samples
  int flood_size = 4096;              // Priority-Flood + D8 + accumulation case: size² samples
  int volume_size = 256;              // volume cases: a size³ density block (meshing against OpenVDB)
  std::vector<std::string> cases;     // see bench_group_list(); empty = all
  std::string json_path;
};

int run_bench(const BenchSettings& s);
// The case groups `--cases` accepts.
bool is_bench_group(const std::string& name);
std::string bench_group_list();  // "noise, stages, …"


}  // namespace relief::cli
