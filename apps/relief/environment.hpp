#pragma once
// What the front ends read from the environment and pass to the library, which reads none:
//   RELIEF_PRESETS, XDG_CONFIG_HOME, HOME  the user preset folders (relief::user_preset_dirs)
//   RELIEF_FONT                            the contact sheet's caption font (relief::contact_sheet_png)
#include <cstdlib>
#include <string>
#include <vector>

#include "relief/recipe.hpp"

namespace relief::cli {

inline std::vector<std::string> env_preset_dirs() {
  return user_preset_dirs(std::getenv("RELIEF_PRESETS"), std::getenv("XDG_CONFIG_HOME"), std::getenv("HOME"));
}

// "" when RELIEF_FONT is unset or empty (the library's default font).
inline std::string env_caption_font() {
  const char* f = std::getenv("RELIEF_FONT");
  return f ? f : "";
}

}  // namespace relief::cli
