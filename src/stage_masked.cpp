// The optional `mask` parameter of the stages that change height (issue 19: "stages that change
// height take an optional mask parameter that scales their effect"), declared once here and given
// to those stages in stage_registry() (stage.cpp).
//
// With `mask` naming a one-channel layer m (0..1, e.g. written by the `mask` stage), the stage's
// result is blended with what the layer held before it ran, sample by sample:
//
//   out = before + clamp(m, 0, 1) · (stage(before) − before)
//
// so the stage acts fully where m ≥ 1 (its own bits) and not at all where m ≤ 0 (the old bits). The blend is pointwise, so it
// keeps the stage's reach (a pointwise stage stays pointwise and fused: its row kernel is wrapped;
// a neighbourhood or global stage keeps its halo or its refusal on windows). A stage without a
// mask (the default, "") is the stage itself: same object, same bytes, and its resolved params do
// not list `mask`, so saved recipes and reports of unmasked recipes are unchanged.
#include <algorithm>
#include <memory>
#include <vector>

#include "parallel.hpp"
#include "relief/error.hpp"
#include "stages.hpp"

namespace relief::stages {
namespace {

struct MaskField {
  std::string mask;
};

Table<MaskField> mask_table() {
  return {{text(&MaskField::mask, "mask",
                "Optional mask layer (0..1, e.g. from a mask stage): the stage acts fully where it is 1, not at all "
                "where it is 0, and in proportion between (\"\" = everywhere)")}};
}

// The layer the stage changes: a fixed name, or the value of a string parameter of the stage.
std::string changed_layer(const Stage& s, const std::string& fixed, const std::string& layer_param) {
  if (layer_param.empty()) return fixed;
  const json p = s.params();
  return p.contains(layer_param) && p[layer_param].is_string() ? p[layer_param].get<std::string>() : fixed;
}

// out = before + clamp(m) · (out − before), element-wise over n samples.
void blend(float* out, const float* before, const float* m, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    const float w = std::clamp(m[i], 0.0f, 1.0f);
    if (w < 1.0f) out[i] = before[i] + w * (out[i] - before[i]);  // w = 1 keeps the stage's own bits
  }
}

const Layer& mask_layer(const Terrain& t, const std::string& mask, const std::string& layer, const std::string& path) {
  if (mask == layer)
    throw Error(path, "the mask cannot be the layer the stage changes ('" + layer + "'): write the mask into another layer");
  auto it = t.layers.find(mask);
  if (it == t.layers.end() || it->second.channels != 1 || it->second.data.size() != t.frame.count())
    throw Error(path, "no one-channel layer '" + mask + "' (a stage before this one, e.g. a mask stage, must write it)");
  return it->second;
}

// The inner stage's row kernel, blended with the row it was given through the mask's row.
class MaskedKernel final : public RowKernel {
 public:
  MaskedKernel(std::unique_ptr<RowKernel> inner, const float* mask, int nx)
      : RowKernel(inner->layer()), inner_(std::move(inner)), mask_(mask), nx_(nx) {}
  void apply_row(int j, float* row) const override {
    thread_local std::vector<float> before;
    before.assign(row, row + nx_);
    inner_->apply_row(j, row);
    blend(row, before.data(), mask_ + std::size_t(j) * std::size_t(nx_), std::size_t(nx_));
  }

 private:
  std::unique_ptr<RowKernel> inner_;
  const float* mask_;
  int nx_;
};

class MaskedStage final : public Stage {
 public:
  MaskedStage(std::unique_ptr<Stage> inner, std::string mask, std::string layer, std::string path)
      : inner_(std::move(inner)), mask_(std::move(mask)), layer_(std::move(layer)), path_(std::move(path)) {}

  void apply(Terrain& t, const Context& ctx) const override {
    if (inner_->fusable()) {  // exactly prepare_rows + every row, as the contract of fusable stages says
      apply_rows(t, *prepare_rows(t, ctx));
      return;
    }
    mask_layer(t, mask_, layer_, path_);
    // What the layer held before (zeros where the stage creates it, as a created layer starts).
    std::vector<float> before;
    if (t.has(layer_)) before = t.get(layer_).data;
    inner_->apply(t, ctx);
    Layer& out = t.get(layer_);
    if (out.channels != 1 || out.data.size() != t.frame.count())
      throw Error(path_, "the mask applies to one-channel layers; '" + layer_ + "' is not one");
    if (before.size() != out.data.size()) before.assign(out.data.size(), 0.0f);
    const Layer& m = mask_layer(t, mask_, layer_, path_);  // looked up again: the stage may add layers
    const std::size_t nx = std::size_t(t.frame.nx);
    float* o = out.data.data();
    const float* b = before.data();
    const float* w = m.data.data();
    detail::parallel_rows(t.frame.nz, [&](int j) { blend(o + std::size_t(j) * nx, b + std::size_t(j) * nx, w + std::size_t(j) * nx, nx); });
  }
  json params() const override {
    json p = inner_->params();
    p["mask"] = mask_;
    return p;
  }
  Reach reach(const Frame& f) const override { return inner_->reach(f); }
  bool fusable() const override { return inner_->fusable(); }
  std::unique_ptr<RowKernel> prepare_rows(Terrain& t, const Context& ctx) const override {
    if (!inner_->fusable()) return nullptr;
    auto k = inner_->prepare_rows(t, ctx);  // creates the layer if the stage creates it
    const Layer& m = mask_layer(t, mask_, k->layer(), path_);
    return std::make_unique<MaskedKernel>(std::move(k), m.data.data(), t.frame.nx);
  }

 private:
  std::unique_ptr<Stage> inner_;
  std::string mask_, layer_, path_;
};

}  // namespace

StageDef masked(StageDef d, std::string layer, std::string layer_param) {
  static const Table<MaskField> table = mask_table();
  d.params.push_back(table.infos().front());
  auto inner_parse = std::move(d.parse);
  d.parse = [inner_parse, layer, layer_param](const json& obj, const std::string& path) -> std::unique_ptr<Stage> {
    if (!obj.is_object() || !obj.contains("mask")) return inner_parse(obj, path);
    MaskField m;
    table.fields.front().read(m, obj.at("mask"), path.empty() ? "mask" : path + ".mask");
    json rest = obj;
    rest.erase("mask");
    std::unique_ptr<Stage> s = inner_parse(rest, path);
    if (m.mask.empty()) return s;
    const std::string target = changed_layer(*s, layer, layer_param);
    return std::make_unique<MaskedStage>(std::move(s), m.mask, target, path.empty() ? "mask" : path + ".mask");
  };
  return d;
}

}  // namespace relief::stages
