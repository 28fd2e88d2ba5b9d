// relief::build_world: a recipe evaluated tile by tile in world coordinates into a tile store
// (relief/world.hpp). Each tile is run() on its window, which grows by the stages' halos and is
// cropped (pipeline.cpp), so pointwise and neighbourhood stages are exact; global stages are
// refused until a world algorithm handles them (Barnes' perimeter methods, issue 18).
//
// Distributed builds (WorldSettings::mpi_module; src/world_transport.hpp): every rank runs this
// function. Rank 0 alone checks the folder, draws the seed and writes world.json, runs the world
// algorithms of global stages (the others wait in a broadcast) and writes overview.png, report.json
// and the final world.json. The tiles of each local phase are handed out one at a time by rank 0
// (WorkHandout); every rank builds them on `at_once` lanes and writes them into the shared folder,
// and each tile's small result (CRC-32, size, overview samples, stage times: TileResult) goes to
// rank 0, which fills the manifest and the overview exactly as a build in one process does. Every
// step whose outcome the ranks must share ends in agree()/agree_all(): rank 0's outcome (or the
// first failure of any rank) is broadcast and rethrown on every rank, so all ranks leave together.
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <regex>
#include <set>
#include <system_error>
#include <thread>

#include "relief/encode_image.hpp"
#include "relief/error.hpp"
#include "relief/file_output.hpp"
#include "relief/generate.hpp"
#include "relief/world.hpp"
#include "relief/world_bounded.hpp"
#include "relief/world_features.hpp"
#include "relief/world_points.hpp"
#include "world_internal.hpp"
#include "world_farm.hpp"
#include "world_overview.hpp"
#include "world_transport.hpp"

namespace relief {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

const char* locality_name(Locality l) {
  return l == Locality::Pointwise ? "pointwise" : l == Locality::Neighbourhood ? "neighbourhood" : "global";
}

// The part of the resolved recipe that decides the samples: seed, world and stages (not the name,
// description or export block).
json identity_doc(const json& resolved) {
  json id = json::object();
  for (const char* k : {"seed", "world", "stages"})
    if (resolved.contains(k)) id[k] = resolved[k];
  return id;
}

std::string world_id_of(const json& resolved, int tile) {
  return detail::hash_hex("relief-world/1\n" + identity_doc(resolved).dump() + "\ntile=" + std::to_string(tile));
}

// The nearest existing folder of `p` (for the free-space query).
fs::path existing_ancestor(fs::path p) {
  std::error_code ec;
  p = fs::absolute(p, ec);
  while (!p.empty() && !fs::exists(p, ec)) {
    if (p == p.parent_path()) break;
    p = p.parent_path();
  }
  return p;
}

// Old world files in `dir` that --force removes: world.json, overview.png, report.json, the flow
// stage's rivers.json and lakes.json, and the tile files named as build_world names them (nothing
// else).
// An intermediate phase's folder: its tile files and marker, then the folder if empty.
void remove_phase_folder(const fs::path& folder) {
  std::error_code ec;
  const std::regex tile_name(R"(x\d{4,}_z\d{4,}\.rtile)");
  if (fs::is_directory(folder, ec))
    for (const auto& e : fs::directory_iterator(folder, ec))
      if (e.is_regular_file(ec) && (std::regex_match(e.path().filename().string(), tile_name) || e.path().filename() == "complete"))
        fs::remove(e.path(), ec);
  fs::remove(folder, ec);  // only when empty
}

// The tile files of an intermediate phase whose next phase is complete (its `complete` marker stays:
// a resumed build skips the phase).
void remove_phase_tiles(const fs::path& folder) {
  std::error_code ec;
  const std::regex tile_name(R"(x\d{4,}_z\d{4,}\.rtile)");
  if (fs::is_directory(folder, ec))
    for (const auto& e : fs::directory_iterator(folder, ec))
      if (e.is_regular_file(ec) && std::regex_match(e.path().filename().string(), tile_name)) fs::remove(e.path(), ec);
}

// What the library's own world algorithms read and overwrite, for lean phase stores (relief/world.hpp,
// "Phases"): a layer such an algorithm overwrites before anything reads it need not be kept for it.
// Any other world algorithm, and every local stage, may read every layer.
struct LayerUse {
  std::set<std::string> reads, writes;
};
const LayerUse* library_layer_use(const std::string& stage) {
  static const std::map<std::string, LayerUse> known = {{"fill", {{"height"}, {"height"}}},
                                                        {"flow", {{"height"}, {"height", "flow", "water"}}}};
  const auto it = known.find(stage);
  return it == known.end() ? nullptr : &it->second;
}

void remove_old_world(const fs::path& dir) {
  std::error_code ec;
  for (const char* f : {"world.json", "overview.png", "report.json", "rivers.json", "lakes.json", "props.json", "props.csv", "features.json"})
    fs::remove(dir / f, ec);
  // points/: p{K}.json and p{K}/x…_z….json (the point files of relief/world.hpp), then the folders if empty.
  const std::regex point_phase(R"(p\d+)"), point_global(R"(p\d+\.json)"), point_tile(R"(x\d{4,}_z\d{4,}\.json)");
  if (fs::is_directory(dir / "points", ec)) {
    for (const auto& e : fs::directory_iterator(dir / "points", ec)) {
      const std::string name = e.path().filename().string();
      if (e.is_regular_file(ec) && std::regex_match(name, point_global)) {
        fs::remove(e.path(), ec);
      } else if (e.is_directory(ec) && std::regex_match(name, point_phase)) {
        for (const auto& f : fs::directory_iterator(e.path(), ec))
          if (f.is_regular_file(ec) && std::regex_match(f.path().filename().string(), point_tile)) fs::remove(f.path(), ec);
        fs::remove(e.path(), ec);
      }
    }
    fs::remove(dir / "points", ec);
  }
  const std::regex tile_name(R"(x\d{4,}_z\d{4,}\.rtile)");
  if (fs::is_directory(dir / "tiles", ec))
    for (const auto& e : fs::directory_iterator(dir / "tiles", ec))
      if (e.is_regular_file(ec) && std::regex_match(e.path().filename().string(), tile_name)) fs::remove(e.path(), ec);
  const std::regex phase_name(R"(phase-\d+)");
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_directory(ec) && std::regex_match(e.path().filename().string(), phase_name)) remove_phase_folder(e.path());
}

void write_or_throw(const fs::path& p, std::string_view bytes, const std::string& out_path) {
  try {
    write_file_atomic(p.string(), bytes);
  } catch (const Error& e) {
    throw Error(out_path, e.message());
  }
}


// ---- distributed builds (src/world_transport.hpp) ----------------------------------------------

// What rank 0 keeps of one finished tile: its checksum and size and overview samples (last phase),
// its stage times (built tiles), whether it was built or found finished.
struct TileResult {
  std::int64_t k = -1;    // tile index, Z·tiles_x + X
  bool built = false;     // false: found finished in the folder
  std::uint32_t crc = 0;  // last phase: CRC-32 of the file
  std::uint64_t bytes = 0;
  std::size_t first = 0;  // stage index of ms[0]
  std::vector<double> ms;
  std::vector<bool> fused;
  std::vector<float> overview;  // the overview samples the tile owns (build_world's overview_points order)
};

// A result as sent to rank 0: u32 length of a JSON header, the header, the overview floats.
std::string encode_result(const TileResult& t) {
  json h = {{"k", t.k}, {"built", t.built}, {"crc", t.crc}, {"bytes", t.bytes}, {"first", t.first}, {"ms", t.ms}, {"fused", t.fused}};
  const std::string hs = h.dump();
  std::string out(4, '\0');
  for (int b = 0; b < 4; ++b) out[std::size_t(b)] = char((hs.size() >> (8 * b)) & 0xFF);
  out += hs;
  const std::size_t at = out.size();
  out.resize(at + t.overview.size() * sizeof(float));
  if (!t.overview.empty()) std::memcpy(out.data() + at, t.overview.data(), t.overview.size() * sizeof(float));
  return out;
}

TileResult decode_result(const std::string& s) {
  auto bad = [] { return std::runtime_error("world transport: a malformed tile result"); };
  if (s.size() < 4) throw bad();
  std::size_t n = 0;
  for (int b = 0; b < 4; ++b) n |= std::size_t(std::uint8_t(s[std::size_t(b)])) << (8 * b);
  if (n > s.size() - 4 || (s.size() - 4 - n) % sizeof(float)) throw bad();
  const json h = json::parse(s.substr(4, n), nullptr, false);
  if (!h.is_object()) throw bad();
  TileResult t;
  try {
    t.k = h.at("k").get<std::int64_t>();
    t.built = h.at("built").get<bool>();
    t.crc = h.at("crc").get<std::uint32_t>();
    t.bytes = h.at("bytes").get<std::uint64_t>();
    t.first = h.at("first").get<std::size_t>();
    t.ms = h.at("ms").get<std::vector<double>>();
    t.fused = h.at("fused").get<std::vector<bool>>();
  } catch (const json::exception&) {
    throw bad();
  }
  if (t.fused.size() != t.ms.size()) throw bad();
  t.overview.resize((s.size() - 4 - n) / sizeof(float));
  if (!t.overview.empty()) std::memcpy(t.overview.data(), s.data() + 4 + n, t.overview.size() * sizeof(float));
  return t;
}

// What a rank's part of a step came to, as JSON: {"kind": 0} (ok), 1 (relief::Error: path,
// message), 2 (Cancelled), 3 (any other exception: message).
json outcome_of(std::exception_ptr e) {
  if (!e) return {{"kind", 0}};
  try {
    std::rethrow_exception(e);
  } catch (const Error& x) {
    return {{"kind", 1}, {"path", x.path()}, {"message", x.message()}};
  } catch (const Cancelled&) {
    return {{"kind", 2}};
  } catch (const std::exception& x) {
    return {{"kind", 3}, {"message", x.what()}};
  } catch (...) {
    return {{"kind", 3}, {"message", "an unknown exception"}};
  }
}

