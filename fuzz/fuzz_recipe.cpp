// Fuzz target: a recipe as the command line reads it — JSON text, then `--set PATH=VALUE`
// overrides, then validation into a pipeline of stages (parse_recipe).
//
// Input: as recipe_input.hpp reads it (the recipe text, then optional "\n--set PATH=VALUE" lines).
// Passes when the input is accepted or refused with relief::Error; any other exception escapes
// (a crash for libFuzzer and the replay driver). Accepted recipes must also round-trip: the resolved
// recipe (what --save-recipe writes) parses again to the same resolved recipe.
#include <cstdint>
#include <cstdlib>
#include <cstdio>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"
#include "recipe_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const relief::json doc = relief::fuzz::recipe_document(data, size);
    const relief::Recipe r = relief::parse_recipe(doc);
    (void)relief::estimate_memory_bytes(r, true);
    (void)r.world.frame();
    const relief::json resolved = r.to_json();
    const relief::json again = relief::parse_recipe(resolved).to_json();
    if (again != resolved) {
      std::fprintf(stderr, "fuzz_recipe: the resolved recipe does not round-trip:\n%s\n%s\n", resolved.dump().c_str(),
                   again.dump().c_str());
      std::abort();
    }
  } catch (const relief::Error&) {
    // refused with a message naming the field: fine
  }
  return 0;
}
