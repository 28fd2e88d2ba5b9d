// A replay driver for the fuzz targets, built with any compiler (no libFuzzer needed), run by CTest:
//
//   fuzz_X_replay CORPUS [--iterations N] [--seed S] [--max-seconds T] [--crash-dir DIR]
//
// CORPUS is a folder (every regular file in it) or one file (a crash input to replay).
// Runs every file of the corpus through LLVMFuzzerTestOneInput, then N deterministic mutations of
// corpus entries (bit flips, byte changes, truncations, deleted and duplicated ranges, splices of two
// entries, number and string swaps), each a pure function of (seed, iteration), so a failure
// reproduces from its iteration number. The mutation loop stops early after T seconds (the corpus
// always runs whole). A target refuses bad input with relief::Error and catches it itself; any other
// exception escaping it fails the run, with the input written to the crash directory. Crashes
// (abort, sanitizer reports) end the process; the handler prints the input first.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <typeinfo>
#include <vector>

#include "relief/random.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

const std::string* g_current = nullptr;

void on_crash(int sig) {
  if (g_current) {
    const char head[] = "\nreplay: crashed on this input:\n";
    (void)!write(2, head, sizeof head - 1);
    (void)!write(2, g_current->data(), std::min<std::size_t>(g_current->size(), 4096));
    (void)!write(2, "\n", 1);
  }
  signal(sig, SIG_DFL);
  raise(sig);
}

struct Rng {
  std::uint64_t seed, iter, k = 0;
  std::uint64_t next() { return relief::hash64(seed, iter, k++); }
  std::size_t below(std::size_t n) { return n == 0 ? 0 : std::size_t(next() % n); }
};

// Number tokens ([-]digits[.digits][e[±]digits]) and string literals of a text, as [begin, end).
std::vector<std::pair<std::size_t, std::size_t>> tokens(const std::string& s, bool numbers) {
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t i = 0; i < s.size();) {
    if (!numbers && s[i] == '"') {
      std::size_t j = i + 1;
      while (j < s.size() && s[j] != '"') j += s[j] == '\\' ? 2 : 1;
      if (j < s.size()) out.emplace_back(i, j + 1);
      i = j + 1;
    } else if (numbers && (std::isdigit((unsigned char)s[i]) || (s[i] == '-' && i + 1 < s.size() && std::isdigit((unsigned char)s[i + 1])))) {
      std::size_t j = i + 1;
      while (j < s.size() && (std::isdigit((unsigned char)s[j]) || s[j] == '.' || s[j] == 'e' || s[j] == 'E' ||
                              ((s[j] == '-' || s[j] == '+') && (s[j - 1] == 'e' || s[j - 1] == 'E'))))
        ++j;
      out.emplace_back(i, j);
      i = j;
    } else {
      ++i;
    }
  }
  return out;
}

const char* kNumbers[] = {"0", "-1", "1", "2", "3", "-0", "0.5", "1e-300", "1e308", "-1e308", "1e999", "40", "255", "256",
                          "65535", "65536", "2147483647", "2147483648", "-2147483649", "4294967296",
                          "9007199254740991", "9007199254740992", "18446744073709551615", "18446744073709551616",
                          "99999999999999999999999", "33", "32769", "32770", "1025", "1.5", "-0.5", "100000", "17"};
const char* kStrings[] = {"\"\"", "\"stage\"", "\"noise\"", "\"island\"", "\"color\"", "\"biomes\"", "\"climate\"", "\"props\"",
                          "\"tilemap\"", "\"flow\"", "\"hydraulic\"", "\"types\"", "\"table\"", "\"levels\"", "\"../../etc/passwd\"",
                          "\"/dev/zero\"", "\"/\"", "\"\\u0000\"", "\"\\ud800\"", "\"gradient\"", "\"perlin\"", "\"stages[0]\"",
                          "\"world.size\"", "\"glb\"", "\"zzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzz\""};
const char kBytes[] = "{}[]\":,.-+0123456789eE \n\\tfnu";

