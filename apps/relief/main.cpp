// relief: the command-line tool. Argument parsing fills a settings struct; one function per
// command does the work through the library. The library never prints or exits: this file owns
// the terminal, the files and the exit codes (0 ok, 1 internal failure, 2 bad input).
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "bench.hpp"
#include "studio.hpp"
#include "relief/explain.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

using namespace relief;

namespace {

struct GenerateSettings {
  std::string recipe;  // preset name or recipe file
  std::string preset;
  std::string out_dir = "out";
  std::string size;
  std::string formats;
  std::vector<std::string> sets;
  std::string save_recipe;
  std::int64_t seed = -1;
  bool seed_given = false;
  int threads = 0;
  bool quiet = false;
};

bool is_tty() { return isatty(fileno(stderr)) != 0; }

std::string human_bytes(std::uint64_t b) {
  char buf[32];
  if (b >= (1ull << 30)) std::snprintf(buf, sizeof buf, "%.2f GiB", double(b) / double(1ull << 30));
  else if (b >= (1ull << 20)) std::snprintf(buf, sizeof buf, "%.1f MiB", double(b) / double(1ull << 20));
  else if (b >= 1024) std::snprintf(buf, sizeof buf, "%.1f KiB", double(b) / 1024.0);
  else std::snprintf(buf, sizeof buf, "%llu B", (unsigned long long)b);
  return buf;
}

std::uint64_t peak_rss_bytes() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return std::uint64_t(u.ru_maxrss) * 1024;
}

// Progress on a terminal only: one rewritten line on stderr.
struct Progress {
  bool on = false;
  void operator()(std::string_view what, double f) const {
    if (!on) return;
    std::fprintf(stderr, "\r\033[K[%3d%%] %.*s", int(std::lround(f * 100)), int(what.size()), what.data());
    std::fflush(stderr);
  }
  void done() const {
    if (on) std::fprintf(stderr, "\r\033[K");
  }
};

json read_recipe_doc(const GenerateSettings& s) {
  std::string src = !s.preset.empty() ? s.preset : s.recipe.empty() ? "island" : s.recipe;
  const bool file_like = s.preset.empty() && !s.recipe.empty() &&
                         (src.find('/') != std::string::npos || src.ends_with(".json") || std::filesystem::exists(src));
  if (!file_like) return load_preset(src);
  std::ifstream in(src, std::ios::binary);
  if (!in) throw Error("recipe", "cannot read '" + src + "'");
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    return json::parse(ss.str());
  } catch (const json::exception& e) {
    throw Error("recipe", "'" + src + "' is not valid JSON: " + e.what());
  }
}

void parse_size(const std::string& text, json& doc) {
  const std::string expect = "expected N or NxM with 2..32769 samples per axis";
  auto num = [&](const std::string& t) -> long long {
    if (t.empty() || t.size() > 6 || t.find_first_not_of("0123456789") != std::string::npos)
      throw Error("--size", expect + ", got \"" + text + "\"");
    return std::stoll(t);
  };
  auto x = text.find_first_of("xX");
  long long nx = num(text.substr(0, x)), nz = x == std::string::npos ? nx : num(text.substr(x + 1));
  if (nx < 2 || nz < 2 || nx > 32769 || nz > 32769) throw Error("--size", expect + ", got \"" + text + "\"");
  if (!doc.contains("world") || !doc["world"].is_object()) doc["world"] = json::object();
  doc["world"]["size"] = json::array({nx, nz});
}

