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
//   GET  /api/stats                 {running, admitted_bytes, work_budget_bytes, limits, cancelled,
//                                   refused}: what runs now and why work was stopped or refused
// Errors are JSON {"error": "path: message", "path": "path"} with a 4xx status; 409 means that a
// newer request of the same client (header X-Relief-Client) superseded this one. An internal
// failure (not the request's fault) is a 500 with {"error": "internal error: …"}.
//
// What the studio bounds (StudioSettings; `relief studio --help`). Generate, steps and export:
//   * stages: a recipe of more than max_stages stages is a 400 naming `stages` (every endpoint);
//   * time: a request still running time_budget_s seconds after it started is stopped and answered
//     503 {"limit": "time_budget"} (no Retry-After: the same request would run as long again);
//   * the client: a request whose client closed its connection is stopped (nobody reads the answer);
//   * memory: each request is admitted with an estimate of its peak memory (estimate_memory_bytes
//     plus what the studio holds: the frame, the snapshots of /api/steps, the files and the zip of
//     an export); while the estimates of the requests running would exceed work_budget_bytes(),
//     a new one is refused with 503, a Retry-After header and {"limit": "memory"}. One request is
//     always admitted when nothing else runs (the per-request size limits bound it);
//   * CPU: at most two generations compute at once; later ones wait, and stop waiting when they
//     are cancelled for one of the reasons above;
//   * shutdown: SIGINT/SIGTERM cancels the work running (answered 503) and stops the server; a
//     stop that takes longer than 2 s (a request body still arriving, a stage between checks)
//     ends the process anyway, with exit code 0.
// Work stops at the next check: between stages, and inside long stages and writers when they
// report progress (erosion rounds, flow phases, OBJ blocks); the longest stretch without a check
// is one noise stage (about 2 s for a cellular one of 16 warped octaves at 1025² on one thread). A long chain of fused row stages (more than 8 noise, island, … in a row) runs
// unfused, so that it is checked between its stages too (the bytes are the same).
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
  int max_stages = 64;             // stages per recipe (the presets have at most 10)
  int time_budget_s = 120;         // seconds a generate, steps or export request may run
  std::size_t work_mib = 0;        // memory budget of the requests running at once; 0 = automatic
};

// The memory budget for requests running at once (StudioSettings::work_mib): work_mib MiB, or when
// 0, a quarter of physical memory but at most 4 GiB (4 GiB when the memory is unknown).
std::uint64_t work_budget_bytes(const StudioSettings& s);

// Serves until SIGINT/SIGTERM; returns the exit code. Throws relief::Error when it cannot bind.
int run_studio(const StudioSettings& s);

}  // namespace relief::cli
