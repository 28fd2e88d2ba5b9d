#pragma once
// Stages: free functions `apply(Terrain&, const Params&, const Context&)` with typed params.
//
// A StageDef describes one stage type: its name, one-line summary, how far it looks (its Reach:
// pointwise stages are pure functions of world position and may be evaluated on any window;
// neighbourhood stages look `halo` samples around each sample; global stages need the whole map),
// what it keeps in memory, its parameter table, and a factory that parses a recipe object into a
// ready-to-run Stage. run() (pipeline.hpp) enforces the reach on windows.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

// What a stage may use besides its params. Never a global RNG: randomness is a counter-based
// hash of (seed, stage index, position or index) — see relief/random.hpp.
struct Context {
  std::uint64_t seed = 0;   // the recipe's seed, 0..2^53−1
  int stage_index = 0;      // position of the running stage in the recipe
  // Progress of long work: (stage name, fraction 0..1 of this stage's work). May be empty. Called
  // from the calling thread only. run() (pipeline.hpp) turns it into the run's overall fraction.
  std::function<void(std::string_view, double)> progress;
  // Seed for this stage: mixes the recipe seed with the stage index (and a per-stage salt).
  std::uint64_t stage_seed(std::uint64_t salt = 0) const;
};

enum class Locality { Pointwise, Neighbourhood, Global };

// How far a stage looks. The contract a Neighbourhood stage promises: its output at a sample
// depends only on its input within `halo` samples (Chebyshev distance) of it, on the sample's world
// position, the seed and the params; at the border of the terrain it reads clamped / one-sided
// samples. So on a window grown by the halo (but never beyond the world's edge, where the whole
// map clamps too) it computes, away from the grown border, exactly the bits of the whole map.
// A Global stage depends on the whole map (drainage, droplets starting anywhere, per-map
// normalisation); `why` says what, for the error that refuses it on a window.
struct Reach {
  Locality locality = Locality::Pointwise;
  // Samples on each side (Neighbourhood), ≥ 0. A Global stage may give the bound of its reach
  // here too (hydraulic erosion: a droplet's longest path), for information: it is still refused
  // on a window, because its result there would not be the whole map's bits.
  int halo = 0;
  std::string why;  // Global: one line, e.g. "drainage depends on every sample down to the sea"
};
inline Reach pointwise() { return {}; }
inline Reach neighbourhood(int halo) { return {Locality::Neighbourhood, halo, {}}; }
inline Reach global(std::string why) { return {Locality::Global, 0, std::move(why)}; }

// What a stage keeps in memory, for estimate_memory_bytes (pipeline.hpp). tests/test_memory.cpp
// (MemoryEstimate) holds the estimate to the measured peak for the presets, so a stage that starts
// keeping more than declared here shows up there.
struct StageMemory {
  std::vector<std::pair<std::string, int>> layers;  // layers it leaves: name → channels (float each)
  std::string layer_param;  // it also leaves the one-channel layer named by this string parameter
  std::uint64_t scratch_per_sample = 0;  // bytes per sample held while it runs, released after
  // Optional: bytes its result adds while the files are encoded (e.g. the tilemap's rendered
  // image), from its resolved params (Stage::params()).
  std::function<std::uint64_t(const json& params)> encode_bytes;
};

// A row stage prepared for one run over one frame: it transforms the rows of one single-channel
// layer in place, sample by sample. Made by Stage::prepare_rows; run by Stage::apply and by
// run() (pipeline.hpp), which passes over the rows once for a chain of consecutive row stages so
// that each row is read and written once while it is in cache, whatever the chain's length.
class RowKernel {
 public:
  explicit RowKernel(std::string layer) : layer_(std::move(layer)) {}
  virtual ~RowKernel() = default;
  // The layer this kernel transforms (single channel, frame.count() samples).
  const std::string& layer() const { return layer_; }
  // Transforms row j (0 ≤ j < frame.nz): row[0 .. frame.nx). Output sample i depends only on
  // input sample i, the sample's world position, the seed and the params — never on the row's
  // neighbours, the order of calls or the thread. Called concurrently for distinct rows; never
  // throws.
  virtual void apply_row(int j, float* row) const = 0;

 private:
  std::string layer_;
};

class Stage {
 public:
  virtual ~Stage() = default;
  virtual void apply(Terrain& t, const Context& ctx) const = 0;
  virtual json params() const = 0;  // fully resolved params (defaults filled in)
  // How far this stage, with its params, looks on a grid like `f` (only f's cell size matters):
  // e.g. thermal erosion's halo grows with its distance_m, and colour relative to the map's
  // maximum is global. Defaults to pointwise.
  virtual Reach reach(const Frame& f) const;