// Throws what outcome `o` (outcome_of) describes; nothing when it is ok. `rank` > 0: the rank it came
// from, named in the message of errors that are not about the input.
void rethrow_outcome(const json& o, int rank) {
  const int kind = o.value("kind", 3);
  if (kind == 0) return;
  const std::string message = o.value("message", std::string("(no message)"));
  if (kind == 1) throw Error(o.value("path", std::string()), message);
  if (kind == 2) throw Cancelled();
  throw std::runtime_error(rank > 0 ? "rank " + std::to_string(rank) + ": " + message : message);
}

// A step that rank 0 does for everyone: `on_root` runs on rank 0, then every rank learns its outcome
// (broadcast): its payload is returned everywhere, its exception rethrown everywhere (as is on
// rank 0, rebuilt from outcome_of on the others). Collective. In one process: on_root().
json agree(detail::WorldTransport& tr, const std::function<json()>& on_root) {
  std::string msg;
  std::exception_ptr mine;
  json payload;
  if (tr.rank() == 0) {
    json o;
    try {
      payload = on_root ? on_root() : json();
      o = {{"kind", 0}, {"payload", payload}};
    } catch (...) {
      mine = std::current_exception();
      o = outcome_of(mine);
    }
    if (tr.size() == 1) {
      if (mine) std::rethrow_exception(mine);
      return payload;
    }
    msg = o.dump();
  }
  tr.broadcast(msg);
  if (mine) std::rethrow_exception(mine);
  if (tr.rank() == 0) return payload;
  const json o = json::parse(msg, nullptr, false);
  if (!o.is_object()) throw std::runtime_error("world transport: a malformed message from rank 0");
  rethrow_outcome(o, 0);
  return o.value("payload", json());
}

