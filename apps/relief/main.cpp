// relief: the command-line tool. Argument parsing fills a settings struct; one function per
// command does the work through the library. The library never prints or exits: this file owns
// the terminal, the files and the exit codes (0 ok, 1 internal failure, 2 bad input).
#include <pthread.h>
#include <signal.h>
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <thread>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <iostream>
#include <mutex>
#include <deque>
#include <functional>
#include <map>
#include <tuple>
#include <sstream>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "bench.hpp"
#include "environment.hpp"
#include "relief/export.hpp"
#include "studio.hpp"
#include "relief/explain.hpp"
#include "relief/generate.hpp"
#include "relief/image.hpp"
#include "relief/output.hpp"
#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "relief/steps.hpp"
#include "relief/world.hpp"
#include "relief/world_engine.hpp"

using namespace relief;

namespace {

struct CliGenerate {
  std::string recipe;  // preset name or recipe file
  std::string preset;
  std::string out_dir = "out";
  std::string size;
  std::string formats;
  std::vector<std::string> sets;
  std::string save_recipe;
  std::string steps_dir;  // --steps: one picture per stage and a contact sheet
  std::int64_t seed = -1;
  bool seed_given = false;
  int threads = 0;
  bool quiet = false;
  bool sync = false;  // --sync: fsync every generated file before renaming it into place
  bool keep_stale = false;  // --keep-stale: keep files an earlier run's manifest lists that this run does not write
  // Tilemap shortcuts: they set parameters of the recipe's "tilemap" stage (added when missing).
  std::string tile_size;  // --tile-size N
  std::string map_tiles;  // --map-tiles N or NxM
  // Writer options as given on the command line (table name → text), parsed by the option table.
  std::map<std::string, std::string> export_text;
  std::map<std::string, bool> export_flags;
  std::vector<std::string> export_given;  // table names of the options that were given
};

// CLI flag of a writer option: "stl_size_mm" → "--stl-size-mm".
std::string option_flag(const std::string& name) {
  std::string f = "--" + name;
  std::replace(f.begin(), f.end(), '_', '-');
  return f;
}

// Writer options: the recipe's "export" block (`base`), then the command line's flags over it,
// validated (errors name the flag).
ExportOptions parse_export_options(const CliGenerate& s, ExportOptions o) {
  for (const std::string& name : s.export_given) {
    json v;
    if (auto it = s.export_flags.find(name); it != s.export_flags.end()) {
      v = it->second;
    } else {
      // Text options take the text as given ("4x4"); others read it as JSON when it parses.
      const std::string& text = s.export_text.at(name);
      bool is_text = false;
      for (auto& f : export_options_table().fields) is_text = is_text || (f.info.name == name && f.info.type == ParamType::Text);
      try {
        check_json_depth(text, "the value", option_flag(name));
        v = is_text ? json(text) : json::parse(text);
      } catch (const json::exception&) {
        v = text;
      }
    }
    set_export_option(o, name, v, option_flag(name));
  }
  validate_export_options(o, option_flag);
  return o;
}

bool is_tty() { return isatty(fileno(stderr)) != 0; }

// Progress on a terminal only: one rewritten line on stderr.
struct Progress {
  bool on = false;
  int last_pct = -1;
  std::string last_what;
  // Redraws the line only when what it says changes (long stages report after every step).
  void operator()(std::string_view what, double f) {
    if (!on) return;
    const int pct = int(std::lround(f * 100));
    if (pct == last_pct && what == last_what) return;
    last_pct = pct;
    last_what = std::string(what);
    std::fprintf(stderr, "\r\033[K[%3d%%] %.*s", pct, int(what.size()), what.data());
    std::fflush(stderr);
  }
  // Clears the line (before other output, and at the end); the next call draws it again.
  void done() {
    if (on) std::fprintf(stderr, "\r\033[K");
    last_pct = -1;
  }
};

json read_recipe_doc(const CliGenerate& s) {
  std::string src = !s.preset.empty() ? s.preset : s.recipe.empty() ? "island" : s.recipe;
  const bool file_like = s.preset.empty() && !s.recipe.empty() &&
                         (src.find('/') != std::string::npos || src.ends_with(".json") || std::filesystem::exists(src));
  if (!file_like) return load_preset(src, cli::env_preset_dirs());
  return read_recipe_file(src);  // its file names resolve against its folder
}

void parse_size(const std::string& text, json& doc) {
  const std::string expect = "expected N or NxM with " + std::to_string(kMinSize) + ".." + std::to_string(kMaxSize) + " samples per axis";
  auto num = [&](const std::string& t) -> long long {
    if (t.empty() || t.size() > 6 || t.find_first_not_of("0123456789") != std::string::npos)
      throw Error("--size", expect + ", got " + quote(text));
    return std::stoll(t);
  };
  auto x = text.find_first_of("xX");
  long long nx = num(text.substr(0, x)), nz = x == std::string::npos ? nx : num(text.substr(x + 1));
  if (nx < kMinSize || nz < kMinSize || nx > kMaxSize || nz > kMaxSize) throw Error("--size", expect + ", got " + quote(text));
  if (!doc.contains("world") || !doc["world"].is_object()) doc["world"] = json::object();
  doc["world"]["size"] = json::array({nx, nz});
}

bool formats_name(const std::string& formats, const std::string& name) {
  std::stringstream ss(formats);
  std::string item;
  while (std::getline(ss, item, ','))
    if (item == name) return true;
  return false;
}

// --formats tilemap, --tile-size and --map-tiles: make sure the recipe has a "tilemap" stage and
// write the flags into it, so that the stage's parameter table validates them. Returns the
// stage's path ("stages[N]"), or "" when no tilemap is wanted.
std::string apply_tilemap_shortcuts(const CliGenerate& s, const std::string& formats, json& doc) {
  const bool flags = !s.tile_size.empty() || !s.map_tiles.empty();
  if (!flags && !formats_name(formats, "tilemap") && !formats_name(formats, "all")) return "";
  if (!doc.contains("stages") || !doc["stages"].is_array()) return "";  // parse_recipe reports it
  json& st = doc["stages"];
  std::size_t at = st.size();
  for (std::size_t i = 0; i < st.size(); ++i)
    if (st[i].is_object() && st[i].value("stage", json()) == "tilemap") at = i;
  if (at == st.size()) st.push_back({{"stage", "tilemap"}});
  json& stage = st[at];
  auto number = [](const std::string& t, const std::string& flag, const std::string& text, const char* expect) {
    if (t.empty() || t.size() > 9 || t.find_first_not_of("0123456789") != std::string::npos)
      throw Error(flag, std::string("expected ") + expect + ", got " + quote(text));
    return std::stoll(t);
  };
  if (!s.tile_size.empty()) stage["tile_size"] = number(s.tile_size, "--tile-size", s.tile_size, "a tile size in pixels (e.g. 32)");
  if (!s.map_tiles.empty()) {
    const auto x = s.map_tiles.find_first_of("xX");
    const char* expect = "N or NxM tiles (e.g. 128x128)";
    const long long w = number(s.map_tiles.substr(0, x), "--map-tiles", s.map_tiles, expect);
    const long long h = x == std::string::npos ? w : number(s.map_tiles.substr(x + 1), "--map-tiles", s.map_tiles, expect);
    stage["tiles_x"] = w;
    stage["tiles_z"] = h;
  }
  return "stages[" + std::to_string(at) + "]";
}

// ---- interruption (SIGINT, SIGTERM) ------------------------------------------------------------
// The signals are blocked in every thread and taken by one thread with sigwait(), so nothing runs in
// a signal handler. That thread asks the run to stop (GenerateSettings::cancelled, checked between
// stages and writers); the run then unwinds, its outputs remove their temporary files, and main()
// exits 130 (SIGINT) or 143 (SIGTERM) with a message. A stage that runs on for more than 2 s is not
// waited for: the thread removes this process's temporary files itself (never during a commit's
// renames) and exits with the same code. Either way no file of the output changes. A signal that
// comes once `generate`'s commit has begun replacing files is too late: the run finishes (exit 0).
std::atomic<int> g_signal{0};
std::atomic<bool> g_finished{false};
// How a command's outputs meet an interruption, given to take_interrupts().
struct InterruptPolicy {
  // Whether the command commits its files once (generate; a world commits tile by tile).
  bool one_commit = true;
  // What the 2 s fallback says was kept: `relief world` keeps its finished tiles (a rerun resumes).
  const char* outcome = "no file was changed";
};

const char* signal_name(int sig) { return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a signal"; }

sigset_t interrupt_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

// The signals are blocked from the process's first moments, before main() and before any thread
// (a slow start, e.g. a sanitizer build under load, takes long enough for a Ctrl-C to land there):
// a signal that arrives before `generate` starts its sigwait thread waits for it instead of ending
// the process without a message. Other commands unblock them (unblock_interrupts).
__attribute__((constructor(101))) void block_interrupts_early() {
  const sigset_t set = interrupt_signals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
}

void unblock_interrupts() {
  const sigset_t set = interrupt_signals();
  pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
}

void take_interrupts(const InterruptPolicy policy = {}) {
  const sigset_t set = interrupt_signals();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);  // still blocked since block_interrupts_early; threads inherit it
  std::thread([set, policy] {
    int sig = 0;
    if (sigwait(&set, &sig) != 0) return;
    g_signal = sig;
    for (int k = 0; k < 200 && !g_finished; ++k) ::usleep(10000);
    const char* clear = isatty(fileno(stderr)) ? "\r\033[K" : "";
    for (;;) {
      if (g_finished) return;
      // `generate` commits once: once that commit has begun replacing files, the run ends as if
      // no signal had come (exit 0), since 130/143 promise that no file was changed.
      if (policy.one_commit && commits_published() > 0) {
        dprintf(2, "%srelief: %s came while the new files were being put in place; the run finishes\n", clear, signal_name(sig));
        return;
      }
      if (remove_live_temporaries()) break;
      ::usleep(10000);  // a commit's renames are under way (a world's tile): they finish first
    }
    dprintf(2, "%srelief: interrupted by %s; %s\n", clear, signal_name(sig), policy.outcome);
    ::_exit(128 + sig);
  }).detach();
}

// Runs `f`; an output error it throws (Error("output", …): the file's place cannot be written) is
// rethrown under `flag`, the option that chose that place (--steps, --save-recipe).
template <class F>
auto as_flag(const char* flag, F&& f) {
  try {
    return f();
  } catch (const Error& e) {
    if (e.path() != "output") throw;
    throw Error(flag, e.message());
  }
}

// The files the previous run into `dir` wrote, from its report.json's manifest ("files"): plain
// names only (no folders, no "..", no hidden files); [] when there is no readable manifest.
std::vector<std::string> previous_manifest(const std::string& dir) {
  std::vector<std::string> names;
  std::ifstream in(std::filesystem::path(dir) / "report.json", std::ios::binary);
  if (!in) return names;
  std::stringstream ss;
  ss << in.rdbuf();
  const json doc = json::parse(ss.str(), nullptr, false);
  if (!doc.is_object() || !doc.contains("files") || !doc["files"].is_array()) return names;
  for (const json& f : doc["files"]) {
    if (!f.is_string()) continue;
    const std::string n = f.get<std::string>();
    if (n.empty() || n[0] == '.' || n.find('/') != std::string::npos || n.find('\0') != std::string::npos) continue;
    names.push_back(n);
  }
  return names;
}

int cmd_generate(const CliGenerate& s) {
  const auto t_start = std::chrono::steady_clock::now();
  json doc = read_recipe_doc(s);
  if (!doc.is_object()) throw Error("recipe", "expected a JSON object, got " + describe(doc));
  if (!s.size.empty()) parse_size(s.size, doc);
  if (s.seed_given) {
    if (s.seed < 0 || std::uint64_t(s.seed) > kMaxSeed)
      throw Error("--seed", "expected an integer in 0..9007199254740991, got " + std::to_string(s.seed));
    doc["seed"] = s.seed;
  }
  // --formats, else the recipe's "export.formats" ("default" = the default set).
  auto recipe_formats = [&doc]() -> std::string {
    if (!doc.contains("export") || !doc["export"].is_object() || !doc["export"].contains("formats")) return "";
    const json& f = doc["export"]["formats"];
    return f.is_string() && f != "default" ? f.get<std::string>() : "";
  };
  const std::string tilemap_stage = apply_tilemap_shortcuts(s, s.formats.empty() ? recipe_formats() : s.formats, doc);
  for (auto& a : s.sets) apply_override(doc, a);
  std::optional<ExportSettings> from_recipe;
  if (doc.contains("export")) from_recipe = parse_export_settings(doc["export"], "export");
  const ExportOptions export_options = parse_export_options(s, from_recipe ? from_recipe->options : ExportOptions{});
  std::string formats = !s.formats.empty() ? s.formats : from_recipe ? from_recipe->formats : "";
  if (formats == "default") formats.clear();
  const bool engine = export_options.engine != Engine::None;
  if (engine && s.size.empty()) {
    // Pick the engine's legal size nearest to the recipe's (square tiles that share a border sample,
    // or abut for Unreal: engine_tile_overlap, world_engine.hpp).
    Recipe probe = parse_recipe(doc);
    const int ov = engine_tile_overlap(export_options.engine);
    const int n = engine_legal_size(export_options.engine, probe.world.nx, export_options.split_x());
    const int tile = (n - ov) / export_options.split_x() + ov;
    const int nz = export_options.split_z() * (tile - ov) + ov;
    if (n != probe.world.nx || nz != probe.world.nz) {
      parse_size(std::to_string(n) + "x" + std::to_string(nz), doc);
      if (!s.quiet) std::fprintf(stderr, "relief: %s: using --size %dx%d (legal for the engine)\n", to_string(export_options.engine).c_str(), n, nz);
    }
  }
  Recipe recipe;
  try {
    recipe = parse_recipe(doc);
  } catch (const Error& e) {
    // A bad value that came from a tilemap flag: name the flag as well as the field.
    const std::string& p = e.path();
    const std::string field = tilemap_stage.empty() || p.rfind(tilemap_stage + ".", 0) != 0 ? "" : p.substr(tilemap_stage.size() + 1);
    const char* flag = field == "tile_size" && !s.tile_size.empty() ? "--tile-size"
                       : (field == "tiles_x" || field == "tiles_z") && !s.map_tiles.empty() ? "--map-tiles"
                                                                                            : nullptr;
    if (flag) throw Error(std::string(flag) + " (" + p + ")", e.message());
    throw;
  }

  // Everything else — which writers, engine legality, memory, running, encoding, the report and
  // the one commit of every file — is relief::generate's (relief/generate.hpp).
  relief::GenerateSettings g;
  g.recipe = std::move(recipe);
  // The tilemap flags imply the tilemap writer, on top of whatever set was asked for.
  std::string fmt = formats;
  if (!tilemap_stage.empty() && !formats_name(fmt, "tilemap") && !formats_name(fmt, "all"))
    fmt = (fmt.empty() ? "default" : fmt) + ",tilemap";
  g.formats = fmt;
  g.formats_path = s.formats.empty() ? "export.formats" : "--formats";
  g.options = export_options;
  // Writer errors about an option name it as the user gave it: the recipe's path when only the
  // recipe's "export" block sets it, else the flag.
  g.option_path = [&s, &doc](const std::string& name) {
    const bool flag = std::find(s.export_given.begin(), s.export_given.end(), name) != s.export_given.end();
    const bool in_recipe = doc.contains("export") && doc["export"].is_object() && doc["export"].contains(name);
    return !flag && in_recipe ? "export." + name : option_flag(name);
  };
  g.size_path = "--size";
  g.threads = s.threads;

  // Outputs, checked before any work: generated files are reproducible from report.json (recipe
  // and seed), so by default they are atomic but not flushed (FileOutput::Sync); --save-recipe's
  // file is always flushed. Every file of the run — the output folder, the step pictures, the saved
  // recipe — is part of one commit: a failed run changes none of them.
  const FileOutput::Sync sync = s.sync ? FileOutput::Sync::Durable : FileOutput::Sync::Atomic;
  FileOutput files(s.out_dir, FileOutput::Mode::OnCommit, sync);
  std::unique_ptr<FileOutput> step_files, recipe_file;
  std::string recipe_name;
  if (!s.steps_dir.empty())
    step_files = as_flag("--steps", [&] { return std::make_unique<FileOutput>(s.steps_dir, FileOutput::Mode::OnCommit, sync); });
  if (!s.save_recipe.empty()) {
    namespace fs = std::filesystem;
    const fs::path target(s.save_recipe);
    std::error_code ec;
    if (fs::is_directory(target, ec) || target.filename().empty() || target.filename() == "." || target.filename() == "..")
      throw Error("--save-recipe", "expected a file name, got the folder \"" + s.save_recipe + "\"");
    recipe_name = target.filename().string();
    const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
    // The saved recipe must not replace a file of this run (e.g. --save-recipe out/report.json -o out).
    if (fs::weakly_canonical(dir, ec) == fs::weakly_canonical(fs::path(s.out_dir), ec)) {
      for (const GeneratedFile& f : plan(g).files)
        if (f.name == recipe_name)
          throw Error("--save-recipe", "\"" + s.save_recipe + "\" is a file this run writes (" + f.writer + "); choose another name");
    }
    recipe_file = as_flag("--save-recipe", [&] {
      return std::make_unique<FileOutput>(dir.string(), FileOutput::Mode::OnCommit, FileOutput::Sync::Durable);
    });
  }

  Progress prog{is_tty() && !s.quiet};
  g.progress = [&](std::string_view what, double f) { prog(what, f); };
  g.cancelled = [] { return g_signal.load() != 0; };
  const std::vector<std::string> previous = s.keep_stale ? std::vector<std::string>{} : previous_manifest(s.out_dir);
  std::vector<StepImage> steps;
  if (step_files)
    g.after_stage = [&](const Terrain& t, const RecipeStage& st, int index) {
      StepImage im = render_step(t, 512);
      im.file = step_file_name(index, st.def->name);
      im.caption = std::to_string(index + 1) + ". " + st.def->name + (st.label.empty() ? "" : " \u2014 " + st.label);
      steps.push_back(std::move(im));
    };
  bool seed_printed = false;
  auto print_seed = [&](std::uint64_t seed) {
    if (seed_printed || s.quiet) return;
    seed_printed = true;
    prog.done();  // the seed line gets a line of its own
    std::printf("seed %llu (reproduce with --seed %llu)\n", (unsigned long long)seed, (unsigned long long)seed);
  };
  if (!g.recipe.seed && !s.quiet) std::fprintf(stderr, "relief: no seed given; using a random one\n");
  g.before_commit = [&](const Terrain&, const Recipe& resolved) {
    print_seed(*resolved.seed);
    // Errors of these files name the flag that chose their place.
    if (step_files)
      as_flag("--steps", [&] {
        for (auto& im : steps) step_files->put(im.file, encode_step_png(im));
        step_files->put("steps.png", contact_sheet_png(steps, resolved.name + " \u2014 seed " + std::to_string(*resolved.seed) + ", " +
                                                                  std::to_string(resolved.world.nx) + "x" +
                                                                  std::to_string(resolved.world.nz) + ", step by step",
                                                              4, 256, cli::env_caption_font()));
      });
    if (recipe_file) as_flag("--save-recipe", [&] { recipe_file->put(recipe_name, resolved.to_json().dump(2) + "\n"); });
  };
  if (step_files) g.also_commit.push_back(step_files.get());
  if (recipe_file) g.also_commit.push_back(recipe_file.get());

  const GenerateReport rep = generate(std::move(g), files);
  prog.done();
  // Stale files: those the previous run's manifest lists and this run did not write (only those;
  // never anything else in the folder). The new manifest is in place, so an interruption here
  // leaves at worst a stale file that the next run removes.
  std::vector<std::string> stale;
  for (const std::string& n : previous) {
    if (std::any_of(rep.files.begin(), rep.files.end(), [&](const GeneratedFile& f) { return f.name == n; })) continue;
    const std::filesystem::path p = std::filesystem::path(s.out_dir) / n;
    std::error_code ec;
    if (std::filesystem::is_regular_file(std::filesystem::symlink_status(p, ec)) && std::filesystem::remove(p, ec)) stale.push_back(n);
  }
  if (!s.quiet) {
    for (auto& p : files.written()) std::printf("wrote %s (%s)\n", p.c_str(), human_bytes(std::filesystem::file_size(p)).c_str());
    if (step_files) std::printf("wrote %zu stage pictures and steps.png into %s\n", steps.size(), s.steps_dir.c_str());
    if (!s.save_recipe.empty()) std::printf("wrote %s (resolved recipe)\n", s.save_recipe.c_str());
    if (!stale.empty()) {
      std::string list;
      for (auto& n : stale) list += (list.empty() ? "" : ", ") + n;
      std::printf("removed %zu file%s of the previous run that this run does not write: %s (--keep-stale keeps them)\n",
                  stale.size(), stale.size() == 1 ? "" : "s", list.c_str());
    }
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("%s %dx%d in %.2f s (generate %.0f ms), peak memory %s\n", rep.recipe.name.c_str(), rep.recipe.world.nx,
                rep.recipe.world.nz, total, rep.generate_ms, human_bytes(peak_rss_bytes()).c_str());
  }
  return 0;
}

// ---- relief world -------------------------------------------------------------------------------
struct CliWorld {
  CliGenerate recipe;  // recipe, preset, seed, sets, threads, quiet (read as `generate` reads them)
  std::string size;    // N or NxM, up to kMaxWorldSize
  int tile = 257;
  bool force = false;
  bool mpi = false;  // --mpi: a distributed build (implied under mpirun)
  // Engine tile set and LOD pyramid written from the finished store (relief/world_engine.hpp).
  std::string engine, split, godot_format;
  bool lod = false;
  bool dry_run = false;  // --dry-run: the checks and estimates, nothing written
};

// --size for a world: N or NxM with kMinSize..kMaxWorldSize samples per axis.
std::pair<std::int64_t, std::int64_t> parse_world_size(const std::string& text) {
  const std::string expect = "expected N or NxM with " + std::to_string(kMinSize) + ".." + std::to_string(kMaxWorldSize) +
                             " samples per axis";
  auto num = [&](const std::string& t) -> std::int64_t {
    if (t.empty() || t.size() > 8 || t.find_first_not_of("0123456789") != std::string::npos)
      throw Error("--size", expect + ", got " + quote(text));
    return std::stoll(t);
  };
  const auto x = text.find_first_of("xX");
  const std::int64_t nx = num(text.substr(0, x)), nz = x == std::string::npos ? nx : num(text.substr(x + 1));
  if (nx < kMinSize || nz < kMinSize || nx > kMaxWorldSize || nz > kMaxWorldSize) throw Error("--size", expect + ", got " + quote(text));
  return {nx, nz};
}

// Distributed world builds (MPI): under Open MPI's mpirun (it sets OMPI_COMM_WORLD_SIZE and
// OMPI_COMM_WORLD_RANK in every rank's environment) or with --mpi. The MPI transport is the relief_mpi
// module next to this binary, loaded by build_world with dlopen ($RELIEF_MPI_MODULE names another
// file), so that relief itself needs no MPI at run time.
int world_mpi_rank() {
  const char* r = std::getenv("OMPI_COMM_WORLD_RANK");
  return r && *r ? std::atoi(r) : 0;
}
std::string world_mpi_module() {
  if (const char* p = std::getenv("RELIEF_MPI_MODULE"); p && *p) return p;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string("relief_mpi.so") : (exe.parent_path() / "relief_mpi.so").string();
}

int cmd_world(const CliWorld& w) {
  const CliGenerate& s = w.recipe;
  const auto t_start = std::chrono::steady_clock::now();
  json doc = read_recipe_doc(s);
  if (!doc.is_object()) throw Error("recipe", "expected a JSON object, got " + describe(doc));
  if (s.seed_given) {
    if (s.seed < 0 || std::uint64_t(s.seed) > kMaxSeed)
      throw Error("--seed", "expected an integer in 0..9007199254740991, got " + std::to_string(s.seed));
    doc["seed"] = s.seed;
  }
  for (auto& a : s.sets) apply_override(doc, a);
  WorldSettings ws;
  ws.recipe = parse_recipe(doc);
  if (!w.size.empty()) std::tie(ws.nx, ws.nz) = parse_world_size(w.size);
  ws.tile = w.tile;
  ws.out_dir = s.out_dir;
  ws.threads = s.threads;
  ws.force = w.force;
  ws.size_path = "--size";
  ws.tile_path = "--tile";
  ws.out_path = "--out";
  ws.force_name = "--force";
  ws.dry_run = w.dry_run;
  if (w.mpi || std::getenv("OMPI_COMM_WORLD_SIZE")) {
    ws.mpi_module = world_mpi_module();
    ws.mpi_path = "--mpi";
  }
  const bool seed_given = ws.recipe.seed.has_value();
  // The engine tile set's options, checked against the world's size before any tile is built.
  ExportOptions engine_options;
  if (!w.engine.empty()) set_export_option(engine_options, "engine", w.engine, "--engine");
  if (!w.split.empty()) set_export_option(engine_options, "split", w.split, "--split");
  if (!w.godot_format.empty()) set_export_option(engine_options, "godot_format", w.godot_format, "--godot-format");
  check_world_export(engine_options, ws.nx ? ws.nx : ws.recipe.world.nx, ws.nz ? ws.nz : ws.recipe.world.nz, cli_flag_path, "--size");
  Progress prog{is_tty() && !s.quiet && world_mpi_rank() == 0};
  ws.progress = [&](const WorldProgress& p) {
    char line[256];
    char left[48] = "";
    if (p.seconds_left >= 0) std::snprintf(left, sizeof left, ", %.0f s left", p.seconds_left);
    char stage[96] = "";
    if (!p.stage_name.empty() && p.phase_fraction >= 0)  // a global stage running over the stored tiles
      std::snprintf(stage, sizeof stage, ", stage %d/%d %.*s %d%%", p.stage + 1, p.stages, int(p.stage_name.size()), p.stage_name.data(),
                    int(p.phase_fraction * 100));
    else if (!p.stage_name.empty())
      std::snprintf(stage, sizeof stage, ", stage %d/%d %.*s", p.stage + 1, p.stages, int(p.stage_name.size()), p.stage_name.data());
    std::snprintf(line, sizeof line, "tiles %lld/%lld%s%s%s", (long long)p.tiles_done, (long long)p.tiles_total,
                  p.tiles_skipped ? (" (" + std::to_string(p.tiles_skipped) + " resumed)").c_str() : "", stage, left);
    prog(line, p.fraction);
  };
  ws.cancelled = [] { return g_signal.load() != 0; };
  WorldReport rep;
  try {
    rep = build_world(std::move(ws));
  } catch (const Cancelled&) {
    prog.done();
    g_finished = true;
    const int sig = g_signal.load();
    if (world_mpi_rank() != 0) return sig ? 128 + sig : 1;  // rank 0 says it
    std::fprintf(stderr, "relief: interrupted by %s; the finished tiles are kept: run the same command again to resume\n",
                 signal_name(sig));
    return sig ? 128 + sig : 1;
  }
  prog.done();
  if (rep.rank != 0) return 0;  // rank 0 prints, and writes what comes after the store
  if (rep.dry_run) {  // printed even with -q: it is the answer
    std::string layers;
    for (const auto& [name, c] : rep.layers) layers += (layers.empty() ? "" : ", ") + name + (c > 1 ? " (" + std::to_string(c) + ")" : "");
    std::printf("world %lldx%lld in %lldx%lld tiles of %d (%lld tiles); layers: %s\n", (long long)rep.grid.nx, (long long)rep.grid.nz,
                (long long)rep.grid.tiles_x, (long long)rep.grid.tiles_z, rep.grid.tile, (long long)rep.grid.count(), layers.c_str());
    std::printf("disk: about %s needed at most (the finished store about %s; estimated from coded sample windows with a margin "
                "of 2), %s free in %s\n",
                human_bytes(rep.estimated_bytes).c_str(), human_bytes(rep.estimated_store_bytes).c_str(),
                rep.disk_free_bytes == UINT64_MAX ? "unknown" : human_bytes(rep.disk_free_bytes).c_str(), s.out_dir.c_str());
    if (rep.memory_stage.empty())
      std::printf("memory: about %s for %d tile%s built at once\n", human_bytes(rep.tile_memory_bytes).c_str(), rep.tiles_at_once,
                  rep.tiles_at_once == 1 ? "" : "s");
    else
      std::printf("memory: about %s in the %s phase (its world algorithm and a tile; %d tile%s built at once elsewhere)\n",
                  human_bytes(rep.tile_memory_bytes).c_str(), rep.memory_stage.c_str(), rep.tiles_at_once, rep.tiles_at_once == 1 ? "" : "s");
    std::printf("seed %llu%s; nothing was written (--dry-run)\n", (unsigned long long)rep.seed,
                seed_given ? "" : rep.seed_reused ? " (the world in the folder's)" : " (random: a build draws its own)");
    return 0;
  }
  if (!s.quiet) {
    if (!seed_given)
      std::printf("seed %llu (%s; reproduce with --seed %llu)\n", (unsigned long long)rep.seed,
                  rep.seed_reused ? "the seed of the world in the folder" : "random", (unsigned long long)rep.seed);
    // The world files beside the tiles: the flow stage's rivers and lakes when the recipe has one.
    std::string files = "world.json, overview.png, report.json";
    for (const auto& st : rep.recipe.value("stages", json::array()))
      if (st.value("stage", "") == "flow") files += ", rivers.json, lakes.json";
    for (const std::string& f : rep.point_files) files += ", " + f;
    std::printf("world %lldx%lld in %lldx%lld tiles of %d: %lld built, %lld resumed; %s in %s (%s)\n", (long long)rep.grid.nx,
                (long long)rep.grid.nz, (long long)rep.grid.tiles_x, (long long)rep.grid.tiles_z, rep.grid.tile,
                (long long)rep.tiles_built, (long long)rep.tiles_skipped, human_bytes(rep.store_bytes).c_str(), s.out_dir.c_str(),
                files.c_str());
  }
  if (engine_options.engine != Engine::None || w.lod) {
    WorldExportSettings es;
    es.store_dir = s.out_dir;
    es.options = engine_options;
    es.lod = w.lod;
    es.option_path = cli_flag_path;
    es.size_path = "--size";
    es.progress = [&](std::string_view what, double f) { prog(what, f); };
    es.cancelled = [] { return g_signal.load() != 0; };
    WorldExportReport er;
    try {
      er = export_world(es);
    } catch (const Cancelled&) {
      prog.done();
      g_finished = true;
      const int sig = g_signal.load();
      std::fprintf(stderr, "relief: interrupted by %s; the store is complete: run the same command again to write the engine tiles\n",
                   signal_name(sig));
      return sig ? 128 + sig : 1;
    }
    prog.done();
    if (!s.quiet) {
      if (er.engine_tiles)
        std::printf("%s: %d engine tiles in %s/%s\n", to_string(engine_options.engine).c_str(), er.engine_tiles, s.out_dir.c_str(),
                    es.engine_subdir.c_str());
      if (er.lod_levels)
        std::printf("lod: %d levels, %lld tiles in %s/%s\n", er.lod_levels, (long long)er.lod_tiles, s.out_dir.c_str(), es.lod_subdir.c_str());
    }
  }
  if (!s.quiet) {
    const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("%.2f s, peak memory %s\n", total, human_bytes(peak_rss_bytes()).c_str());
  }
  return 0;
}

// `relief world` on one rank of a distributed build: ranks other than 0 print no error, since rank 0
// reports the same one (every rank reads the same input, and build_world throws any rank's failure
// on every rank) — except when MPI itself did not start on that rank (--mpi errors). They exit with
// status 0 then: a rank that exits non-zero first makes mpirun stop the others, which could cut
// rank 0 short before it prints; mpirun's own status is rank 0's (2).
int cmd_world_rank(const CliWorld& w) {
  if (world_mpi_rank() == 0) return cmd_world(w);
  try {
    return cmd_world(w);
  } catch (const Error& e) {
    if (e.path() == "--mpi") throw;
    g_finished = true;
    return 0;
  } catch (const Cancelled&) {
    g_finished = true;
    const int sig = g_signal.load();
    return sig ? 128 + sig : 1;
  } catch (const std::exception&) {
    g_finished = true;
    return 1;
  }
}

int cmd_presets(bool as_json) {
  auto list = list_presets(cli::env_preset_dirs());
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

// A parameter's accepted values: "8|16", "0..1", "a|b|c" ("" for other types).
std::string param_range(const ParamInfo& p) {
  std::string range;
  if ((p.type == ParamType::Int || p.type == ParamType::Float) && !p.values.empty()) {
    for (double v : p.values) {
      std::ostringstream o;
      o << v;
      range += (range.empty() ? "" : "|") + o.str();
    }
  } else if (p.type == ParamType::Int || p.type == ParamType::Float) {
    std::ostringstream o;
    o << p.min << ".." << p.max;
    range = o.str();
  } else if (p.type == ParamType::Choice) {
    for (auto& c : p.choices) range += (range.empty() ? "" : "|") + c;
  }
  return range;
}

// `text` broken at spaces, commas and '|' into lines of at most `width` characters.
std::vector<std::string> wrap(const std::string& text, std::size_t width) {
  std::vector<std::string> lines;
  std::string line;
  std::size_t last_break = std::string::npos;
  for (char c : text) {
    line.push_back(c);
    if (c == ' ' || c == ',' || c == '|') last_break = line.size();
    if (line.size() > width && last_break != std::string::npos && last_break < line.size()) {
      lines.push_back(line.substr(0, last_break));
      line = line.substr(last_break);
      last_break = std::string::npos;
    }
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

// The text table of `relief explain`: one line per parameter. Defaults and ranges that do not fit
// their columns are never cut: they go on lines of their own below, wrapped whole.
void print_params(const std::vector<ParamInfo>& ps, int indent = 4) {
  for (auto& p : ps) {
    const std::string range = param_range(p);
    const std::string def = p.default_value.dump(-1, ' ', false, json::error_handler_t::replace);
    const bool long_def = def.size() > 12, long_range = range.size() > 22;
    std::printf("%*s%-16s %-7s default %-12s %-22s %s%s%s\n", indent, "", p.name.c_str(), to_string(p.type),
                long_def ? "(below)" : def.c_str(), long_range ? "(below)" : range.c_str(), p.description.c_str(),
                p.unit.empty() ? "" : (" [" + p.unit + "]").c_str(), p.effect == Effect::Recolour ? " (recolour)" : "");
    for (auto [label, text, on] : {std::tuple{"default: ", def, long_def}, std::tuple{"values: ", range, long_range}}) {
      if (!on) continue;
      const auto lines = wrap(text, 96);
      for (std::size_t k = 0; k < lines.size(); ++k)
        std::printf("%*s%s%s\n", indent + 4, "", k == 0 ? label : "         ", lines[k].c_str());
    }
    if (!p.fields.empty()) print_params(p.fields, indent + 4);  // a list's records: one line per field
  }
}

// What the stage guarantees in `relief world` builds (world.hpp, world_guarantee), one wrapped line.
void print_world_guarantee(const StageDef& d, int indent = 4) {
  const WorldGuarantee g = world_guarantee(d);
  auto lines = wrap("world builds: " + g.guarantee + " — " + g.how, 100);
  for (std::string& l : lines)  // prose: no trailing space where it was broken (defaults keep theirs)
    while (l.size() > 1 && l.back() == ' ') l.pop_back();
  for (std::size_t k = 0; k < lines.size(); ++k) std::printf("%*s%s%s\n", indent, "", k == 0 ? "" : "  ", lines[k].c_str());
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
      throw Error("stage", "unknown stage " + quote(stage) + (near.empty() ? "" : " (did you mean '" + near + "'?)"));
    }
    std::printf("%s: %s\n", d->name.c_str(), d->summary.c_str());
    print_world_guarantee(*d);
    print_params(d->params);
    return 0;
  }
  std::printf("world:\n");
  print_params(world_params());
  std::printf("\nstages (use `relief explain STAGE` for one):\n");
  for (auto& d : stage_registry()) {
    std::printf("  %s: %s\n", d.name.c_str(), d.summary.c_str());
    print_world_guarantee(d, 4);
    print_params(d.params);
  }
  std::printf("\nformats (--formats a,b,c):\n");
  for (auto& w : writer_registry()) {
    std::string files;
    for (auto& f : w.files) files += (files.empty() ? "" : ", ") + f;
    std::printf("  %-10s %s -> %s%s\n", w.name.c_str(), w.description.c_str(), files.c_str(), w.in_default_set ? "" : " (not default)");
  }
  std::printf("\nwriter options (relief generate --NAME VALUE):\n");
  auto infos = export_options_table().infos();
  for (auto& p : infos) p.name = option_flag(p.name);
  print_params(infos);
  return 0;
}

// Checks of generate's flags among themselves, before anything is read (the lead's
// relief::generate can take them over): one recipe, not two.
void check_generate_flags(const CliGenerate& s) {
  if (!s.preset.empty() && !s.recipe.empty())
    throw Error("--preset", "two recipes given, " + quote(s.recipe) + " and --preset " + quote(s.preset) + "; give one");
}

// ---- command-line values ------------------------------------------------------------------------
// Numbers on the command line are read here, not by CLI11, so that every error has the one form
// `relief: error: FLAG: expected …, got "WHAT WAS TYPED"`: decimal digits only (`010` is ten, not
// octal; `0x10`, `1.5`, `""` and `+1` are errors), and the range is checked on the text, so
// 18446744073709551616 is quoted as typed rather than wrapped or saturated.
std::int64_t read_int_flag(const std::string& text, const std::string& flag, std::int64_t lo, std::int64_t hi,
                           const char* note = nullptr) {
  const std::string expect = "expected an integer in " + std::to_string(lo) + ".." + std::to_string(hi) +
                             (note ? std::string(" (") + note + ")" : std::string());
  const bool neg = !text.empty() && text[0] == '-';
  const std::string digits = text.substr(neg ? 1 : 0);
  if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos)
    throw Error(flag, expect + ", got " + quote(text));
  const std::size_t first = std::min(digits.find_first_not_of('0'), digits.size());
  if (digits.size() - first > 18) throw Error(flag, expect + ", got " + quote(text));
  const std::int64_t v = (neg ? -1 : 1) * std::int64_t(std::stoull(digits.substr(first).empty() ? "0" : digits.substr(first)));
  if (v < lo || v > hi) throw Error(flag, expect + ", got " + quote(text));
  return v;
}

// Integer flags of every command: registered as text, read by read_int_flag after parsing.
struct IntFlags {
  struct Entry {
    CLI::Option* opt = nullptr;
    std::string flag, text;
    std::int64_t lo = 0, hi = 0;
    std::function<void(std::int64_t)> set;
  };
  std::deque<Entry> entries;  // stable addresses: CLI11 keeps a pointer to each text
  template <class T>
  CLI::Option* add(CLI::App* cmd, const std::string& names, T& target, std::int64_t lo, std::int64_t hi,
                   const std::string& help, bool show_default = true) {
    Entry& e = entries.emplace_back();
    e.flag = names.substr(0, names.find(','));
    e.lo = lo, e.hi = hi;
    e.set = [&target](std::int64_t v) { target = T(v); };
    e.opt = cmd->add_option(names, e.text, help + " [" + std::to_string(lo) + ".." + std::to_string(hi) + "]");
    if (show_default) e.opt->default_str(std::to_string(target));
    e.opt->type_name("INT");
    return e.opt;
  }
  void read() {
    for (Entry& e : entries)
      if (e.opt->count() > 0) e.set(read_int_flag(e.text, e.flag, e.lo, e.hi));
  }
};

// What a flag's value must be, for the message when it is given empty (`-o ""`).
std::string expected_value(const CLI::Option* o) {
  static const std::map<std::string, std::string> known = {
      {"--out", "an output folder"},
      {"--preset", "a preset name (see `relief presets`)"},
      {"--size", "N or NxM with 2..32769 samples per axis"},
      {"--formats", "comma-separated format names or 'all' (see `relief explain`)"},
      {"--set", "PATH=VALUE (e.g. stages[1].octaves=8)"},
      {"--save-recipe", "a file name"},
      {"--steps", "a folder"},
      {"--host", "a host name or address"},
      {"--json", "a file name"},
      {"recipe", "a preset name or a recipe JSON file"},
      {"stage", "a stage name (see `relief explain`)"},
  };
  const std::string name = o->get_name(false, false).substr(0, o->get_name(false, false).find(','));
  for (auto& [k, v] : known)
    if (o->check_lname(k.substr(2)) || name == k) return v;
  std::string d = o->get_description();
  d = d.substr(0, d.find(" ["));
  return "a value (" + d + ")";
}

// The flag's name as the user can type it: its long name, else its short one, else the positional's.
std::string flag_name(const CLI::Option* o) {
  if (!o->get_lnames().empty()) return "--" + o->get_lnames().front();
  if (!o->get_snames().empty()) return "-" + o->get_snames().front();
  return o->get_name();
}

// An empty value is never a default: `-o ""`, `--size ""`, `--formats ""` are errors.
void refuse_empty_values(CLI::App* cmd) {
  for (const CLI::Option* o : cmd->get_options()) {
    // Flags take no value; integers say what they expect themselves (read_int_flag).
    if (o->count() == 0 || o->get_expected_min() == 0 || o->get_type_name() == "INT") continue;
    for (const std::string& r : o->results())
      if (r.empty()) throw Error(flag_name(o), "expected " + expected_value(o) + ", got an empty value");
  }
}

// CLI11's own parse errors in the one format, naming the flag and what was expected.
std::string parse_error_message(const CLI::ParseError& e, const CLI::App& app) {
  const std::string what = e.what();
  if (dynamic_cast<const CLI::RequiredError*>(&e) && what.find("subcommand") != std::string::npos)
    return "expected a command: generate, world, presets, explain, bench or studio (see relief --help)";
  if (dynamic_cast<const CLI::ExtrasError*>(&e)) {
    std::string extra = what.substr(what.find(':') == std::string::npos ? 0 : what.find(':') + 2);
    std::string cmd;
    for (const CLI::App* sub : app.get_subcommands()) cmd = sub->get_name();
    if (!extra.empty() && extra[0] == '-')
      return (cmd.empty() ? std::string("") : cmd + ": ") + "unknown flag " + quote(extra.substr(0, extra.find(' '))) +
             " (see relief " + cmd + " --help)";
    if (cmd == "generate")
      return "generate: unexpected argument " + quote(extra) + " (give one recipe: a preset name or a JSON file; see relief generate --help)";
    return (cmd.empty() ? std::string("") : cmd + ": ") + "unexpected argument " + quote(extra) + " (see relief " + cmd + " --help)";
  }
  if (dynamic_cast<const CLI::ArgumentMismatch*>(&e)) {
    // "--out: At Most 1 required but received 2" (the flag twice), "--seed: 1 required INT missing".
    const std::string flag = what.substr(0, what.find(':'));
    if (what.find("missing") != std::string::npos) return flag + ": expected a value after the flag";
    if (what.find("At Most") != std::string::npos) return flag + ": given more than once; give it once";
    return what;
  }
  return what + " (see relief --help)";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"relief: procedural terrain generator — heightmaps, textured meshes and maps from a seed and a recipe"};
  app.set_version_flag("--version", std::string("relief ") + RELIEF_VERSION);
  app.require_subcommand(1);

