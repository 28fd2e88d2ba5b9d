#pragma once
// Stages: free functions `apply(Terrain&, const Params&, const Context&)` with typed params.
//
// A StageDef describes one stage type: its name, one-line summary, locality (pointwise stages
// are pure functions of world position and may be evaluated on any window; neighbourhood stages
// look `halo` samples around each sample; global stages need the whole map), its parameter table,
// and a factory that parses a recipe object into a ready-to-run Stage.
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
  Locality locality = Locality::Pointwise;
  int halo = 0;  // samples looked at around each sample (Neighbourhood)
  std::vector<ParamInfo> params;
  std::function<std::unique_ptr<Stage>(const json& obj, const std::string& path)> parse;
  json to_json() const;  // for `relief explain --json` and the studio
};

// Builds a StageDef from a table and an apply function. The recipe key "stage" names the stage
// and "label" is an optional caption; every other key must be a parameter of the table.
template <class P>
StageDef make_stage(std::string name, std::string summary, Locality locality, int halo, Table<P> table,
                    void (*apply)(Terrain&, const P&, const Context&),
                    void (*validate)(const P&, const std::string& path) = nullptr) {
  struct Impl final : Stage {
    P p;
    std::shared_ptr<const Table<P>> table;
    void (*fn)(Terrain&, const P&, const Context&) = nullptr;
    void apply(Terrain& t, const Context& ctx) const override { fn(t, p, ctx); }
    json params() const override { return table->write(p); }
  };
  auto shared = std::make_shared<const Table<P>>(std::move(table));
  StageDef d;
  d.name = std::move(name);
  d.summary = std::move(summary);
  d.locality = locality;
  d.halo = halo;
  d.params = shared->infos();
  d.parse = [shared, apply, validate](const json& obj, const std::string& path) -> std::unique_ptr<Stage> {
    auto s = std::make_unique<Impl>();
    s->p = shared->read(obj, path, {"stage", "label"});
    if (validate) validate(s->p, path);
    s->table = shared;
    s->fn = apply;
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
