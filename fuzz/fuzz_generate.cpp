// Fuzz target: an accepted recipe runs, so stage code and writers meet fuzzed parameters too.
//
// Input: as recipe_input.hpp reads it (the recipe text, then optional "\n--set PATH=VALUE" lines),
// as fuzz_recipe. A recipe parse_recipe accepts is then generated at a tiny size (each axis clamped
// to 2..33 samples, keeping what the input asked below that) with one thread, through
// relief::generate into memory with the recipe's own export block, or every writer ("all") when it
// has none. Recipes of more than 8 stages are skipped (parse-only coverage is fuzz_recipe's), and
// the run is cancelled between stages after two seconds, so one slow input cannot stall the
// fuzzer. Passes when the run succeeds, is cancelled, or is refused with relief::Error (a writer's
// or engine's refusal of a legal recipe is fine); any other exception escapes, and a crash, a
// sanitizer report or a non-finite height aborts.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "recipe_input.hpp"
#include "relief/generate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const relief::json doc = relief::fuzz::recipe_document(data, size);
    relief::GenerateSettings s;
    s.recipe = relief::parse_recipe(doc);
    if (s.recipe.stages.size() > 8) return 0;
    s.recipe.world.nx = std::clamp(s.recipe.world.nx, relief::kMinSize, 33);
    s.recipe.world.nz = std::clamp(s.recipe.world.nz, relief::kMinSize, 33);
    if (!s.recipe.seed) s.recipe.seed = 1;
    if (!doc.is_object() || !doc.contains("export")) s.formats = "all";
    s.threads = 1;
    const auto start = std::chrono::steady_clock::now();
    s.cancelled = [start] { return std::chrono::steady_clock::now() - start > std::chrono::seconds(2); };
    relief::MemoryOutput out;
    const relief::Generated g = relief::generate_keep(std::move(s), out);
    if (g.terrain.has("height"))
      for (float h : g.terrain.get("height").data)
        if (!std::isfinite(h)) {
          std::fprintf(stderr, "fuzz_generate: a non-finite height\n");
          std::abort();
        }
  } catch (const relief::Error&) {
    // refused with a message naming the field: fine
  } catch (const relief::Cancelled&) {
    // took too long for a fuzz input: fine
  }
  return 0;
}
