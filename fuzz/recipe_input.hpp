#pragma once
// The input format shared by the recipe targets (fuzz_recipe, fuzz_generate): the recipe's JSON text,
// optionally followed by lines "\n--set PATH=VALUE", each one override applied in order, as
// `relief generate … --set PATH=VALUE` does. Returns the document after the overrides; throws
// relief::Error as the CLI's recipe reading does.
#include <cstddef>
#include <cstdint>
#include <string>

#include "relief/recipe.hpp"

namespace relief::fuzz {

inline json recipe_document(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  static const std::string marker = "\n--set ";
  std::size_t at = text.find(marker);
  json doc = parse_json(text.substr(0, at), "recipe");  // as the CLI reads a recipe file
  while (at != std::string::npos) {
    const std::size_t from = at + marker.size();
    at = text.find(marker, from);
    apply_override(doc, text.substr(from, at == std::string::npos ? std::string::npos : at - from));
  }
  return doc;
}

}  // namespace relief::fuzz
