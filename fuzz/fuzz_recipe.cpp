// Fuzz target: a recipe as the command line reads it — JSON text, then `--set PATH=VALUE`
// overrides, then validation into a pipeline of stages (parse_recipe).
//
// Input: the recipe text, optionally followed by lines "\n--set PATH=VALUE" (each one override,
// applied in order, as `relief generate … --set PATH=VALUE` does).
// Passes when the input is accepted or refused with relief::Error; any other exception escapes
// (a crash for libFuzzer and the replay driver). Accepted recipes must also round-trip: the resolved
// recipe (what --save-recipe writes) parses again to the same resolved recipe.
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <string>
#include <vector>

#include "relief/pipeline.hpp"
#include "relief/recipe.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  static const std::string marker = "\n--set ";
  std::size_t at = text.find(marker);
  const std::string recipe_text = text.substr(0, at);
  std::vector<std::string> sets;
  while (at != std::string::npos) {
    const std::size_t from = at + marker.size();
    at = text.find(marker, from);
    sets.push_back(text.substr(from, at == std::string::npos ? std::string::npos : at - from));
  }
  try {
    relief::json doc = relief::parse_json(recipe_text, "recipe");  // as the CLI reads a recipe file
    for (const std::string& s : sets) relief::apply_override(doc, s);
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