  // Row interface (optional). A fusable stage is pointwise and reads and writes nothing but one
  // single-channel layer (RowKernel::layer()); apply(t, ctx) is exactly prepare_rows(t, ctx)
  // followed by apply_row on every row, so fused and unfused runs give identical bytes.
  virtual bool fusable() const { return false; }
  // For fusable stages (nullptr otherwise): validates the terrain as apply would (throwing
  // relief::Error, e.g. for a missing layer), creates the kernel's layer if the stage creates it,
  // precomputes everything that depends only on the frame, seed and params, and returns the
  // kernel. Must not read or change the values of any layer: run() prepares every stage of a
  // chain before the first row is transformed.
  virtual std::unique_ptr<RowKernel> prepare_rows(Terrain& t, const Context& ctx) const;
};

// Runs `k` on every row of its layer of `t`, row-parallel (results identical for any thread count).
void apply_rows(Terrain& t, const RowKernel& k);

struct StageDef {
  std::string name;
  std::string summary;
  // The declared reach with default params (`relief explain`); the parsed Stage::reach is the one
  // run() enforces. halo_rule says how a param-dependent halo is computed (empty if fixed).
  Locality locality = Locality::Pointwise;
  int halo = 0;  // samples looked at around each sample (Neighbourhood)
  std::string why_global;  // Global: why the stage needs the whole map
  std::string halo_rule;
  StageMemory memory;
  std::vector<ParamInfo> params;
  std::function<std::unique_ptr<Stage>(const json& obj, const std::string& path)> parse;
  json to_json() const;  // for `relief explain --json` and the studio
};

// Builds a StageDef from a table and an apply function. The recipe key "stage" names the stage
// and "label" is an optional caption; every other key must be a parameter of the table. `reach`
// is the stage's declared reach; `reach_of`, if given, computes the reach of parsed params on a
// grid (a halo in metres or steps, a mode that needs the whole map) and `halo_rule` describes it.
template <class P>
StageDef make_stage(std::string name, std::string summary, Reach reach, Table<P> table,
                    void (*apply)(Terrain&, const P&, const Context&),
                    void (*validate)(const P&, const std::string& path) = nullptr,
                    Reach (*reach_of)(const P&, const Frame&) = nullptr, std::string halo_rule = {}) {
  struct Impl final : Stage {
    P p;
    std::shared_ptr<const Table<P>> table;
    void (*fn)(Terrain&, const P&, const Context&) = nullptr;
    Reach declared;
    Reach (*reach_of)(const P&, const Frame&) = nullptr;
    void apply(Terrain& t, const Context& ctx) const override { fn(t, p, ctx); }
    json params() const override { return table->write(p); }
    Reach reach(const Frame& f) const override { return reach_of ? reach_of(p, f) : declared; }
  };
  auto shared = std::make_shared<const Table<P>>(std::move(table));
  StageDef d;
  d.name = std::move(name);
  d.summary = std::move(summary);
  d.locality = reach.locality;
  d.halo = reach.halo;
  d.why_global = reach.why;
  d.halo_rule = std::move(halo_rule);
  d.params = shared->infos();
  d.parse = [shared, apply, validate, reach, reach_of](const json& obj, const std::string& path) -> std::unique_ptr<Stage> {
    auto s = std::make_unique<Impl>();
    s->p = shared->read(obj, path, {"stage", "label"});
    if (validate) validate(s->p, path);
    s->table = shared;
    s->fn = apply;
    s->declared = reach;
    s->reach_of = reach_of;
    return s;
  };
  return d;
}

// Builds a fusable pointwise StageDef from a table and a prepare function (see Stage::prepare_rows);
// its apply runs the prepared kernel over every row.
template <class P>
StageDef make_row_stage(std::string name, std::string summary, Table<P> table,
                        std::unique_ptr<RowKernel> (*prepare)(Terrain&, const P&, const Context&),
                        void (*validate)(const P&, const std::string& path) = nullptr) {
  struct Impl final : Stage {
    P p;
    std::shared_ptr<const Table<P>> table;
    std::unique_ptr<RowKernel> (*prep)(Terrain&, const P&, const Context&) = nullptr;
    void apply(Terrain& t, const Context& ctx) const override { apply_rows(t, *prep(t, p, ctx)); }
    json params() const override { return table->write(p); }
    bool fusable() const override { return true; }
    std::unique_ptr<RowKernel> prepare_rows(Terrain& t, const Context& ctx) const override { return prep(t, p, ctx); }
  };
  auto shared = std::make_shared<const Table<P>>(std::move(table));
  StageDef d;
  d.name = std::move(name);
  d.summary = std::move(summary);
  d.locality = Locality::Pointwise;
  d.params = shared->infos();
  d.parse = [shared, prepare, validate](const json& obj, const std::string& path) -> std::unique_ptr<Stage> {
    auto s = std::make_unique<Impl>();
    s->p = shared->read(obj, path, {"stage", "label"});
    if (validate) validate(s->p, path);
    s->table = shared;
    s->prep = prepare;
    return s;
  };
  return d;
}

// Every stage Relief knows, in a stable order.
const std::vector<StageDef>& stage_registry();
// The stage named `name`, or nullptr.
const StageDef* find_stage(std::string_view name);

}  // namespace relief
