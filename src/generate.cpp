// relief::generate: the writing policy behind every front end (relief/generate.hpp).
#include "relief/generate.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <sstream>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "relief/error.hpp"
#include "relief/params.hpp"

namespace relief {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

bool builds_mesh(const WriterDef& w) { return w.name == "obj" || w.name == "glb" || w.name == "fbx" || w.name == "stl"; }

// Every file a writer put into the Output, by name, as it passes through: the report's file list.
class RecordingOutput final : public Output {
 public:
  RecordingOutput(Output& inner, std::string writer, std::mutex& m, std::vector<GeneratedFile>& files)
      : inner_(inner), writer_(std::move(writer)), m_(m), files_(files) {}
  void put(const std::string& filename, std::string bytes) override {
    record(filename, bytes.size());
    inner_.put(filename, std::move(bytes));
  }
  std::unique_ptr<OutputStream> open(const std::string& filename, std::size_t size_hint) override {
    struct Counting final : OutputStream {
      std::unique_ptr<OutputStream> s;
      RecordingOutput* owner;
      std::string name;
      std::uint64_t n = 0;
      void write(std::string_view b) override {
        n += b.size();
        s->write(b);
      }
      void close() override {
        s->close();
        owner->record(name, n);
      }
    };
    auto c = std::make_unique<Counting>();
    c->s = inner_.open(filename, size_hint);
    c->owner = this;
    c->name = filename;
    return c;
  }
  void record(const std::string& name, std::uint64_t bytes) {
    std::lock_guard<std::mutex> lock(m_);
    files_.push_back({name, writer_, bytes});
  }

 private:
  Output& inner_;
  std::string writer_;
  std::mutex& m_;
  std::vector<GeneratedFile>& files_;
};

}  // namespace

// ---- memory policy ------------------------------------------------------------------------------

std::uint64_t memory_budget_bytes() { return physical_memory_bytes() / 100 * kMemoryBudgetPercent; }

void check_memory(const Recipe& r, bool with_mesh, std::uint64_t budget) {
  if (budget == 0) budget = memory_budget_bytes();
  if (budget == 0) return;  // unknown machine: no refusal
  const std::uint64_t need = estimate_memory_bytes(r, with_mesh);
  if (need <= budget) return;
  throw Error("world.size", "a " + std::to_string(r.world.nx) + "x" + std::to_string(r.world.nz) +
                                " terrain with these formats needs about " + human_bytes(need) + ", but the limit here is " +
                                human_bytes(budget) + "; choose a smaller size" + (with_mesh ? " or leave out the meshes" : ""));
}

// ---- writer selection ---------------------------------------------------------------------------

bool WriterPlan::with_mesh() const {
  return std::any_of(writers.begin(), writers.end(), [](const WriterDef* w) { return builds_mesh(*w); });
}

bool WriterPlan::has(std::string_view name) const {
  return std::any_of(writers.begin(), writers.end(), [&](const WriterDef* w) { return w->name == name; });
}

bool WriterPlan::is_named(const WriterDef* w) const { return std::find(named.begin(), named.end(), w) != named.end(); }