std::string mutate(const std::vector<std::string>& corpus, Rng& rng) {
  std::string s = corpus[rng.below(corpus.size())];
  // Replaces a random number (numbers) or string token of s with a random entry of `values`.
  auto swap_token = [&](bool numbers, const auto& values) {
    auto t = tokens(s, numbers);
    if (t.empty()) return;
    auto [a, b] = t[rng.below(t.size())];
    s.replace(a, b - a, values[rng.below(std::size(values))]);
  };
  const std::size_t steps = 1 + rng.below(4);
  for (std::size_t m = 0; m < steps; ++m) {
    switch (rng.below(9)) {
      case 0:  // bit flip
        if (!s.empty()) s[rng.below(s.size())] ^= char(1u << rng.below(8));
        break;
      case 1:  // a syntax byte
        if (!s.empty()) s[rng.below(s.size())] = kBytes[rng.below(sizeof kBytes - 1)];
        break;
      case 2:  // truncation
        s.resize(rng.below(s.size() + 1));
        break;
      case 3: {  // delete a range
        if (s.empty()) break;
        const std::size_t a = rng.below(s.size()), n = 1 + rng.below(std::min<std::size_t>(64, s.size() - a));
        s.erase(a, n);
        break;
      }
      case 4: {  // duplicate a range
        if (s.empty()) break;
        const std::size_t a = rng.below(s.size()), n = 1 + rng.below(std::min<std::size_t>(256, s.size() - a));
        s.insert(rng.below(s.size() + 1), s.substr(a, n));
        break;
      }
      case 5: {  // splice: a prefix of this entry and a suffix of another
        const std::string& o = corpus[rng.below(corpus.size())];
        s = s.substr(0, rng.below(s.size() + 1)) + o.substr(rng.below(o.size() + 1));
        break;
      }
      case 6:
      case 7:  // number swap
        swap_token(true, kNumbers);
        break;
      case 8:  // string swap
        swap_token(false, kStrings);
        break;
    }
  }
  return s;
}

// Runs one input; false (after reporting) when something other than a refusal escaped.
bool run_one(const std::string& input, const std::string& name, const std::string& crash_dir) {
  g_current = &input;
  std::string what;
  try {
    LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(input.data()), input.size());
    g_current = nullptr;
    return true;
  } catch (const std::exception& e) {
    what = std::string(typeid(e).name()) + ": " + e.what();
  } catch (...) {
    what = "an exception that is not a std::exception";
  }
  g_current = nullptr;
  std::filesystem::create_directories(crash_dir);
  const std::string file = crash_dir + "/" + name;
  std::ofstream(file, std::ios::binary) << input;
  std::fprintf(stderr, "replay: %s threw %s\n  input saved as %s\n", name.c_str(), what.c_str(), file.c_str());
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s CORPUS_DIR_OR_FILE [--iterations N] [--seed S] [--max-seconds T] [--crash-dir DIR]\n", argv[0]);
    return 2;
  }
  const std::string dir = argv[1];
  std::uint64_t iterations = 3000, seed = 1;
  double max_seconds = 60;
  std::string crash_dir = "fuzz-crashes";
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--iterations") iterations = std::stoull(v);
    else if (k == "--seed") seed = std::stoull(v);
    else if (k == "--max-seconds") max_seconds = std::stod(v);
    else if (k == "--crash-dir") crash_dir = v;
    else {
      std::fprintf(stderr, "replay: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  for (int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) signal(sig, on_crash);

  std::vector<std::filesystem::path> files;
  std::error_code ec;
  if (std::filesystem::is_directory(dir, ec)) {
    for (auto& e : std::filesystem::directory_iterator(dir, ec))
      if (e.is_regular_file()) files.push_back(e.path());
  } else if (std::filesystem::exists(dir, ec)) {
    files.push_back(dir);  // one input (a crash file); anything readable, /dev/stdin included
  } else {
    std::fprintf(stderr, "replay: %s: no such file or folder\n", dir.c_str());
    return 2;
  }
  if (ec) {
    std::fprintf(stderr, "replay: cannot read %s: %s\n", dir.c_str(), ec.message().c_str());
    return 2;
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    std::fprintf(stderr, "replay: no inputs in %s\n", dir.c_str());
    return 2;
  }
  std::vector<std::string> corpus;
  for (auto& f : files) {
    std::ifstream in(f, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    corpus.push_back(ss.str());
  }
  int failures = 0;
  for (std::size_t i = 0; i < corpus.size(); ++i) failures += !run_one(corpus[i], "corpus-" + files[i].filename().string(), crash_dir);

  const auto t0 = std::chrono::steady_clock::now();
  std::uint64_t done = 0;
  for (; done < iterations; ++done) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > max_seconds) break;
    Rng rng{seed, done};
    failures += !run_one(mutate(corpus, rng), "seed" + std::to_string(seed) + "-iteration" + std::to_string(done), crash_dir);
    if (failures > 20) break;
  }
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("replay: %zu corpus inputs and %llu of %llu mutations (seed %llu) in %.1f s: %d failures\n", corpus.size(),
              (unsigned long long)done, (unsigned long long)iterations, (unsigned long long)seed, s, failures);
  return failures ? 1 : 0;
}