  CliGenerate gs;
  auto* gen = app.add_subcommand("generate", "Generate a terrain from a preset or recipe file and write its files");
  gen->add_option("recipe", gs.recipe, "Preset name or recipe JSON file (default: island)");
  gen->add_option("--preset,-p", gs.preset, "Preset name (see `relief presets`)");
  gen->add_option("-o,--out", gs.out_dir, "Output directory (created if missing)")->capture_default_str();
  std::string seed_text;  // read by read_int_flag: decimal only, quoted as typed in errors
  gen->add_option("--seed,-s", seed_text, "Seed, a decimal integer in 0..2^53-1 (default: the recipe's, else random and printed)")
      ->type_name("INT");
  gen->add_option("--size", gs.size, "Samples per axis: N or NxM (cells stay square; depth follows the aspect)");
  gen->add_option("--formats,-f", gs.formats, "Comma-separated writers replacing the default set, or 'all' (see `relief explain`)");
  gen->add_option("--set", gs.sets, "Override a recipe field: PATH=VALUE, e.g. 'stages[1].octaves=8' (repeatable)");
  IntFlags ints;
  ints.add(gen, "--threads,-j", gs.threads, 0, 1024, "Worker threads (0 = all cores); output is identical for any count", false);
  gen->add_option("--save-recipe", gs.save_recipe, "Write the fully resolved recipe (defaults and seed) to FILE");
  gen->add_option("--steps", gs.steps_dir,
                  "Also write one hillshaded picture per stage (NN-STAGE.png) and a captioned contact sheet steps.png into DIR");
  gen->add_flag("--quiet,-q", gs.quiet, "Print nothing but errors");
  gen->add_flag("--keep-stale", gs.keep_stale,
                "Keep the files an earlier run into the output folder wrote (its report.json lists them) that this run "
                "does not write; by default they are removed, so the folder holds one run's files");
  gen->add_flag("--sync", gs.sync,
                "Flush every file to disk (fsync) before renaming it into place, so it survives a power cut; without it "
                "each file is still all-old or all-new if the run fails, and the kernel writes it back later");
  gen->add_option("--tile-size", gs.tile_size,
                  "Tilemap: tile size in pixels (16, 32, 64 …); sets the tilemap stage's tile_size and implies --formats tilemap");
  gen->add_option("--map-tiles", gs.map_tiles,
                  "Tilemap: tiles across and down, N or NxM (e.g. 128x128); sets tiles_x/tiles_z of the tilemap stage");
  // Writer options: one flag per entry of the option table (declared once, in export_options.cpp).
  std::vector<std::pair<std::string, CLI::Option*>> export_cli;
  for (const ParamInfo& p : export_options_table().infos()) {
    std::string help = p.description + " [default " + p.default_value.dump();
    if (p.type == ParamType::Int || p.type == ParamType::Float) help += "; " + param_range(p) + (p.unit.empty() ? "" : " " + p.unit);
    else if (p.type == ParamType::Choice) help += "; " + param_range(p);
    help += "]";
    CLI::Option* opt = p.type == ParamType::Bool ? gen->add_flag(option_flag(p.name), gs.export_flags[p.name], help)
                                                 : gen->add_option(option_flag(p.name), gs.export_text[p.name], help);
    export_cli.emplace_back(p.name, opt);
  }