WriterPlan select_writers(const std::string& formats, const ExportOptions& options, const std::string& path) {
  const bool engine = options.engine != Engine::None;
  std::vector<const WriterDef*> chosen;
  WriterPlan plan;
  auto add_set = [&](bool all) {
    for (auto& w : writer_registry())
      if (all ? (w.name != "engine" || engine) : w.in_default_set) chosen.push_back(&w);
  };
  if (formats.empty()) {
    add_set(false);
  } else {
    std::vector<std::string> names;
    for (auto& w : writer_registry()) names.push_back(w.name);
    std::stringstream ss(formats);
    std::string name;
    bool any = false;
    std::vector<const WriterDef*> removed;
    while (std::getline(ss, name, ',')) {
      if (name.empty()) continue;
      any = true;
      const bool remove = name[0] == '-';
      if (remove) name.erase(0, 1);
      if (!remove && (name == "default" || name == "all")) {
        add_set(name == "all");
        continue;
      }
      const WriterDef* w = find_writer(name);
      if (!w) {
        std::string near = nearest_name(name, names), list;
        for (auto& n : names) list += (list.empty() ? "" : ", ") + n;
        throw Error(path, "unknown format \"" + name + "\"" + (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                              "; available: " + list + ", or default, all");
      }
      if (remove) {
        removed.push_back(w);
        continue;
      }
      chosen.push_back(w);
      plan.named.push_back(w);
    }
    if (!any) throw Error(path, "expected at least one format, got \"" + formats + "\"");
    std::erase_if(chosen, [&](const WriterDef* w) { return std::find(removed.begin(), removed.end(), w) != removed.end(); });
    std::erase_if(plan.named, [&](const WriterDef* w) { return std::find(removed.begin(), removed.end(), w) != removed.end(); });
    if (chosen.empty()) throw Error(path, "no format left in \"" + formats + "\"");
  }
  // Implied writers (transitively; named when their chooser was), and the engine files when an
  // engine is chosen.
  for (std::size_t k = 0; k < chosen.size(); ++k)
    for (const std::string& n : chosen[k]->implies)
      if (const WriterDef* w = find_writer(n)) {
        chosen.push_back(w);
        if (plan.is_named(chosen[k])) plan.named.push_back(w);
      }
  if (engine) chosen.push_back(find_writer("engine"));
  // Registry order, once each: the order never depends on how the list was spelt.
  for (auto& w : writer_registry())
    if (std::find(chosen.begin(), chosen.end(), &w) != chosen.end()) plan.writers.push_back(&w);
  return plan;
}

// ---- generate -----------------------------------------------------------------------------------

GeneratePlan plan(const GenerateSettings& s) {
  const Recipe& recipe = s.recipe;
  GeneratePlan p;
  p.options = s.options ? *s.options : recipe.export_settings ? recipe.export_settings->options : ExportOptions{};
  p.option_path = s.option_path ? OptionPath(s.option_path) : OptionPath([](const std::string& name) { return "export." + name; });
  validate_export_options(p.options, p.option_path);
  p.formats_path = s.formats ? s.formats_path : "export.formats";
  std::string formats = s.formats ? *s.formats : recipe.export_settings ? recipe.export_settings->formats : "";
  if (formats == "default") formats.clear();
  p.writers = select_writers(formats, p.options, p.formats_path);
  if (p.writers.has("engine")) check_engine_size(p.options, recipe.world.nx, recipe.world.nz, p.option_path, s.size_path);
  check_memory(recipe, p.writers.with_mesh(), s.memory_budget_bytes);
  for (const WriterDef* w : p.writers.writers)
    for (const std::string& f : w->files) p.files.push_back({f, w->name, 0});
  return p;
}

Generated generate_keep(GenerateSettings s, Output& out) {
  const auto t_start = Clock::now();
  Recipe& recipe = s.recipe;

  // 1. Plan: every refusal before any work.
  const GeneratePlan planned = plan(s);
  const ExportOptions& options = planned.options;
  const OptionPath& option_path = planned.option_path;
  const WriterPlan& plan = planned.writers;
  if (s.terrain && !recipe.seed) throw Error("seed", "a terrain given to generate() needs the recipe's seed");
  const Frame whole = recipe.world.frame();
  if (s.terrain && (s.terrain->frame.nx != whole.nx || s.terrain->frame.nz != whole.nz || s.terrain->frame.ix0 != 0 ||
                    s.terrain->frame.iz0 != 0))
    throw Error("world", "the terrain given to generate() is not of this recipe's world");

  auto progress = [&](std::string_view what, double f) {
    if (s.progress) s.progress(what, f);
  };
  auto check_cancel = [&] {
    if (s.cancelled && s.cancelled()) throw Cancelled();
  };

  // 2. Run.
  Generated g;
  GenerateReport& rep = g.report;
  const Terrain* terrain = s.terrain;
  if (!terrain) {
    RunOptions opt;
    opt.threads = s.threads;
    opt.progress = [&](std::string_view st, double f) { progress(std::string("stage ") + std::string(st), f * 0.7); };
    opt.after_stage = s.after_stage;
    opt.cancelled = s.cancelled;
    RunResult res = run(recipe, opt);
    rep.seed = res.seed;
    rep.timings = std::move(res.timings);
    rep.generate_ms = res.total_ms;
    g.terrain = std::move(res.terrain);
    terrain = &g.terrain;
  } else {
    rep.seed = *recipe.seed;
    rep.timings = s.timings;
    for (auto& t : rep.timings) rep.generate_ms += t.ms;
  }
  recipe.seed = rep.seed;

  // 3. Encode: the writers that run (by name, and every writer option) go into the recipe, so that
  // a saved recipe and report.json reproduce these files.
  const WriterDef* report = nullptr;
  std::vector<const WriterDef*> encoders;
  for (const WriterDef* w : plan.writers) {
    if (w->name == "report") {
      report = w;
      continue;
    }
    if (w->applies && !w->applies(*terrain)) {
      const bool named = plan.is_named(w);
      if (named && !w->needs.empty())
        throw Error(planned.formats_path, w->name + " needs " + w->needs);
      if (!named) {
        rep.skipped.push_back(w->name);
        continue;
      }
    }
    encoders.push_back(w);
  }
  {
    std::string ran;
    for (const WriterDef* w : plan.writers)
      if (w == report || std::find(encoders.begin(), encoders.end(), w) != encoders.end()) ran += (ran.empty() ? "" : ",") + w->name;
    recipe.export_settings = ExportSettings{ran, options};
  }
  check_cancel();

  WriteContext wc;
  wc.seed = rep.seed;
  wc.recipe = recipe.to_json();
  wc.options = options;
  wc.option_path = option_path;
  std::mutex progress_mutex, files_mutex;
  wc.progress = [&](std::string_view what, double f) {
    std::lock_guard<std::mutex> lock(progress_mutex);
    progress(what, 0.7 + 0.25 * f);
  };
  if (s.cancelled)
    wc.cancelled = [&] {
      std::lock_guard<std::mutex> lock(progress_mutex);
      return s.cancelled();
    };
  // Writers run in parallel, one task each (the OBJ's rows spread over the threads as well). Each
  // writes its files straight into the output as soon as they are encoded, so writing overlaps
  // encoding; the commit below makes them visible only when every writer has succeeded. The bytes
  // never depend on scheduling.
  std::vector<double> ms(encoders.size());
  {
    tbb::task_arena arena(s.threads > 0 ? capped_threads(s.threads) : tbb::task_arena::automatic);
    arena.execute([&] {
      tbb::parallel_for(
          std::size_t(0), encoders.size(),
          [&](std::size_t k) {
            const auto t0 = Clock::now();
            RecordingOutput rec(out, encoders[k]->name, files_mutex, rep.files);
            encoders[k]->write(*terrain, wc, rec);
            ms[k] = ms_since(t0);
          },
          tbb::simple_partitioner());  // one task per writer, whatever their number
    });
  }
  for (std::size_t k = 0; k < encoders.size(); ++k) rep.encode_ms.emplace_back(encoders[k]->name, ms[k]);
  check_cancel();

  // 4. Report.
  if (report) {
    json perf;
    perf["threads"] = s.threads;
    json st = json::array();
    for (auto& t : rep.timings) {
      json e = {{"stage", t.name}, {"label", t.label}, {"ms", t.ms}};
      if (t.fused) e["fused"] = true;  // ran in one row pass with the stages before it
      st.push_back(e);
    }
    perf["stages"] = st;
    perf["generate_ms"] = rep.generate_ms;
    json enc = json::object();
    for (auto& [name, t] : rep.encode_ms) enc[name] = t;
    perf["encode_ms"] = enc;  // per writer: encoding and writing its temporary files
    perf["peak_memory_bytes"] = peak_rss_bytes();
    perf["total_ms"] = ms_since(t_start);
    wc.report["performance"] = perf;
    // The manifest: every file this run writes into the output (report.json included), so that a
    // front end can tell the next run into the same folder which files were this run's.
    std::vector<std::string> names;
    {
      std::lock_guard<std::mutex> lock(files_mutex);
      for (auto& f : rep.files) names.push_back(f.name);
    }
    for (auto& f : report->files) names.push_back(f);
    std::sort(names.begin(), names.end());
    names.erase(std::unique(names.begin(), names.end()), names.end());
    wc.report["files"] = names;
    RecordingOutput rec(out, report->name, files_mutex, rep.files);
    report->write(*terrain, wc, rec);
  }

  // 5. Commit, with the caller's other outputs.
  if (s.before_commit) s.before_commit(*terrain, recipe);
  check_cancel();
  progress("writing files", 0.95);
  std::vector<Output*> all{&out};
  for (Output* o : s.also_commit)
    if (o && o != &out) all.push_back(o);
  commit_all(all);

  std::sort(rep.files.begin(), rep.files.end(), [](const GeneratedFile& a, const GeneratedFile& b) { return a.name < b.name; });
  rep.recipe = std::move(recipe);
  rep.peak_memory_bytes = peak_rss_bytes();
  rep.total_ms = ms_since(t_start);
  progress("done", 1.0);
  if (s.terrain) g.terrain = Terrain{};  // the caller's terrain stays the caller's
  return g;
}

GenerateReport generate(GenerateSettings settings, Output& out) { return generate_keep(std::move(settings), out).report; }

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

}  // namespace relief