int cmd_generate(const GenerateSettings& s) {
  const auto t_start = std::chrono::steady_clock::now();
  json doc = read_recipe_doc(s);
  if (!doc.is_object()) throw Error("recipe", "expected a JSON object, got " + describe(doc));
  if (!s.size.empty()) parse_size(s.size, doc);
  if (s.seed_given) {
    if (s.seed < 0 || std::uint64_t(s.seed) > kMaxSeed)
      throw Error("--seed", "expected an integer in 0..9007199254740991, got " + std::to_string(s.seed));
    doc["seed"] = s.seed;
  }
  for (auto& a : s.sets) apply_override(doc, a);
  Recipe recipe = parse_recipe(doc);

  // Writers: validated before any work is done.
  std::vector<const WriterDef*> writers;
  if (s.formats.empty()) {
    for (auto& w : writer_registry())
      if (w.in_default_set) writers.push_back(&w);
  } else {
    std::stringstream ss(s.formats);
    std::string name;
    std::vector<std::string> names;
    for (auto& w : writer_registry()) names.push_back(w.name);
    while (std::getline(ss, name, ',')) {
      if (name.empty()) continue;
      const WriterDef* w = find_writer(name);
      if (!w) {
        std::string near = nearest_name(name, names), list;
        for (auto& n : names) list += (list.empty() ? "" : ", ") + n;
        throw Error("--formats", "unknown format \"" + name + "\"" + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                                     "; available: " + list);
      }
      writers.push_back(w);
    }
    if (writers.empty()) throw Error("--formats", "expected at least one format, got \"" + s.formats + "\"");
  }
  bool with_mesh = false, with_albedo = false;
  for (auto* w : writers) with_mesh = with_mesh || w->name == "obj", with_albedo = with_albedo || w->name == "albedo";
  // terrain.mtl references albedo.png: an OBJ is never written without its texture.
  if (with_mesh && !with_albedo) writers.push_back(find_writer("albedo"));
  const std::uint64_t need = estimate_memory_bytes(recipe, with_mesh), have = physical_memory_bytes();
  if (have && need > have * 8 / 10)
    throw Error("world.size", "a " + std::to_string(recipe.world.nx) + "x" + std::to_string(recipe.world.nz) +
                                  " terrain with these formats needs about " + human_bytes(need) + ", but this machine has " +
                                  human_bytes(have) + "; choose a smaller --size" + (with_mesh ? " or drop obj from --formats" : ""));

  // Check the output directory before spending time on generation.
  FileOutput files(s.out_dir);

  Progress prog{is_tty() && !s.quiet};
  RunOptions opt;
  opt.threads = s.threads;
  opt.progress = [&](std::string_view st, double f) { prog(std::string("stage ") + std::string(st), f * 0.7); };
  if (!recipe.seed && !s.quiet) std::fprintf(stderr, "relief: no seed given; using a random one\n");
  RunResult res = run(recipe, opt);
  recipe.seed = res.seed;
  if (!s.quiet) std::printf("seed %llu (reproduce with --seed %llu)\n", (unsigned long long)res.seed, (unsigned long long)res.seed);

  WriteContext wc;
  wc.seed = res.seed;
  wc.recipe = recipe.to_json();
  wc.progress = [&](std::string_view what, double f) { prog(what, 0.7 + 0.3 * f); };
  MemoryOutput mem;
  json write_ms = json::object();
  const WriterDef* report = nullptr;
  for (auto* w : writers) {
    if (w->name == "report") {
      report = w;
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    w->write(res.terrain, wc, mem);
    write_ms[w->name] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  }
  if (report) {
    json perf;
    perf["threads"] = s.threads;
    json st = json::array();
    for (auto& t : res.timings) st.push_back({{"stage", t.name}, {"label", t.label}, {"ms", t.ms}});
    perf["stages"] = st;
    perf["generate_ms"] = res.total_ms;
    perf["encode_ms"] = write_ms;
    perf["peak_memory_bytes"] = peak_rss_bytes();
    perf["total_ms"] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_start).count();
    wc.report["performance"] = perf;
    report->write(res.terrain, wc, mem);
  }
  std::size_t k = 0;
  for (auto& [name, bytes] : mem.files) {
    prog("writing " + name, 0.7 + 0.3 * double(k++) / double(mem.files.size()));
    files.put(name, std::move(bytes));
  }
  if (!s.save_recipe.empty()) {
    write_file_atomic(s.save_recipe, recipe.to_json().dump(2) + "\n");
  }
  prog.done();
  if (!s.quiet) {
    for (auto& p : files.written()) std::printf("wrote %s (%s)\n", p.c_str(), human_bytes(std::filesystem::file_size(p)).c_str());
    if (!s.save_recipe.empty()) std::printf("wrote %s (resolved recipe)\n", s.save_recipe.c_str());
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("%s %dx%d in %.2f s (generate %.0f ms), peak memory %s\n", recipe.name.c_str(), recipe.world.nx,
                recipe.world.nz, total, res.total_ms, human_bytes(peak_rss_bytes()).c_str());
  }
  return 0;
}

int cmd_presets(bool as_json) {
  auto list = list_presets();
  if (as_json) {
    json a = json::array();
    for (auto& p : list) a.push_back({{"name", p.name}, {"description", p.description}, {"origin", p.origin}});
    std::printf("%s\n", a.dump(2).c_str());
    return 0;
  }
  std::size_t w = 0;
  for (auto& p : list) w = std::max(w, p.name.size());
  for (auto& p : list)
    std::printf("%-*s  %s%s\n", int(w), p.name.c_str(), p.description.c_str(),
                p.origin == "built-in" ? "" : ("  [" + p.origin + "]").c_str());
  return 0;
}

