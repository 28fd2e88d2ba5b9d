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
  std::vector<std::string> cases;     // "noise", "presets", "export"; empty = all
  std::string json_path;
};

int run_bench(const BenchSettings& s);

}  // namespace relief::cli