  CliWorld wsx;
  auto* wld = app.add_subcommand("world", "Build a world larger than one map as a tile store (float tiles, world.json, overview.png), resumable");
  wld->add_option("recipe", wsx.recipe.recipe, "Preset name or recipe JSON file (default: island)");
  wld->add_option("--preset,-p", wsx.recipe.preset, "Preset name (see `relief presets`)");
  wsx.recipe.out_dir = "world";
  wld->add_option("-o,--out", wsx.recipe.out_dir, "Output folder of the tile store (created if missing)")->capture_default_str();
  std::string world_seed_text;
  wld->add_option("--seed,-s", world_seed_text,
                  "Seed, a decimal integer in 0..2^53-1 (default: the recipe's, else that of the same world in the folder, else random)")
      ->type_name("INT");
  wld->add_option("--size", wsx.size, "World samples per axis: N or NxM, up to " + std::to_string(kMaxWorldSize) + " (default: the recipe's)");
  ints.add(wld, "--tile,-t", wsx.tile, 0, kMaxWorldTile, "Tile size in samples, 2^n+1 (tiles share their border samples)");
  wld->add_option("--set", wsx.recipe.sets, "Override a recipe field: PATH=VALUE, e.g. 'stages[1].octaves=8' (repeatable)");
  ints.add(wld, "--threads,-j", wsx.recipe.threads, 0, 1024, "Worker threads (0 = all cores); output is identical for any count", false);
  wld->add_flag("--quiet,-q", wsx.recipe.quiet, "Print nothing but errors");
  wld->add_flag("--force", wsx.force,
                "Replace a different world found in the output folder (its world.json, tiles, overview.png and report.json); "
                "without it such a folder is refused");
  wld->add_flag("--mpi", wsx.mpi,
                "Build with MPI, tiles spread over the ranks (implied under mpirun: `mpirun -n P relief world ...`); the "
                "store's bytes are those of a build without MPI");
  wld->add_option("--engine", wsx.engine, "Also write the engine tile set from the store into OUT/engine: unity, unreal or godot "
                                          "(the same files as `relief generate --engine E --split KxM` at this size)");
  wld->add_option("--split", wsx.split, "Engine tiles along x and z, NxM (default 1x1; unity, godot: neighbours share a border sample; "
                                        "unreal: edge to edge)");
  wld->add_option("--godot-format", wsx.godot_format, "Engine godot: exr (32-bit float metres, default) or r16");
  wld->add_flag("--dry-run", wsx.dry_run,
                "Check the input and the folder, print the disk and memory estimates, and build nothing (exit 2 when a "
                "build would be refused)");
  wld->add_flag("--lod", wsx.lod, "Also write a LOD pyramid into OUT/lod: 16-bit PNG height (and RGB colour) tiles, each level "
                                  "every other sample of the one below, up to one tile");

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
  auto* ben = app.add_subcommand("bench", "Measure noise, erosion and whole presets (medians), with libnoise as the peer for noise");
  ints.add(ben, "--runs", bs.runs, 1, 1000, "Timed runs per case (at least 5 for published figures)");
  ints.add(ben, "--noise-size", bs.noise_size, 16, 16384, "Noise cases evaluate size² samples");
  ints.add(ben, "--peer-size", bs.peer_size, 16, 16384, "libnoise cases evaluate size² samples (compared per sample)");
  ben->add_option("--threads", bench_threads, "Comma-separated thread counts")->capture_default_str();
  ben->add_option("--preset-sizes", bench_sizes, "Comma-separated preset sizes")->capture_default_str();
  ints.add(ben, "--erosion-size", bs.erosion_size, 16, 16384, "Droplet, thermal and stream-power cases use size² samples");
  ints.add(ben, "--flood-size", bs.flood_size, 16, 32768, "Priority-Flood + D8 + accumulation case uses size² samples");
  ben->add_option("--cases", bench_cases, "Comma-separated groups: " + cli::bench_group_list() + " (default: all)");
  ben->add_option("--json", bs.json_path, "Also write the results as JSON to FILE");

