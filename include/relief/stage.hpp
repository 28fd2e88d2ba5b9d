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
  // Progress of long work: (stage name, fraction 0..1). May be empty. Called from the calling
  // thread only.
  std::function<void(std::string_view, double)> progress;
  // Seed for this stage: mixes the recipe seed with the stage index (and a per-stage salt).
  std::uint64_t stage_seed(std::uint64_t salt = 0) const;
};

enum class Locality { Pointwise, Neighbourhood, Global };

class Stage {
 public:
  virtual ~Stage() = default;
  virtual void apply(Terrain& t, const Context& ctx) const = 0;
  virtual json params() const = 0;  // fully resolved params (defaults filled in)
};

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

// Every stage Relief knows, in a stable order.
const std::vector<StageDef>& stage_registry();
// The stage named `name`, or nullptr.
const StageDef* find_stage(std::string_view name);

}  // namespace relief
