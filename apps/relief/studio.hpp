#pragma once
// `relief studio`: a local web server with a live 3D preview of a recipe (apps/relief/studio.cpp).
//
// The page (web/, bundled into the binary at build time) talks to a small API:
//   GET  /api/presets               [{name, description, origin}]           (list_presets())
//   GET  /api/presets/NAME          the preset's recipe document             (load_preset())
//   GET  /api/params                the parameter table = `relief explain --json`
//   POST /api/resolve   {recipe}    {recipe: fully resolved recipe}          (validation only)
//   POST /api/generate  {recipe, layers?}   binary "RLF1" frame (studio_frame.hpp): layers, points,
//                                           per-stage timings
//   POST /api/steps     {recipe}    binary frame with every stage's height and colour
//   POST /api/export    {recipe, format, file?}   one file, or a zip of the format's files
// Errors are JSON {"error": "path: message", "path": "path"} with a 4xx status; 409 means that a
// newer request of the same client (header X-Relief-Client) superseded this one.
#include <cstddef>
#include <string>

namespace relief::cli {

struct StudioSettings {
  std::string host = "127.0.0.1";  // loopback unless asked otherwise
  int port = 8080;                 // 0 = any free port (printed)
  bool open = false;               // open the page with xdg-open
  int max_preview = 1025;          // samples per axis accepted by generate/steps
  int max_export = 2049;           // samples per axis accepted by export
  std::size_t max_body = 1u << 20; // request body limit in bytes
  std::size_t cache_mib = 512;     // stage-output cache budget
  int threads = 0;                 // generation threads (0 = all cores)
};

// Serves until SIGINT/SIGTERM; returns the exit code. Throws relief::Error when it cannot bind.
int run_studio(const StudioSettings& s);

}  // namespace relief::cli