  cli::StudioSettings ss;
  auto* stu = app.add_subcommand("studio", "Serve Relief Studio: a live 3D preview with sliders, stage playback, walk mode and exports");
  ints.add(stu, "--port", ss.port, 0, 65535, "TCP port (0 = any free port, printed)");
  stu->add_option("--host", ss.host, "Address to listen on (loopback unless you say otherwise)")->capture_default_str();
  stu->add_flag("--open", ss.open, "Open the page in the default browser (xdg-open)");
  ints.add(stu, "--max-preview", ss.max_preview, 2, 8193, "Largest preview size accepted (samples per axis)");
  ints.add(stu, "--max-export", ss.max_export, kMinSize, kMaxSize, "Largest export size accepted (samples per axis)");
  ints.add(stu, "--cache-mib", ss.cache_mib, 16, 1 << 20, "Memory for cached stage outputs, MiB");
  ints.add(stu, "--cache-idle", ss.cache_idle_s, 0, 86400,
           "Seconds without a running request after which spare layer buffers are freed (0 = never)");
  ints.add(stu, "--threads,-j", ss.threads, 0, 1024, "Generation threads (0 = all cores)", false);
  ints.add(stu, "--max-stages", ss.max_stages, 1, 100000, "Most stages a recipe may have (more: a 400 naming `stages`)");
  ints.add(stu, "--time-budget", ss.time_budget_s, 1, 86400,
           "Seconds a generate, steps or export request may run before it is stopped (503)");
  ints.add(stu, "--work-mib", ss.work_mib, 0, 1 << 24,
           "Memory budget, MiB, of the requests running at once, by their estimates; a request that would exceed it "
           "gets 503 and Retry-After (0 = a quarter of physical memory, at most 4096)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "relief: error: %s\n", printable_text(parse_error_message(e, app)).c_str());
    return 2;
  }
  try {
    for (CLI::App* cmd : {gen, wld, pre, exp, ben, stu}) refuse_empty_values(cmd);
    ints.read();
    gs.seed_given = gen->count("--seed") > 0;
    if (gs.seed_given) gs.seed = read_int_flag(seed_text, "--seed", 0, std::int64_t(kMaxSeed), "decimal digits");
    for (auto& [name, opt] : export_cli)
      if (opt->count() > 0) gs.export_given.push_back(name);
    if (*gen) {
      check_generate_flags(gs);
      // More threads than the machine runs make TBB print a warning on the terminal; the
      // output is the same for any count, so the request is capped (report.json says the count used).
      gs.threads = capped_threads(gs.threads);
      take_interrupts();
      const int code = cmd_generate(gs);
      g_finished = true;
      return code;
    }
    if (*wld) {
      wsx.recipe.seed_given = wld->count("--seed") > 0;
      if (wsx.recipe.seed_given) wsx.recipe.seed = read_int_flag(world_seed_text, "--seed", 0, std::int64_t(kMaxSeed), "decimal digits");
      check_generate_flags(wsx.recipe);
      wsx.recipe.threads = capped_threads(wsx.recipe.threads);
      take_interrupts({false, "the finished tiles are kept: run the same command again to resume"});
      const int code = cmd_world_rank(wsx);
      g_finished = true;
      return code;
    }
    unblock_interrupts();  // the other commands end on Ctrl-C as any program does (the studio takes them itself)
    if (*pre) return cmd_presets(presets_json);
    if (*exp) return cmd_explain(explain_stage, explain_json);
    if (*stu) {
      ss.threads = capped_threads(ss.threads);
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
                                   ", got " + quote(text));
          v.push_back(std::stoi(item));
        }
        if (v.empty()) throw Error(field, "expected at least one value");
        return v;
      };
      bs.threads = ints(bench_threads, "--threads", 1, 1024);
      bs.preset_sizes = ints(bench_sizes, "--preset-sizes", kMinSize, kMaxSize);
      std::stringstream ss(bench_cases);
      std::string c;
      while (std::getline(ss, c, ',')) {
        if (!cli::is_bench_group(c)) throw Error("--cases", "expected one of " + cli::bench_group_list() + ", got " + quote(c));
        bs.cases.push_back(c);
      }
      return cli::run_bench(bs);
    }
  } catch (const Cancelled&) {
    g_finished = true;
    const int sig = g_signal.load();
    std::fprintf(stderr, "%srelief: interrupted by %s; no file was changed\n", is_tty() ? "\r\033[K" : "", signal_name(sig));
    return sig ? 128 + sig : 1;
  } catch (const Error& e) {
    g_finished = true;
    std::fprintf(stderr, "%srelief: error: %s\n", is_tty() ? "\r\033[K" : "", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "%srelief: error: out of memory; choose a smaller --size\n", is_tty() ? "\r\033[K" : "");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%srelief: internal error: %s\n", is_tty() ? "\r\033[K" : "", printable_text(e.what()).c_str());
    return 1;
  }
  return 0;
}