// This process's resident memory while each phase of a build runs (report.json: the phases' peaks;
// what earlier phases still hold counts too). The process's high-water mark cannot be split by
// phase, so a thread reads the resident size (/proc/self/statm) every 10 ms, and at every phase
// change, and keeps each phase's largest.
class PhaseMemory {
 public:
  explicit PhaseMemory(std::size_t phases) : peak_(phases, 0) {
    thread_ = std::thread([this] {
      std::unique_lock<std::mutex> l(m_);
      while (!done_) {
        note();
        cv_.wait_for(l, std::chrono::milliseconds(10));
      }
    });
  }
  ~PhaseMemory() { stop(); }
  PhaseMemory(const PhaseMemory&) = delete;
  PhaseMemory& operator=(const PhaseMemory&) = delete;
  void enter(std::size_t phase) {
    std::lock_guard<std::mutex> l(m_);
    note();
    phase_ = phase;
    note();
  }
  void stop() {
    {
      std::lock_guard<std::mutex> l(m_);
      if (done_) return;
      note();
      done_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  std::uint64_t peak(std::size_t phase) const { return peak_.at(phase); }

 private:
  void note() {  // under m_
    if (phase_ >= peak_.size()) return;
    unsigned long long size = 0, resident = 0;
    std::FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return;
    const int got = std::fscanf(f, "%llu %llu", &size, &resident);
    std::fclose(f);
    if (got == 2) peak_[phase_] = std::max<std::uint64_t>(peak_[phase_], std::uint64_t(resident) * page_);
  }
  const std::uint64_t page_ = std::uint64_t(::sysconf(_SC_PAGESIZE));
  std::vector<std::uint64_t> peak_;
  std::size_t phase_ = std::size_t(-1);  // none yet
  bool done_ = false;
  std::mutex m_;
  std::condition_variable cv_;
  std::thread thread_;
};

// agree() after every rank's own part: `local` (this rank's failure, or null) reaches rank 0 first;
// rank 0 throws the first failure (its own, else the lowest rank's) for everyone, else runs on_root.
json agree_all(detail::WorldTransport& tr, std::exception_ptr local, const std::function<json()>& on_root) {
  if (tr.size() == 1) {
    if (local) std::rethrow_exception(local);
    return on_root ? on_root() : json();
  }
  detail::WorkHandout gather(tr, 0, nullptr);
  const std::vector<std::string> statuses = gather.finish(outcome_of(local).dump());
  return agree(tr, [&]() -> json {
    if (local) std::rethrow_exception(local);
    for (std::size_t k = 1; k < statuses.size(); ++k) {
      const json o = json::parse(statuses[k], nullptr, false);
      if (!o.is_object()) throw std::runtime_error("world transport: rank " + std::to_string(k) + " sent a malformed status");
      rethrow_outcome(o, int(k));
    }
    return on_root ? on_root() : json();
  });
}

}  // namespace

WorldReport build_world(WorldSettings s) {
  const auto t_start = Clock::now();
  WorldReport rep;
  Recipe r = std::move(s.recipe);
  const std::int64_t nx = s.nx > 0 ? s.nx : r.world.nx, nz = s.nz > 0 ? s.nz : r.world.nz;
  const WorldGrid grid = world_grid(nx, nz, s.tile, s.size_path, s.tile_path);
  rep.grid = grid;
  r.world.nx = int(grid.nx);
  r.world.nz = int(grid.nz);
  const Frame frame = r.world.frame();
  // The library's own world algorithms (default_world_algorithms) unless the caller gave its own.
  std::set<std::string> callers_algorithms;
  for (const auto& [name, algo] : s.algorithms) callers_algorithms.insert(name);
  for (auto& [name, algo] : default_world_algorithms()) s.algorithms.emplace(name, algo);

  // 1. Stages: every one must have a world algorithm (for now: be local).
  int halo = 0;
  json stages = json::array();
  std::vector<std::size_t> globals;  // global stages run by a world algorithm
  for (std::size_t i = 0; i < r.stages.size(); ++i) {
    const RecipeStage& st = r.stages[i];
    const Reach re = st.stage->reach(frame);
    if (re.locality == Locality::Global && s.algorithms.count(st.def->name)) {
      if (i == 0) throw Error("stages[0]", "'" + st.def->name + "' runs over stored tiles, so the recipe must start with a local stage");
      globals.push_back(i);
      stages.push_back({{"index", i},
                        {"stage", st.def->name},
                        {"label", st.label},
                        {"locality", "global"},
                        {"halo", 0},
                        {"world", callers_algorithms.count(st.def->name) ? "world algorithm" : world_guarantee(*st.def).guarantee},
                        {"world_how", callers_algorithms.count(st.def->name) ? "the caller's world algorithm" : world_guarantee(*st.def).how}});
      continue;
    }
    if (re.locality == Locality::Global)
      throw Error("stages[" + std::to_string(i) + "]",
                  "'" + st.def->name + "' has no world support yet: it needs the whole map (" +
                      (re.why.empty() ? "a global stage" : re.why) +
                      "); world builds run pointwise and neighbourhood stages and the global stages that have a world "
                      "algorithm (`relief explain` says which) — leave it out, or build one map with `relief generate`");
    if (re.locality == Locality::Neighbourhood) halo += std::max(0, re.halo);
    stages.push_back({{"index", i},
                      {"stage", st.def->name},
                      {"label", st.label},
                      {"locality", locality_name(re.locality)},
                      {"halo", re.locality == Locality::Neighbourhood ? re.halo : 0},
                      {"world", "exact"},
                      {"world_how", world_guarantee(*st.def).how}});
  }

  // The ranks (one without MPI): rank 0 prepares the folder and writes the manifest, every rank
  // builds the tiles rank 0 hands it, rank 0 runs the world algorithms and finishes the store.
  const std::unique_ptr<detail::WorldTransport> transport =
      s.mpi_module.empty() ? detail::in_process_transport() : detail::load_mpi_transport(s.mpi_module, s.mpi_path);
  detail::WorldTransport& tr = *transport;
  const bool root = tr.rank() == 0;
  rep.rank = tr.rank();
  rep.ranks = tr.size();
  if (!root) s.progress = nullptr;  // rank 0 counts every rank's tiles
  const fs::path dir(s.out_dir);
  std::error_code ec;
  const int threads = s.threads > 0 ? capped_threads(s.threads) : tbb::info::default_concurrency();
  const int at_once = grid.count() >= 2 * std::int64_t(threads) ? threads : 1;
  rep.tiles_at_once = at_once;
  const int step = int(std::max<std::int64_t>(1, (std::max(grid.nx, grid.nz) - 1 + kWorldOverviewMax - 2) / (kWorldOverviewMax - 1)));
  rep.overview_step = step;
  const int ow = int((grid.nx - 1) / step + 1), oh = int((grid.nz - 1) / step + 1);

  // The phases (relief/world.hpp, "Phases"): runs of local stages and the global stages run by world
  // algorithms, in recipe order; their folders, ids and lean layer sets are set below.
  struct Phase {
    bool global = false;
    std::size_t first = 0, end = 0;  // stages [first, end) (a global phase: one stage)
    fs::path folder;                 // where its tiles go
    std::string id;                  // the world_id its tile headers carry
    std::set<std::string> drop;      // layers its store leaves out (lean stores; none in the last phase)
  };
  std::vector<Phase> phases;
  {
    std::size_t first = 0;
    for (std::size_t g : globals) {
      if (g > first) phases.push_back({false, first, g, {}, {}, {}});
      phases.push_back({true, g, g + 1, {}, {}, {}});
      first = g + 1;
    }
    if (first < r.stages.size() || phases.empty()) phases.push_back({false, first, r.stages.size(), {}, {}, {}});
  }

  // 2.-6. on rank 0; the other ranks learn the seed and the phases' layers (or rank 0's error) from it.
  json resolved, manifest;
  // Rank 0: the folder holds this world, complete and intact (world.json says so and every tile
  // matches its checksum): a rerun skips every phase before the last (their stores are gone) and a
  // last phase that is a world algorithm; a last local phase still checks each tile.
  bool was_complete = false;
  const json started = agree(tr, [&]() -> json {
    // 2. The folder: the same world (resume), a different one (refuse unless forced), or none.
    json old;
    bool have_old = false;
    if (fs::exists(dir / "world.json", ec)) {
      bool ok = false;
      const std::string text = detail::read_file_bytes((dir / "world.json").string(), ok);
      old = json::parse(text, nullptr, false);
      have_old = true;
    }
    const std::string recipe_id = [&] {
      json j = r.to_json();
      j.erase("seed");
      return world_id_of(j, grid.tile);
    }();
    // The old manifest is a file in the user's folder: read only fields of the expected types.
    auto old_string = [&](const char* key) -> std::string {
      const auto it = old.is_object() ? old.find(key) : old.end();
      return it != old.end() && it->is_string() ? it->get<std::string>() : std::string();
    };
    auto old_field = [&](const char* key) -> json {
      const auto it = old.is_object() ? old.find(key) : old.end();
      return it != old.end() ? *it : json();
    };
    const bool old_is_world = old_string("format") == "relief-world";
    if (!r.seed) {
      const json seed = old_field("seed");
      if (have_old && old_is_world && old_string("recipe_id") == recipe_id && seed.is_number_unsigned()) {
        r.seed = seed.get<std::uint64_t>();
        rep.seed_reused = true;
      } else {
        r.seed = random_seed();
      }
    }
    rep.seed = *r.seed;
    resolved = r.to_json();
    rep.recipe = resolved;
    rep.world_id = world_id_of(resolved, grid.tile);
    if (have_old) {
      const bool same = old_is_world && old_string("world_id") == rep.world_id;
      if (!same && !s.force) {
        std::string what = "something that is not a Relief world manifest";
        if (old_is_world) {
          const json rec = old_field("recipe"), fr = old_field("frame"), gr = old_field("grid"), seed = old_field("seed");
          const json name = rec.is_object() && rec.contains("name") ? rec["name"] : json("?");
          const json tile = gr.is_object() && gr.contains("tile") ? gr["tile"] : json(0);
          what = "another world (recipe " + (name.is_string() ? quote(name.get<std::string>()) : name.dump()) +
                 (fr.is_object() && fr.contains("size") ? ", " + fr["size"].dump() : "") + ", tile " + tile.dump() +
                 (seed.is_null() ? "" : ", seed " + seed.dump()) + ")";
        }
        throw Error(s.out_path, "the folder " + quote(s.out_dir) + " holds " + what +
                                    ", not this one (its world.json differs in recipe, seed, size or tile); choose another folder, "
                                    "or pass " + s.force_name + " to replace it");
      }
      if (!same && !s.dry_run) remove_old_world(dir);
      if (same && old_string("status") == "complete") {
        try {
          was_complete = verify_world(dir.string()).empty();
        } catch (const Error&) {
          was_complete = false;
        }
      }
    }

    // 3. The layers each phase leaves: from runs of the recipe up to the phase's end on a small
    // window, or on a small whole map when the recipe has global stages (same names and channels).
    std::vector<std::map<std::string, int>> after(phases.size());
    for (std::size_t k = 0; k < phases.size(); ++k) {
      RunOptions probe;
      probe.threads = 1;
      Recipe small = r;
      small.stages.resize(phases[k].end);
      if (globals.empty()) {
        probe.window = frame.window(0, 0, int(std::min<std::int64_t>(grid.nx, 5)), int(std::min<std::int64_t>(grid.nz, 5)));
      } else {  // global stages run on a small whole map
        small.world.nx = int(std::min<std::int64_t>(grid.nx, 33));
        small.world.nz = int(std::min<std::int64_t>(grid.nz, 33));
      }
      const RunResult res = run(small, probe);
      for (auto& [name, l] : res.terrain.layers) after[k][name] = l.channels;
    }
    for (auto& [name, c] : after.back()) rep.layers.emplace_back(name, c);
    std::uint64_t channels = 0;
    for (auto& [name, c] : rep.layers) channels += std::uint64_t(c);
    // Lean stores: a phase keeps the layers that a later phase reads before one of the library's
    // world algorithms overwrites them, and those that reach the last store.
    json drop = json::array();
    std::vector<std::map<std::string, int>> phase_layers(phases.size());  // the layers each store holds
    for (std::size_t k = 0; k < phases.size(); ++k) {
      std::set<std::string> live, kept;
      for (auto& [name, c] : after[k]) live.insert(name);
      for (std::size_t j = k + 1; j < phases.size(); ++j) {
        const std::string& name = r.stages[phases[j].first].def->name;
        const LayerUse* use = phases[j].global && !callers_algorithms.count(name) ? library_layer_use(name) : nullptr;
        if (!use) break;  // it may read anything that is left
        for (const std::string& l : live)
          if (use->reads.count(l)) kept.insert(l);
        for (const std::string& l : use->writes) live.erase(l);
      }
      kept.insert(live.begin(), live.end());
      std::set<std::string> dropped;
      for (auto& [name, c] : after[k])
        if (kept.count(name)) phase_layers[k][name] = c;
        else dropped.insert(name);
      drop.push_back(dropped);
    }

    // What a global stage's world algorithm needs besides the tiles: the caller's figures when given
    // (WorldSettings::algorithm_needs), else the library's for its name.
    auto algorithm_needs = [&](const RecipeStage& st) {
      const auto it = s.algorithm_needs.find(st.def->name);
      if (it != s.algorithm_needs.end() && it->second) return it->second(st, grid);
      return default_world_algorithm_needs(st, grid, frame, threads);
    };

    // 4. Disk: each layer's coded bytes per sample, measured (see "Disk and memory" in
    // relief/world.hpp), against the free space (plus the tiles there). With phases, the largest
    // two consecutive phase stores: phase K's tiles are removed once phase K+1 is complete.
    {
      std::map<std::string, std::pair<std::uint64_t, std::uint64_t>> coded;  // layer → (bytes, samples)
      auto measure = [&](const Terrain& t, bool only_new) {
        std::vector<const Layer*> ls;
        std::vector<std::string> names;
        for (auto& [name, l] : t.layers)
          if (!only_new || !coded.count(name)) ls.push_back(&l), names.push_back(name);
        if (ls.empty()) return;
        const std::vector<std::string> parts = detail::encode_tile_parts(ls, t.frame.nx);
        for (std::size_t k = 0; k < ls.size(); ++k) {
          auto& [bytes, samples] = coded[names[k]];
          bytes += parts[k].size();
          samples += std::uint64_t(t.frame.nx) * std::uint64_t(t.frame.nz);
        }
      };
      constexpr int kSample = 129;  // samples per side of a sample window and of the small whole map
      if (!phases[0].global) {
        Recipe first = r;
        first.stages.resize(phases[0].end);
        std::set<std::int64_t> xs{0, grid.tiles_x / 2, grid.tiles_x - 1}, zs{0, grid.tiles_z / 2, grid.tiles_z - 1};
        for (std::int64_t Z : zs)
          for (std::int64_t X : xs) {
            const WorldGrid::Window w = grid.window(X, Z);
            RunOptions opt;
            opt.threads = threads;
            opt.window = frame.window(w.ix0, w.iz0, std::min(w.nx, kSample), std::min(w.nz, kSample));
            measure(run(first, opt).terrain, false);
          }
      }
      bool missing = false;  // a layer that only a later phase makes
      for (const auto& layers : phase_layers)
        for (auto& [name, c] : layers) missing = missing || !coded.count(name);
      if (missing) {
        Recipe small = r;
        small.world.nx = int(std::min<std::int64_t>(grid.nx, kSample));
        small.world.nz = int(std::min<std::int64_t>(grid.nz, kSample));
        RunOptions opt;
        opt.threads = threads;
        measure(run(small, opt).terrain, true);
      }
      auto store_estimate = [&](const std::map<std::string, int>& layers) {
        double per_sample = 0;  // coded bytes per sample of every layer, with the margin
        std::uint64_t ch = 0;
        for (auto& [name, c] : layers) {
          ch += std::uint64_t(c);
          const auto it = coded.find(name);
          per_sample += it != coded.end() && it->second.second ? 2.0 * double(it->second.first) / double(it->second.second) : 4.0 * c;
        }
        std::uint64_t b = 0;
        for (int kx = 0; kx < 2; ++kx)
          for (int kz = 0; kz < 2; ++kz) {
            // The four kinds of tile: full, clipped in x, clipped in z, the corner.
            const std::int64_t cols = kx == 0 ? grid.tiles_x - 1 : 1, rows = kz == 0 ? grid.tiles_z - 1 : 1;
            const WorldGrid::Window w = grid.window(kx == 0 ? 0 : grid.tiles_x - 1, kz == 0 ? 0 : grid.tiles_z - 1);
            const std::uint64_t n = std::uint64_t(w.nx) * std::uint64_t(w.nz);
            const std::uint64_t est = std::min<std::uint64_t>(compressBound(uLong(n * ch * 4)), std::uint64_t(std::ceil(per_sample * double(n))));
            b += std::uint64_t(cols * rows) * (est + 1024);
          }
        return b;
      };
      // What a world algorithm keeps on disk besides the stores while its phase runs.
      auto scratch = [&](std::size_t k) -> std::uint64_t {
        return phases[k].global ? algorithm_needs(r.stages[phases[k].first]).scratch_bytes : 0;
      };
      std::uint64_t stores = store_estimate(phase_layers[0]) + scratch(0);
      for (std::size_t k = 0; k + 1 < phases.size(); ++k)
        stores = std::max(stores, store_estimate(phase_layers[k]) + store_estimate(phase_layers[k + 1]) + scratch(k + 1));
      rep.estimated_store_bytes = store_estimate(phase_layers.back());
      // world.json and report.json (beyond their sizes below), the tiles' lines in world.json,
      // overview.png (3 bytes per pixel).
      const std::int64_t ostep = (std::max(grid.nx, grid.nz) - 1 + kWorldOverviewMax - 2) / (kWorldOverviewMax - 1);
      const std::uint64_t opx = std::uint64_t((grid.nx - 1) / std::max<std::int64_t>(1, ostep) + 1) *
                                std::uint64_t((grid.nz - 1) / std::max<std::int64_t>(1, ostep) + 1);
      const std::uint64_t need = 4096 + stores + std::uint64_t(grid.count()) * 64 + opx * 3;
      rep.estimated_bytes = need;
      std::uint64_t present = 0;
      if (fs::is_directory(dir / "tiles", ec))
        for (const auto& e : fs::directory_iterator(dir / "tiles", ec))
          if (e.is_regular_file(ec)) present += e.file_size(ec);
      std::uint64_t free_bytes = s.disk_free_bytes;
      if (free_bytes == 0) {
        const fs::space_info sp = fs::space(existing_ancestor(dir), ec);
        free_bytes = ec ? UINT64_MAX : sp.available;
      }
      rep.disk_free_bytes = free_bytes == UINT64_MAX ? free_bytes : free_bytes + present;
      if (need > free_bytes + present)
        throw Error(s.size_path, "a " + std::to_string(grid.nx) + "x" + std::to_string(grid.nz) + " world with " +
                                     std::to_string(channels) + " float channels needs about " + human_bytes(need) +
                                     " on disk (estimated from coded sample windows, with a margin of 2), but " + quote(s.out_dir) +
                                     " has " + human_bytes(free_bytes) + " free; choose a smaller size or free some space");
    }

    // 5. Memory: the tiles built at once, each a run on the grown tile, plus its encoding.
    {
      Recipe grown = r;
      grown.world.nx = int(std::min<std::int64_t>(grid.nx, grid.tile + 2 * std::int64_t(halo)));
      grown.world.nz = int(std::min<std::int64_t>(grid.nz, grid.tile + 2 * std::int64_t(halo)));
      const std::uint64_t raw = std::uint64_t(grid.tile) * std::uint64_t(grid.tile) * channels * 4;
      const std::uint64_t per_tile = estimate_memory_bytes(grown, false) + 2 * raw + compressBound(uLong(raw));
      const int step = int((std::max(grid.nx, grid.nz) - 1 + kWorldOverviewMax - 2) / (kWorldOverviewMax - 1));
      const std::uint64_t overview = detail::WorldOverview::memory_bytes((grid.nx - 1) / std::max(1, step) + 1, (grid.nz - 1) / std::max(1, step) + 1);
      rep.tile_memory_bytes = std::uint64_t(at_once) * per_tile + overview + std::uint64_t(grid.count()) * 16;
      // A world algorithm's phase holds its own state besides one tile at a time (relief/world_bounded.hpp):
      // stream power its coarse solve (and refinement), hydraulic its groups in flight. The largest phase
      // counts, and a refusal names what needs the memory.
      std::string need_what;  // empty: the tiles
      std::size_t need_stage = 0;
      for (const Phase& ph : phases) {
        if (!ph.global) continue;  // the stages a world algorithm runs
        const std::size_t i = ph.first;
        const RecipeStage& st = r.stages[i];
        std::uint64_t phase = algorithm_needs(st).memory_bytes;
        if (phase == 0) continue;
        phase += per_tile + overview + std::uint64_t(grid.count()) * 16;
        if (phase > rep.tile_memory_bytes) rep.tile_memory_bytes = phase, need_what = st.def->name, need_stage = i;
      }
      rep.memory_stage = need_what;
      const std::uint64_t budget = s.memory_budget_bytes ? s.memory_budget_bytes : memory_budget_bytes();
      if (budget && rep.tile_memory_bytes > budget) {
        if (!need_what.empty())
          throw Error("stages[" + std::to_string(need_stage) + "]",
                      "the world algorithm of stage '" + need_what + "' needs about " + human_bytes(rep.tile_memory_bytes) + " on a " +
                          std::to_string(grid.nx) + "x" + std::to_string(grid.nz) + " world in tiles of " + std::to_string(grid.tile) +
                          (need_what == "hydraulic"      ? " (its groups of blocks: a droplet's reach in cells sets their size)"
                           : need_what == "stream_power" ? " (its coarse solve and one refined block with its records)"
                                                         : "") +
                          ", but the limit here is " + human_bytes(budget) +
                          (need_what == "hydraulic"      ? "; choose fewer threads, a coarser world or shorter droplet paths (lifetime, step_m)"
                           : need_what == "stream_power" ? "; choose a smaller world or fewer steps"
                                                         : "; choose a smaller world"));
        throw Error(s.tile_path, "tiles of " + std::to_string(grid.tile) + " samples (" + std::to_string(at_once) +
                                     " at once) need about " + human_bytes(rep.tile_memory_bytes) + ", but the limit here is " +
                                     human_bytes(budget) + "; choose a smaller tile or fewer threads");
      }
    }

    if (s.dry_run)
      return json{{"seed", rep.seed}, {"seed_reused", rep.seed_reused}, {"dry_run", true}, {"estimated_bytes", rep.estimated_bytes},
                  {"estimated_store_bytes", rep.estimated_store_bytes}, {"disk_free_bytes", rep.disk_free_bytes}};

    // 6. The manifest, before the first tile.
    manifest = {
        {"format", "relief-world"},
        {"version", 1},
        {"status", "building"},
        {"world_id", rep.world_id},
        {"recipe_id", recipe_id},
        {"seed", rep.seed},
        {"frame",
         {{"size", {grid.nx, grid.nz}},
          {"spacing_m", frame.spacing_m},
          {"width_m", frame.world_width_m},
          {"depth_m", frame.world_depth_m},
          {"height_m", frame.height_m},
          {"sea_level", frame.sea_level},
          {"convention", "sample (i, j) at x = i·spacing_m, z = j·spacing_m; corners included; row-major, x fastest"}}},
        {"grid",
         {{"tile", grid.tile},
          {"tiles", {grid.tiles_x, grid.tiles_z}},
          {"shared_border", 1},
          {"tile_window", "tile (X, Z) covers samples [X*(tile-1), min(X*(tile-1)+tile, size)) per axis; the last row and "
                          "column are clipped to the world when size-1 is not a multiple of tile-1"},
          {"path", "tiles/x{X:04}_z{Z:04}.rtile"}}},
        {"layers", json::array()},
        {"tile_format", {{"magic", "RLFTILE1"}, {"version", 1}, {"encoding", "float32le-rowdelta-shuffle-planes"}, {"checksum", "crc32 trailer"}}},
        {"halo", halo},
        {"stages", stages},
        {"overview", {{"file", "overview.png"}, {"step", step}, {"size", {ow, oh}}}},
        {"recipe", resolved}};
    for (auto& [name, c] : rep.layers) manifest["layers"].push_back({{"name", name}, {"channels", c}});
    fs::create_directories(dir / "tiles", ec);
    if (ec) throw Error(s.out_path, "cannot create " + quote((dir / "tiles").string()) + ": " + ec.message());
    remove_dead_temporaries(dir.string());
    remove_dead_temporaries((dir / "tiles").string());
    write_or_throw(dir / "world.json", manifest.dump(2) + "\n", s.out_path);
    return json{{"seed", rep.seed}, {"seed_reused", rep.seed_reused}, {"drop", drop}};
  });
  if (s.dry_run) {  // nothing written: the estimates (every rank learns rank 0's)
    rep.dry_run = true;
    if (!root) {
      rep.seed = started.at("seed").get<std::uint64_t>();
      rep.seed_reused = started.at("seed_reused").get<bool>();
      rep.estimated_bytes = started.at("estimated_bytes").get<std::uint64_t>();
      rep.estimated_store_bytes = started.at("estimated_store_bytes").get<std::uint64_t>();
      rep.disk_free_bytes = started.at("disk_free_bytes").get<std::uint64_t>();
      r.seed = rep.seed;
      rep.recipe = r.to_json();
      rep.world_id = world_id_of(rep.recipe, grid.tile);
    }
    rep.total_ms = ms_since(t_start);
    return rep;
  }
  for (std::size_t k = 0; k < phases.size(); ++k) phases[k].drop = started.at("drop").at(k).get<std::set<std::string>>();
  if (!root) {
    r.seed = started.at("seed").get<std::uint64_t>();
    rep.seed = *r.seed;
    rep.seed_reused = started.at("seed_reused").get<bool>();
    resolved = r.to_json();
    rep.recipe = resolved;
    rep.world_id = world_id_of(resolved, grid.tile);
  }
  // Every rank must see rank 0's folder (one shared file system): the manifest it wrote.
  {
    std::exception_ptr unseen;
    if (!root) {
      bool ok = false;
      const json seen = json::parse(detail::read_file_bytes((dir / "world.json").string(), ok), nullptr, false);
      if (!ok || !seen.is_object() || !seen.contains("world_id") || seen["world_id"] != rep.world_id)
        unseen = std::make_exception_ptr(Error(s.out_path, "rank " + std::to_string(tr.rank()) + " does not see the manifest that rank 0 wrote in " +
                                                             quote(s.out_dir) + ": every rank must write to the same folder of one shared file system"));
    }
    agree_all(tr, unseen, nullptr);
  }

  // 7. The phases: local stages tile by tile, global stages by their world algorithms.
  {
    for (std::size_t k = 0; k < phases.size(); ++k) {
      const bool last = k + 1 == phases.size();
      phases[k].folder = last ? dir / "tiles" : dir / ("phase-" + std::to_string(k));
      phases[k].id = last ? rep.world_id : rep.world_id + "-p" + std::to_string(k);
    }
  }
  std::int64_t local_phases = 0;
  for (const Phase& ph : phases) local_phases += ph.global ? 0 : 1;
  const std::int64_t total = grid.count() * local_phases;
  // Progress: each global phase counts as one pass over the tiles (WorldProgress::fraction).
  const double units_total = double(std::max<std::int64_t>(1, grid.count() * std::int64_t(phases.size())));
  std::int64_t global_done = 0;  // tiles' worth of the global phases finished or skipped
  double phase_fraction = -1;     // the running global phase's share (−1: none running)
  double global_seconds = 0;      // time spent in global phases (for the pace of the tiles)
  Clock::time_point t_phase;      // the running global phase's start
  std::vector<std::uint32_t> crcs(std::size_t(grid.count()), 0);
  std::vector<std::uint64_t> sizes(std::size_t(grid.count()), 0);
  // Rank 0 only: the overview's samples, kept in a temporary file of the world folder.
  std::unique_ptr<detail::WorldOverview> overview;
  if (root) {
    try {
      overview = std::make_unique<detail::WorldOverview>(dir.string(), ow, oh);
    } catch (const Error& e) {
      throw Error(s.out_path, e.message());
    }
  }
  std::vector<double> stage_ms(r.stages.size(), 0.0);
  std::vector<bool> fused(r.stages.size(), false);
  std::mutex m;  // progress, timings, counters
  std::int64_t done = 0, skipped = 0, built = 0;
  double built_units = 0;  // tiles' worth of building finished (for the time estimate)
  double last_fraction = 0;
  std::uint64_t peak_memory = 0;  // the largest peak of the other ranks (rank 0)
  const auto t_tiles = Clock::now();
  auto report = [&](std::string_view stage_name, int stage, double tile_fraction) {  // under m
    if (!s.progress) return;
    WorldProgress p;
    p.tiles_total = total;
    p.tiles_done = done;
    p.tiles_skipped = skipped;
    p.stage = stage;
    p.stages = int(r.stages.size());
    p.stage_name = stage_name;
    const double global_units = double(global_done) + (phase_fraction > 0 ? phase_fraction * double(grid.count()) : 0.0);
    last_fraction = std::max(last_fraction, std::min(1.0, (double(done) + global_units + tile_fraction) / units_total));
    p.fraction = last_fraction;
    p.phase_fraction = phase_fraction;
    // Time left: the tiles left at the pace of the tiles built so far (the global phases' time
    // apart), plus the running global phase's rest at its own pace so far.
    const auto now = Clock::now();
    const double in_phase = phase_fraction >= 0 ? std::chrono::duration<double>(now - t_phase).count() : 0.0;
    const double units = built_units + tile_fraction;
    if (units > 0.05) {
      const double elapsed = std::max(0.0, std::chrono::duration<double>(now - t_tiles).count() - global_seconds - in_phase);
      p.seconds_left = elapsed / units * std::max(0.0, double(total - done) - tile_fraction);
    }
    if (phase_fraction > 0.01) p.seconds_left = std::max(0.0, p.seconds_left) + in_phase * (1.0 - phase_fraction) / phase_fraction;
    s.progress(p);
  };
  auto cancelled = [&] { return s.cancelled && s.cancelled(); };
  // The overview samples a tile owns (its shared last row and column belong to the next tile), in
  // the order of its rows, then columns: f(index into overview, index into the tile's samples).
  auto overview_points = [&](const WorldGrid::Window& w, auto&& f) {
    const bool last_x = w.ix0 + w.nx == grid.nx, last_z = w.iz0 + w.nz == grid.nz;
    for (int j = 0; j < w.nz - (last_z ? 0 : 1); ++j) {
      const std::int64_t iz = w.iz0 + j;
      if (iz % step) continue;
      for (int i = 0; i < w.nx - (last_x ? 0 : 1); ++i) {
        const std::int64_t ix = w.ix0 + i;
        if (ix % step) continue;
        f(std::size_t(iz / step) * std::size_t(ow) + std::size_t(ix / step), std::size_t(j) * std::size_t(w.nx) + std::size_t(i));
      }
    }
  };
  auto overview_of = [&](const WorldTile& t) {
    std::vector<float> v;
    auto it = t.layers.find("height");
    if (it == t.layers.end()) return v;
    const std::size_t c = std::size_t(it->second.channels);
    overview_points(t.window, [&](std::size_t, std::size_t at) { v.push_back(it->second.data[at * c]); });
    return v;
  };
  // Rank 0: a tile's overview samples (overview_of's order) into the overview, in runs along rows.
  auto put_overview = [&](const WorldGrid::Window& w, const std::vector<float>& v) {
    std::size_t n = 0, first = 0, start = 0, len = 0;
    overview_points(w, [&](std::size_t at, std::size_t) {
      if (n >= v.size()) return;
      if (len > 0 && at == first + len) {
        ++len;
      } else {
        if (len > 0) overview->set_run(first, v.data() + start, len);
        first = at, start = n, len = 1;
      }
      ++n;
    });
    if (len > 0) overview->set_run(first, v.data() + start, len);
  };
  auto take_overview = [&](const WorldTile& t) {  // rank 0
    const std::vector<float> v = overview_of(t);
    put_overview(t.window, v);
  };
  auto tile_file = [](const Phase& ph, std::int64_t X, std::int64_t Z) {
    return ph.folder / fs::path(world_tile_path(X, Z)).filename();
  };
  // The bytes of a tile of phase `ph` at (X, Z) whose CRC-32, header and framing are valid and whose
  // world_id and window are the phase's (empty when missing, damaged or foreign), parsed into
  // `parts`; no plane is inflated.
  auto parsed = [&](const Phase& ph, std::int64_t X, std::int64_t Z, detail::TileParts& parts) -> std::string {
    const fs::path path = tile_file(ph, X, Z);
    std::error_code e2;
    if (!fs::exists(path, e2)) return {};
    bool ok = false;
    std::string bytes = detail::read_file_bytes(path.string(), ok);
    if (!ok) return {};
    try {
      parts = detail::parse_tile(bytes, path.string());
      const WorldTile& t = parts.tile;
      const WorldGrid::Window w = grid.window(X, Z);
      if (t.world_id != ph.id || t.X != X || t.Z != Z || t.window.ix0 != w.ix0 || t.window.iz0 != w.iz0 || t.window.nx != w.nx ||
          t.window.nz != w.nz)
        return {};
      return bytes;
    } catch (const Error&) {
      return {};
    }
  };
  // A valid tile of phase `ph` at (X, Z), every layer decoded: its bytes (empty when missing, damaged
  // or foreign).
  auto existing = [&](const Phase& ph, std::int64_t X, std::int64_t Z, WorldTile* out) -> std::string {
    detail::TileParts parts;
    std::string bytes = parsed(ph, X, Z, parts);
    if (bytes.empty()) return {};
    try {
      WorldTile t = parts.tile;
      for (std::size_t k = 0; k < parts.parts.size(); ++k)
        t.layers[parts.parts[k].name] = detail::decode_tile_part(bytes, parts, k, tile_file(ph, X, Z).string());
      if (out) *out = std::move(t);
      return bytes;
    } catch (const Error&) {
      return {};
    }
  };
  auto missing = [&](const Phase& ph, std::int64_t X, std::int64_t Z) {
    return Error(s.out_path, "tile " + tile_file(ph, X, Z).string() + " is missing or damaged; run the build again");
  };
  // Tile (X, Z) of phase `ph`: every layer (names null) or only the named ones.
  auto load_tile = [&](const Phase& ph, std::int64_t X, std::int64_t Z, const std::vector<std::string>* names = nullptr) {
    WorldTile t;
    if (!names) {
      if (existing(ph, X, Z, &t).empty()) throw missing(ph, X, Z);
      return t;
    }
    detail::TileParts parts;
    const std::string bytes = parsed(ph, X, Z, parts);
    if (bytes.empty()) throw missing(ph, X, Z);
    t = parts.tile;
    for (const std::string& name : *names) {
      std::size_t k = 0;
      while (k < parts.parts.size() && parts.parts[k].name != name) ++k;
      if (k == parts.parts.size())
        throw Error(s.out_path, "tile " + tile_file(ph, X, Z).string() + " has no layer " + quote(name));
      try {
        t.layers[name] = detail::decode_tile_part(bytes, parts, k, tile_file(ph, X, Z).string());
      } catch (const Error&) {
        throw missing(ph, X, Z);
      }
    }
    return t;
  };
  std::vector<std::unique_ptr<FileOutput>> outputs(phases.size());  // made when a phase starts
  // Points (relief/world_points.hpp): a local phase whose stages make points writes, before each
  // tile file, the points the tile owns into points/p{K}/x…_z….json; a global stage's points go to
  // points/p{K}.json. Kept after the build (a rerun of a complete build skips every tile and still
  // needs them); rank 0 merges them into props.json / features.json at the end.
  const fs::path points_dir = dir / "points";
  auto phase_makes_points = [&](const Phase& ph) {
    if (ph.global) return false;
    for (std::size_t i = ph.first; i < ph.end; ++i) {
      const std::string& name = r.stages[i].def->name;
      if (name == "props" || name == "volcano" || name == "features") return true;
    }
    return false;
  };
  // "p{K}" and "p{K}.json" (built by append: GCC 12 warns falsely, -Wrestrict, on "p" + std::string).
  auto phase_name = [](std::size_t pk, const char* suffix) {
    std::string n = "p";
    n += std::to_string(pk);
    n += suffix;
    return n;
  };
  auto points_folder = [&](std::size_t pk) { return points_dir / phase_name(pk, ""); };
  auto points_file = [&](std::size_t pk, std::int64_t X, std::int64_t Z) {
    return points_folder(pk) / (fs::path(world_tile_path(X, Z)).stem().string() + ".json");
  };
  // The points tile (X, Z) owns after phase pk, or nullopt when its file is missing or stale.
  auto read_tile_points = [&](std::size_t pk, std::int64_t X, std::int64_t Z) -> std::optional<std::vector<Point>> {
    bool ok = false;
    const fs::path f = points_file(pk, X, Z);
    const std::string bytes = detail::read_file_bytes(f.string(), ok);
    if (!ok) return std::nullopt;
    try {
      return decode_world_points(bytes, phases[pk].id, X, Z, f.string());
    } catch (const Error&) {
      return std::nullopt;
    }
  };
  std::vector<std::unique_ptr<FileOutput>> point_outputs(phases.size());
  std::map<int, std::vector<Point>> global_points;  // rank 0: stage index → a world algorithm's points
  auto put_tile = [&](const Phase& ph, std::int64_t X, std::int64_t Z, const std::string& bytes) {
    // Atomic (temporary file, rename) but not flushed: a tile that a power cut leaves empty or
    // damaged fails its CRC-32 on the next run and is rebuilt, so resuming stays exact.
    try {
      outputs.at(std::size_t(&ph - phases.data()))->put(tile_file(ph, X, Z).filename().string(), bytes);
    } catch (const Error& e) {
      throw Error(s.out_path, e.message());
    }
  };
  // Phase `ph`'s tile, without the layers it drops (lean stores).
  auto store_tile = [&](const Phase& ph, WorldTile t) {
    t.world_id = ph.id;
    for (const std::string& name : ph.drop) t.layers.erase(name);
    const std::string bytes = detail::encode_tile(t);
    put_tile(ph, t.X, t.Z, bytes);
    return bytes;
  };
  // Phase `ph`'s tile (X, Z): the input phase's tile with the layers of `changed` replaced or added,
  // the others' coded planes copied through (the bytes store_tile writes for the whole tile).
  auto update_tile = [&](const Phase& ph, const Phase& in, std::int64_t X, std::int64_t Z, WorldTile changed) {
    detail::TileParts parts;
    const std::string bytes = parsed(in, X, Z, parts);
    if (bytes.empty()) throw missing(in, X, Z);
    const WorldGrid::Window w = grid.window(X, Z);
    const std::size_t n = std::size_t(w.nx) * std::size_t(w.nz);
    std::vector<const Layer*> coded_layers;
    for (auto it = changed.layers.begin(); it != changed.layers.end();) {
      if (ph.drop.count(it->first)) {
        it = changed.layers.erase(it);
        continue;
      }
      if (it->second.channels < 1 || it->second.data.size() != n * std::size_t(it->second.channels))
        throw Error("tile", "layer '" + it->first + "' has " + std::to_string(it->second.data.size()) + " values, expected " +
                                std::to_string(n) + " samples x " + std::to_string(it->second.channels) + " channels");
      coded_layers.push_back(&it->second);
      ++it;
    }
    const std::vector<std::string> coded = detail::encode_tile_parts(coded_layers, w.nx);
    std::map<std::string, detail::RawPart> all;  // ascending names, as encode_tile orders them
    for (const detail::TileParts::Part& p : parts.parts)
      if (!ph.drop.count(p.name)) all[p.name] = {p.name, p.channels, std::string_view(bytes).substr(p.offset, p.size)};
    std::size_t k = 0;
    for (auto& [name, l] : changed.layers) all[name] = {name, l.channels, coded[k++]};
    std::vector<detail::RawPart> list;
    for (auto& [name, part] : all) list.push_back(part);
    WorldTile head;
    head.world_id = ph.id;
    head.X = X;
    head.Z = Z;
    head.window = w;
    put_tile(ph, X, Z, detail::assemble_tile(head, list));
  };
  // The layers of the window [ix0, ix0+nx) × [iz0, iz0+nz) from phase `ph`'s tiles.
  auto read_region = [&](const Phase& ph, std::int64_t ix0, std::int64_t iz0, int nx, int nz) {
    Terrain t;
    t.frame = frame.window(ix0, iz0, nx, nz);
    const std::int64_t sz = grid.tile - 1;
    for (std::int64_t Z = std::min(iz0 / sz, grid.tiles_z - 1); Z <= std::min((iz0 + nz - 1) / sz, grid.tiles_z - 1); ++Z)
      for (std::int64_t X = std::min(ix0 / sz, grid.tiles_x - 1); X <= std::min((ix0 + nx - 1) / sz, grid.tiles_x - 1); ++X) {
        const WorldTile tile = load_tile(ph, X, Z);
        const WorldGrid::Window& w = tile.window;
        const std::int64_t a0 = std::max(ix0, w.ix0), a1 = std::min(ix0 + nx, w.ix0 + w.nx);
        const std::int64_t b0 = std::max(iz0, w.iz0), b1 = std::min(iz0 + nz, w.iz0 + w.nz);
        for (auto& [name, src] : tile.layers) {
          Layer& dst = t.layer(name, src.channels);
          const std::size_t c = std::size_t(src.channels);
          for (std::int64_t z = b0; z < b1; ++z)
            std::copy_n(src.data.data() + (std::size_t(z - w.iz0) * std::size_t(w.nx) + std::size_t(a0 - w.ix0)) * c,
                        std::size_t(a1 - a0) * c, dst.data.data() + (std::size_t(z - iz0) * std::size_t(nx) + std::size_t(a0 - ix0)) * c);
        }
      }
    return t;
  };
  // A stage that stands in for a global stage already applied to the stored tiles: pointwise, so
  // that run() accepts windows; it never runs (the run resumes after it).
  struct Placeholder final : Stage {
    void apply(Terrain&, const Context&) const override { throw Error("world", "a placeholder stage ran"); }
    json params() const override { return json::object(); }
  };
  auto placeholder = std::make_shared<const Placeholder>();
  const int run_threads = at_once > 1 ? 1 : threads;
  // What rank 0 keeps of a finished tile (built here, by another rank, or found finished).
  std::vector<std::int64_t> built_by_rank(std::size_t(tr.size()), 0);  // rank 0: tiles each rank built
  std::vector<std::int64_t> global_by_rank(std::size_t(tr.size()), 0);  // rank 0: global phases' tile solves each rank ran
  auto apply_result = [&](TileResult&& t, bool last, int from) {  // under m
    if (last) {
      crcs[std::size_t(t.k)] = t.crc;
      sizes[std::size_t(t.k)] = t.bytes;
      const WorldGrid::Window w = grid.window(t.k % grid.tiles_x, t.k / grid.tiles_x);
      put_overview(w, t.overview);
    }
    for (std::size_t i = 0; i < t.ms.size() && t.first + i < stage_ms.size(); ++i) {
      stage_ms[t.first + i] += t.ms[i];
      fused[t.first + i] = fused[t.first + i] || t.fused[i];
    }
    ++done;
    if (t.built) {
      ++built;
      ++built_by_rank[std::size_t(from)];
      built_units += 1.0;
    } else {
      ++skipped;
    }
    report("", 0, 0.0);
  };
  std::int64_t built_here = 0;  // tiles this rank built
  bool final_done_in_memory = false;
  // Rank 0's (the report is its); a sampler that cannot start leaves the phases without a figure.
  std::optional<PhaseMemory> phase_memory;
  if (root) {
    try {
      phase_memory.emplace(phases.size());
    } catch (const std::system_error&) {
    }
  }
  std::vector<bool> phase_skipped(phases.size(), false);
  for (std::size_t pk = 0; pk < phases.size(); ++pk) {
    const Phase& ph = phases[pk];
    if (phase_memory) phase_memory->enter(pk);
    const bool last = pk + 1 == phases.size();
    // Rank 0 decides whether the phase is done already (resumed) and prepares its folder; then
    // every rank opens the folder (removing temporary files that killed runs left there, before
    // any rank writes in it).
    const json begun = agree(tr, [&]() -> json {
      std::error_code e2;
      if ((was_complete && (!last || ph.global)) || (!last && fs::exists(ph.folder / "complete", e2))) {
        if (pk > 0) remove_phase_tiles(phases[pk - 1].folder);  // left by a build stopped before it removed them
        return {{"skip", true}};
      }
      fs::create_directories(ph.folder, e2);
      if (e2) throw Error(s.out_path, "cannot create " + quote(ph.folder.string()) + ": " + e2.message());
      return {{"skip", false}};
    });
    if (begun.at("skip").get<bool>()) {
      phase_skipped[pk] = true;
      std::lock_guard<std::mutex> lock(m);
      if (!ph.global) {
        done += grid.count();
        skipped += grid.count();
      } else {
        global_done += grid.count();
      }
      continue;
    }
    if (!ph.global) {
      std::exception_ptr opened;
      try {
        outputs[pk] = std::make_unique<FileOutput>(ph.folder.string(), FileOutput::Mode::Immediate, FileOutput::Sync::Atomic);
        outputs[pk]->forget_written();  // a path per tile would grow with the world
        if (phase_makes_points(ph)) {
          point_outputs[pk] = std::make_unique<FileOutput>(points_folder(pk).string(), FileOutput::Mode::Immediate, FileOutput::Sync::Atomic);
          point_outputs[pk]->forget_written();
        }
      } catch (const Error& e) {
        opened = std::make_exception_ptr(Error(s.out_path, e.message()));
      } catch (...) {
        opened = std::current_exception();
      }
      agree_all(tr, opened, nullptr);
    }
    if (ph.global) {
      // The tiles' large layers that the last tile runs gave to the process-wide buffer cache
      // (relief/terrain.hpp) would sit unused through the world algorithm, which holds its own state
      // (the memory check counts one tile beside it): freed first, on every rank.
      release_cached_buffers();
      // The world algorithm runs on rank 0; the other ranks run the tile solves it hands out
      // (src/world_farm.hpp: the fill algorithm's), then wait for its outcome.
      const RecipeStage& st = r.stages[ph.first];
      const Phase& in = phases[pk - 1];
      auto open_phase = [&] {
        try {
          outputs[pk] = std::make_unique<FileOutput>(ph.folder.string(), FileOutput::Mode::Immediate, FileOutput::Sync::Atomic);
          outputs[pk]->forget_written();  // a path per tile would grow with the world
        } catch (const Error& e) {
          throw Error(s.out_path, e.message());
        }
      };
      auto stage_io = [&] {  // what every rank's tile work reads and writes
        WorldStageIO io;
        io.grid = grid;
        io.world = frame;
        io.load = [&](std::int64_t X, std::int64_t Z) { return load_tile(in, X, Z); };
        io.load_layers = [&](std::int64_t X, std::int64_t Z, const std::vector<std::string>& names) {
          return load_tile(in, X, Z, &names);
        };
        io.store = [&](std::int64_t X, std::int64_t Z, WorldTile t) {
          t.X = X;
          t.Z = Z;
          t.window = grid.window(X, Z);
          store_tile(ph, std::move(t));
        };
        io.update = [&](std::int64_t X, std::int64_t Z, WorldTile t) { update_tile(ph, in, X, Z, std::move(t)); };
        io.threads = threads;
        io.cancelled = s.cancelled;
        io.seed = rep.seed;
        io.legend = world_legend(r, ph.first);
        io.scratch_dir = ph.folder.string();
        return io;
      };
      if (!root) {
        std::exception_ptr opened;  // a kernel here fails with it (rank 0 stops the phase)
        try {
          open_phase();
        } catch (...) {
          opened = std::current_exception();
        }
        const WorldStageIO io = stage_io();
        detail::TileFarm::serve(tr, threads, [&](const std::string& kernel) {
          if (opened) std::rethrow_exception(opened);
          return detail::make_farm_kernel(kernel, io, st);
        });
      }
      agree(tr, [&]() -> json {
        detail::TileFarm farm(tr);  // first: whatever happens, its end releases the other ranks
        struct Tally {  // the farm's tasks per rank, kept when the algorithm ends in any way
          detail::TileFarm& f;
          std::vector<std::int64_t>& by_rank;
          ~Tally() {
            f.end();
            const std::vector<std::int64_t> n = f.tasks_by_rank();
            for (std::size_t k = 0; k < n.size() && k < by_rank.size(); ++k) by_rank[k] += n[k];
          }
        } tally{farm, global_by_rank};
        open_phase();
        WorldStageIO io = stage_io();
        io.farm = &farm;
        // World files a stage makes (rivers.json, lakes.json) go into the world folder, atomically.
        FileOutput world_files(dir.string(), FileOutput::Mode::Immediate, FileOutput::Sync::Atomic);
        io.out = &world_files;
        io.points = [&](std::vector<Point> pts) {  // kept on disk too, for a resumed build
          std::error_code e2;
          fs::create_directories(points_dir, e2);
          write_or_throw(points_dir / phase_name(pk, ".json"), encode_world_points(ph.id, -1, -1, pts), s.out_path);
          global_points[int(ph.first)] = std::move(pts);
        };
        if (s.progress)
          io.progress = [&](double f) {  // the algorithm's share, kept from decreasing
            std::lock_guard<std::mutex> lock(m);
            if (!(f > phase_fraction)) return;
            phase_fraction = std::min(1.0, f);
            report(st.def->name, int(ph.first), 0.0);
          };
        {
          std::lock_guard<std::mutex> lock(m);
          phase_fraction = 0;
          t_phase = Clock::now();
          report(st.def->name, int(ph.first), 0.0);
        }
        tbb::task_arena arena(threads);  // the algorithm's tile work runs on the build's threads
        arena.execute([&] { s.algorithms.at(st.def->name)(io, st, int(ph.first)); });
        stage_ms[ph.first] += ms_since(t_phase);
        {
          std::lock_guard<std::mutex> lock(m);
          if (phase_fraction < 1) {
            phase_fraction = 1;
            report(st.def->name, int(ph.first), 0.0);
          }
          phase_fraction = -1;
          global_done += grid.count();
          global_seconds += ms_since(t_phase) / 1e3;
        }
        if (!last) {
          write_or_throw(ph.folder / "complete", "", s.out_path);
          remove_phase_tiles(in.folder);  // no later phase reads them
        }
        return json();
      });
      continue;
    }
    // A local phase: stages [first, end), resumed from the previous phase's tiles when first > 0.
    Recipe rp = r;
    rp.stages.resize(ph.end);
    for (std::size_t g : globals)
      if (g < ph.end) rp.stages[g].stage = placeholder;
    std::int64_t phalo = 0;
    for (const RecipeStage& st : rp.stages) {
      const Reach re = st.stage->reach(frame);
      if (re.locality == Locality::Neighbourhood) phalo += std::max(0, re.halo);
    }
    const Phase* in = pk > 0 ? &phases[pk - 1] : nullptr;
    const bool makes_points = phase_makes_points(ph);
    const std::vector<BiomeInfo> legend = in ? world_legend(r, ph.first) : std::vector<BiomeInfo>();
    auto do_tile = [&](std::int64_t k) {
      if (cancelled()) throw Cancelled();
      const std::int64_t X = k % grid.tiles_x, Z = k / grid.tiles_x;
      const WorldGrid::Window w = grid.window(X, Z);
      TileResult res;
      res.k = k;
      res.first = ph.first;
      // A finished tile of this world and phase: verified and skipped.
      {
        WorldTile t;
        const std::string bytes = existing(ph, X, Z, last ? &t : nullptr);
        if (!bytes.empty() && (!makes_points || read_tile_points(pk, X, Z))) {
          if (last) {
            res.overview = overview_of(t);
            res.crc = detail::tile_checksum(bytes);
            res.bytes = bytes.size();
          }
          return res;
        }
      }
      RunOptions opt;
      opt.threads = run_threads;
      opt.window = frame.window(w.ix0, w.iz0, w.nx, w.nz);
      opt.cancelled = s.cancelled;
      opt.progress = [&](std::string_view name, double f) {
        if (!s.progress) return;
        std::lock_guard<std::mutex> lock(m);
        const int stage = std::min(int(rp.stages.size()) - 1, int(f * double(rp.stages.size())));
        report(name == "done" ? std::string_view() : name, std::max(0, stage), at_once > 1 ? 0.0 : f);
      };
      Terrain snapshot;
      if (in) {
        // The grown window run() computes on (pipeline.cpp's work frame: each side grows by the
        // halo while inside the world), read from the previous phase's tiles.
        auto grow = [&](std::int64_t lo, int n, std::int64_t world_n, std::int64_t& out_lo, int& out_n) {
          std::int64_t a = lo, b = lo + n - 1;
          if (phalo > 0 && a > 0) a = std::max<std::int64_t>(0, a - phalo);
          if (phalo > 0 && b < world_n - 1) b = std::min<std::int64_t>(world_n - 1, b + phalo);
          out_lo = a;
          out_n = int(b - a + 1);
        };
        std::int64_t gx0, gz0;
        int gnx, gnz;
        grow(w.ix0, w.nx, grid.nx, gx0, gnx);
        grow(w.iz0, w.nz, grid.nz, gz0, gnz);
        const bool whole = w.ix0 == 0 && w.iz0 == 0 && w.nx == grid.nx && w.nz == grid.nz;
        snapshot = whole ? read_region(*in, 0, 0, w.nx, w.nz) : read_region(*in, gx0, gz0, gnx, gnz);
        snapshot.biomes = legend;  // tiles store no legend: the one the stages before leave (params alone)
        opt.resume = Resume{&snapshot, int(ph.first)};
      }
      RunResult run_res = run(rp, opt);
      snapshot = Terrain();
      WorldTile t;
      t.X = X;
      t.Z = Z;
      t.window = w;
      if (makes_points) {  // written before the tile, so that a tile on disk always has its points
        const std::vector<Point> owned = owned_world_points(run_res.terrain, grid, X, Z);
        try {
          point_outputs[pk]->put(points_file(pk, X, Z).filename().string(), encode_world_points(ph.id, X, Z, owned));
        } catch (const Error& e) {
          throw Error(s.out_path, e.message());
        }
      }
      t.layers = std::move(run_res.terrain.layers);
      run_res.terrain = Terrain();
      if (last) res.overview = overview_of(t);
      const std::string bytes = store_tile(ph, std::move(t));
      if (last) {
        res.crc = detail::tile_checksum(bytes);
        res.bytes = bytes.size();
      }
      res.built = true;
      for (const StageTiming& st : run_res.timings) {
        res.ms.push_back(st.ms);
        res.fused.push_back(st.fused);
      }
      if (s.after_tile) s.after_tile(X, Z);
      return res;
    };
    // The tiles are handed out one by one by rank 0 (WorkHandout) to `at_once` lanes on each rank;
    // each finished tile's result reaches rank 0 (apply_result). A lane that fails stops the round;
    // the first failure (rank 0's own, else the lowest rank's) is what every rank throws.
    detail::WorkHandout handout(tr, grid.count(), [&](int from, const std::string& bytes) {
      TileResult t = decode_result(bytes);
      if (t.k < 0 || t.k >= grid.count()) throw std::runtime_error("world transport: a result for tile " + std::to_string(t.k));
      std::lock_guard<std::mutex> lock(m);
      apply_result(std::move(t), last, from);
    });
    std::mutex fail_m;
    std::exception_ptr failed;
    auto lane = [&] {
      try {
        std::string sent;
        bool have = false;
        for (std::int64_t k; (k = handout.next(have ? &sent : nullptr)) >= 0;) {
          have = false;
          TileResult res = do_tile(k);
          if (res.built) {
            std::lock_guard<std::mutex> lock(m);
            ++built_here;
          }
          if (root) {
            std::lock_guard<std::mutex> lock(m);
            apply_result(std::move(res), last, 0);
          } else {
            sent = encode_result(res);
            have = true;
          }
        }
      } catch (...) {
        handout.stop();
        std::lock_guard<std::mutex> lock(fail_m);
        if (!failed) failed = std::current_exception();
      }
    };
    if (at_once > 1) {
      tbb::task_arena arena(at_once);
      arena.execute([&] {
        tbb::parallel_for(0, at_once, [&](int) { lane(); }, tbb::simple_partitioner());
      });
    } else {
      lane();
    }
    json status = outcome_of(failed);
    status["peak_rss"] = peak_rss_bytes();
    std::vector<std::string> statuses;
    std::exception_ptr finish_failed;
    try {
      statuses = handout.finish(status.dump(), failed != nullptr);
    } catch (...) {
      finish_failed = std::current_exception();
    }
    agree(tr, [&]() -> json {
      if (failed) std::rethrow_exception(failed);
      if (finish_failed) std::rethrow_exception(finish_failed);
      for (std::size_t k = 1; k < statuses.size(); ++k) {
        const json o = json::parse(statuses[k], nullptr, false);
        if (!o.is_object()) throw std::runtime_error("world transport: rank " + std::to_string(k) + " sent a malformed status");
        peak_memory = std::max(peak_memory, o.value("peak_rss", std::uint64_t(0)));
        rethrow_outcome(o, int(k));
      }
      if (!last) {
        write_or_throw(ph.folder / "complete", "", s.out_path);
        if (in) remove_phase_tiles(in->folder);  // no later phase reads them
      }
      return json();
    });
    if (last) final_done_in_memory = true;
  }
  rep.tiles_built = built_here;
  // Rank 0 finishes the store: the other ranks' tiles are written and their results are here.
  if (!root) return rep;
  if (!final_done_in_memory) {  // the last phase was a world algorithm: checksums and overview from its tiles
    // Read on the build's threads; only the height (the overview's) is decoded, every file's CRC-32
    // and framing checked.
    struct Final {
      std::uint32_t crc = 0;
      std::uint64_t bytes = 0;
      WorldTile tile;
    };
    std::vector<std::int64_t> all(static_cast<std::size_t>(grid.count()));
    for (std::int64_t k = 0; k < grid.count(); ++k) all[std::size_t(k)] = k;
    tbb::task_arena arena(threads);
    arena.execute([&] {
      detail::ordered_tiles<Final>(
          all,
          [&](std::int64_t k) {
            const std::int64_t X = k % grid.tiles_x, Z = k / grid.tiles_x;
            detail::TileParts parts;
            const std::string bytes = parsed(phases.back(), X, Z, parts);
            if (bytes.empty()) throw Error(s.out_path, "the world algorithm of the last stage left tile " + std::to_string(k) + " missing");
            Final f;
            f.crc = detail::tile_checksum(bytes);
            f.bytes = bytes.size();
            f.tile = parts.tile;
            for (std::size_t q = 0; q < parts.parts.size(); ++q)
              if (parts.parts[q].name == "height") {
                try {
                  f.tile.layers["height"] = detail::decode_tile_part(bytes, parts, q, tile_file(phases.back(), X, Z).string());
                } catch (const Error&) {
                  throw Error(s.out_path, "the world algorithm of the last stage left tile " + std::to_string(k) + " damaged");
                }
              }
            return f;
          },
          [&](std::int64_t k, Final f) {
            take_overview(f.tile);
            crcs[std::size_t(k)] = f.crc;
            sizes[std::size_t(k)] = f.bytes;
          });
    });
  }
  if (phase_memory) phase_memory->stop();
  rep.tiles_built = built;
  rep.tiles_skipped = skipped;
  for (std::size_t i = 0; i < r.stages.size(); ++i)
    rep.timings.push_back({r.stages[i].def->name, r.stages[i].label, stage_ms[i], fused[i]});
  for (std::uint64_t b : sizes) rep.store_bytes += b;

  // 8. Points, overview, report, then the manifest marks the build complete.
  {
    std::vector<std::vector<Point>> tile_points;
    bool any = false;
    for (std::size_t pk = 0; pk < phases.size(); ++pk) {
      const Phase& ph = phases[pk];
      if (ph.global) {
        if (global_points.count(int(ph.first))) continue;
        bool ok = false;
        const fs::path f = points_dir / phase_name(pk, ".json");
        const std::string bytes = detail::read_file_bytes(f.string(), ok);
        if (ok) {
          try {
            global_points[int(ph.first)] = decode_world_points(bytes, ph.id, -1, -1, f.string());
          } catch (const Error&) {  // another world's: this one's stage made no points
          }
        }
        continue;
      }
      if (!phase_makes_points(ph)) continue;
      any = true;
      for (std::int64_t k = 0; k < grid.count(); ++k) {
        std::optional<std::vector<Point>> p = read_tile_points(pk, k % grid.tiles_x, k / grid.tiles_x);
        if (!p) throw Error(s.out_path, "the points of tile " + std::to_string(k) + " (" + points_file(pk, k % grid.tiles_x, k / grid.tiles_x).string() +
                                            ") are missing or damaged; run the build again");
        if (!p->empty()) tile_points.push_back(std::move(*p));
      }
    }
    if (any || !global_points.empty()) {
      try {
        FileOutput point_files(dir.string(), FileOutput::Mode::Immediate, FileOutput::Sync::Durable);
        rep.point_files = write_world_points(merge_world_points(r, tile_points, global_points), frame, point_files);
      } catch (const Error& e) {
        throw Error(s.out_path, e.message());
      }
    }
  }
  try {
    overview->write_png(dir.string(), frame.spacing_m * step, frame.height_m, frame.sea_level);
  } catch (const Error& e) {
    throw Error(s.out_path, e.message());
  }
  // The largest of any rank; the high-water mark the kernel reports may lag this process's resident
  // size as sampled per phase.
  rep.peak_memory_bytes = std::max(peak_rss_bytes(), peak_memory);
  if (phase_memory)
    for (std::size_t pk = 0; pk < phases.size(); ++pk) rep.peak_memory_bytes = std::max(rep.peak_memory_bytes, phase_memory->peak(pk));
  rep.total_ms = ms_since(t_start);
  // Per stage: its time and its phase; per phase: its stages and rank 0's resident peak while it ran
  // (a resumed build's skipped phases: none).
  std::vector<std::size_t> phase_of(r.stages.size(), 0);
  json phase_list = json::array();
  for (std::size_t pk = 0; pk < phases.size(); ++pk) {
    json names = json::array();
    for (std::size_t i = phases[pk].first; i < phases[pk].end; ++i) phase_of[i] = pk, names.push_back(r.stages[i].def->name);
    json e = {{"stages", names}, {"global", phases[pk].global}, {"skipped", bool(phase_skipped[pk])}};
    if (phase_memory && !phase_skipped[pk]) e["peak_memory_bytes"] = phase_memory->peak(pk);
    phase_list.push_back(e);
  }
  json st = json::array();
  for (std::size_t i = 0; i < rep.timings.size(); ++i) {
    const auto& t = rep.timings[i];
    json e = {{"stage", t.name}, {"label", t.label}, {"ms", t.ms}, {"phase", phase_of[i]}};
    if (t.fused) e["fused"] = true;
    if (phase_memory && !phase_skipped[phase_of[i]]) e["phase_peak_memory_bytes"] = phase_memory->peak(phase_of[i]);
    st.push_back(e);
  }
  const json report_doc = {
      {"world_id", rep.world_id},
      {"seed", rep.seed},
      {"size", {grid.nx, grid.nz}},
      {"tile", grid.tile},
      {"tiles", {{"total", grid.count()}, {"phases", phases.size()}, {"built", built}, {"skipped", skipped}, {"at_once", at_once}, {"built_by_rank", built_by_rank}, {"global_solves_by_rank", global_by_rank}}},
      {"performance",
       {{"threads", threads},
        {"ranks", tr.size()},
        {"transport", tr.description()},
        {"stages", st},
        {"phases", phase_list},
        {"total_ms", rep.total_ms},
        {"peak_memory_bytes", rep.peak_memory_bytes},
        {"estimated_memory_bytes", rep.tile_memory_bytes}}},
      {"store_bytes", rep.store_bytes},
      {"estimated_store_bytes", rep.estimated_store_bytes},  // the finished store's part, comparable with store_bytes
      {"estimated_disk_bytes", rep.estimated_bytes}};         // all the build needs at most (stores that coexist, scratch)
  write_or_throw(dir / "report.json", report_doc.dump(2) + "\n", s.out_path);
  // The tiles array is written as text, one tile at a time, in the layout dump(1) gives: a world of
  // many tiles would otherwise hold a JSON node per number (hundreds of bytes per tile).
  manifest["status"] = "complete";
  manifest["tiles"] = json::array();
  std::string text = manifest.dump(1);
  const std::string empty_tiles = "\"tiles\": []\n}";
  if (text.size() < empty_tiles.size() || text.compare(text.size() - empty_tiles.size(), empty_tiles.size(), empty_tiles) != 0)
    throw std::logic_error("world.json: the tiles array is not last");
  text.resize(text.size() - 3);  // up to and including "tiles": [
  text += "\n";
  // Streamed into the file (temporary, fsync, rename) in pieces of about 64 KiB: the listing of a
  // world of many tiles (about 200 bytes each) is never whole in memory.
  try {
    FileOutput out(dir.string(), FileOutput::Mode::Immediate, FileOutput::Sync::Durable);
    std::unique_ptr<OutputStream> file = out.open("world.json");
    for (std::int64_t k = 0; k < grid.count(); ++k) {
      const std::int64_t X = k % grid.tiles_x, Z = k / grid.tiles_x;
      const WorldGrid::Window w = grid.window(X, Z);
      const json one = {{"tile", {X, Z}},
                        {"window", {w.ix0, w.iz0, w.nx, w.nz}},
                        {"crc32", detail::hex32(crcs[std::size_t(k)])},
                        {"bytes", sizes[std::size_t(k)]}};
      const std::string body = one.dump(1);  // indented by two levels below
      text += "  ";
      for (char c : body) {
        text += c;
        if (c == '\n') text += "  ";
      }
      text += k + 1 < grid.count() ? ",\n" : "\n";
      if (text.size() >= 65536) {
        file->write(text);
        text.clear();
      }
    }
    text += " ]\n}\n";
    file->write(text);
    file->close();
  } catch (const Error& e) {
    throw Error(s.out_path, e.message());
  }
  for (std::size_t k = 0; k + 1 < phases.size(); ++k) remove_phase_folder(phases[k].folder);
  return rep;
}

}  // namespace relief