void print_params(const std::vector<ParamInfo>& ps) {
  for (auto& p : ps) {
    std::string range;
    if (p.type == ParamType::Int || p.type == ParamType::Float) {
      std::ostringstream o;
      o << p.min << ".." << p.max;
      range = o.str();
    } else if (p.type == ParamType::Choice) {
      for (auto& c : p.choices) range += (range.empty() ? "" : "|") + c;
    }
    std::printf("    %-16s %-7s default %-12s %-22s %s%s%s\n", p.name.c_str(), to_string(p.type),
                p.default_value.dump().substr(0, 12).c_str(), range.c_str(), p.description.c_str(),
                p.unit.empty() ? "" : (" [" + p.unit + "]").c_str(), p.effect == Effect::Recolour ? " (recolour)" : "");
  }
}

int cmd_explain(const std::string& stage, bool as_json) {
  if (as_json) {
    std::printf("%s\n", parameter_table_json(stage).dump(2).c_str());
    return 0;
  }
  if (!stage.empty()) {
    const StageDef* d = find_stage(stage);
    if (!d) {
      std::vector<std::string> names;
      for (auto& x : stage_registry()) names.push_back(x.name);
      std::string near = nearest_name(stage, names);
      throw Error("stage", "unknown stage \"" + stage + "\"" + (near.empty() ? "" : " (did you mean '" + near + "'?)"));
    }
    std::printf("%s: %s\n", d->name.c_str(), d->summary.c_str());
    print_params(d->params);
    return 0;
  }
  std::printf("world:\n");
  print_params(world_params());
  std::printf("\nstages (use `relief explain STAGE` for one):\n");
  for (auto& d : stage_registry()) {
    std::printf("  %s: %s\n", d.name.c_str(), d.summary.c_str());
    print_params(d.params);
  }
  std::printf("\nformats (--formats a,b,c):\n");
  for (auto& w : writer_registry()) {
    std::string files;
    for (auto& f : w.files) files += (files.empty() ? "" : ", ") + f;
    std::printf("  %-10s %s -> %s%s\n", w.name.c_str(), w.description.c_str(), files.c_str(), w.in_default_set ? "" : " (not default)");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"relief: procedural terrain generator — heightmaps, textured meshes and maps from a seed and a recipe"};
  app.set_version_flag("--version", std::string("relief ") + RELIEF_VERSION);
  app.require_subcommand(1);

  GenerateSettings gs;
  auto* gen = app.add_subcommand("generate", "Generate a terrain from a preset or recipe file and write its files");
  gen->add_option("recipe", gs.recipe, "Preset name or recipe JSON file (default: island)");
  gen->add_option("--preset,-p", gs.preset, "Preset name (see `relief presets`)");
  gen->add_option("-o,--out", gs.out_dir, "Output directory (created if missing)")->capture_default_str();
  gen->add_option("--seed,-s", gs.seed, "Seed, 0..2^53-1 (default: the recipe's, else random and printed)");
  gen->add_option("--size", gs.size, "Samples per axis: N or NxM (cells stay square; depth follows the aspect)");
  gen->add_option("--formats,-f", gs.formats, "Comma-separated writers replacing the default set (see `relief explain`)");
  gen->add_option("--set", gs.sets, "Override a recipe field: PATH=VALUE, e.g. 'stages[1].octaves=8' (repeatable)");
  gen->add_option("--threads,-j", gs.threads, "Worker threads (0 = all cores); output is identical for any count")
      ->check(CLI::Range(0, 1024));
  gen->add_option("--save-recipe", gs.save_recipe, "Write the fully resolved recipe (defaults and seed) to FILE");
  gen->add_flag("--quiet,-q", gs.quiet, "Print nothing but errors");

  bool presets_json = false;
  auto* pre = app.add_subcommand("presets", "List presets: built-in, then $RELIEF_PRESETS folders and ~/.config/relief/presets");
  pre->add_flag("--json", presets_json, "Print as JSON");

  std::string explain_stage;
  bool explain_json = false;
  auto* exp = app.add_subcommand("explain", "Describe the world block, every stage and its parameters, and the formats");
  exp->add_option("stage", explain_stage, "Only this stage");
  exp->add_flag("--json", explain_json, "Print the parameter table as JSON");

  cli::BenchSettings bs;
  std::string bench_threads = "1,2", bench_sizes = "1025,4097", bench_cases;
  auto* ben = app.add_subcommand("bench", "Measure noise and whole presets (medians), with libnoise as the peer in the same run");
  ben->add_option("--runs", bs.runs, "Timed runs per case (at least 5 for published figures)")->check(CLI::Range(1, 1000))->capture_default_str();
  ben->add_option("--noise-size", bs.noise_size, "Noise cases evaluate size² samples")->check(CLI::Range(16, 16384))->capture_default_str();
  ben->add_option("--peer-size", bs.peer_size, "libnoise cases evaluate size² samples (compared per sample)")->check(CLI::Range(16, 16384))->capture_default_str();
  ben->add_option("--threads", bench_threads, "Comma-separated thread counts")->capture_default_str();
  ben->add_option("--preset-sizes", bench_sizes, "Comma-separated preset sizes")->capture_default_str();
  ben->add_option("--cases", bench_cases, "Comma-separated groups: noise, stages, presets (default: all)");
  ben->add_option("--json", bs.json_path, "Also write the results as JSON to FILE");

  cli::StudioSettings ss;
  auto* stu = app.add_subcommand("studio", "Serve Relief Studio: a live 3D preview with sliders, stage playback, walk mode and exports");
  stu->add_option("--port", ss.port, "TCP port (0 = any free port, printed)")->check(CLI::Range(0, 65535))->capture_default_str();
  stu->add_option("--host", ss.host, "Address to listen on (loopback unless you say otherwise)")->capture_default_str();
  stu->add_flag("--open", ss.open, "Open the page in the default browser (xdg-open)");
  stu->add_option("--max-preview", ss.max_preview, "Largest preview size accepted (samples per axis)")
      ->check(CLI::Range(2, 8193))->capture_default_str();
  stu->add_option("--max-export", ss.max_export, "Largest export size accepted (samples per axis)")
      ->check(CLI::Range(2, 32769))->capture_default_str();
  stu->add_option("--cache-mib", ss.cache_mib, "Memory for cached stage outputs, MiB")->check(CLI::Range(16, 1 << 20))->capture_default_str();
  stu->add_option("--threads,-j", ss.threads, "Generation threads (0 = all cores)")->check(CLI::Range(0, 1024));

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  }
  gs.seed_given = gen->count("--seed") > 0;
  try {
    if (*gen) return cmd_generate(gs);
    if (*pre) return cmd_presets(presets_json);
    if (*exp) return cmd_explain(explain_stage, explain_json);
    if (*stu) {
#ifdef RELIEF_HAVE_STUDIO
      return cli::run_studio(ss);
#else
      throw Error("studio", "this relief was built without the studio: run scripts/setup.sh, then rebuild");
#endif
    }
    if (*ben) {
      auto ints = [](const std::string& text, const char* field, int lo, int hi) {
        std::vector<int> v;
        std::stringstream ss(text);
        std::string item;
        while (std::getline(ss, item, ',')) {
          if (item.empty() || item.find_first_not_of("0123456789") != std::string::npos || item.size() > 6 ||
              std::stoi(item) < lo || std::stoi(item) > hi)
            throw Error(field, "expected comma-separated integers in " + std::to_string(lo) + ".." + std::to_string(hi) +
                                   ", got \"" + text + "\"");
          v.push_back(std::stoi(item));
        }
        if (v.empty()) throw Error(field, "expected at least one value");
        return v;
      };
      bs.threads = ints(bench_threads, "--threads", 1, 1024);
      bs.preset_sizes = ints(bench_sizes, "--preset-sizes", 2, 32769);
      std::stringstream ss(bench_cases);
      std::string c;
      while (std::getline(ss, c, ',')) {
        if (c != "noise" && c != "presets" && c != "stages")
          throw Error("--cases", "expected noise, stages or presets, got \"" + c + "\"");
        bs.cases.push_back(c);
      }
      return cli::run_bench(bs);
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "%srelief: error: %s\n", is_tty() ? "\r\033[K" : "", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%srelief: error: out of memory; choose a smaller --size\n", is_tty() ? "\r\033[K" : "");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%srelief: internal error: %s\n", is_tty() ? "\r\033[K" : "", e.what());
    return 1;
  }
  return 0;
}
