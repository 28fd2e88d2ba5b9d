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
//   POST /api/volume    {recipe, layers?}   the recipe's volume (caves, overhangs, arches) as
//                                   caves.glb (model/gltf-binary: one node per chunk, vertex colours,
//                                   metres, y up, sea surface at y = 0), by relief::generate's caves
//                                   writer on the cached terrain; header X-Relief-Timings
//                                   {generate_ms, first_stage, mesh_ms, server_ms}. A recipe without a
//                                   volume stage is a 400 naming `stages`. /api/generate's header says
//                                   whether its terrain has a volume ("volume": true). Volume requests
//                                   run in a lane of their own per client: they supersede only that
//                                   client's older volume requests.
//   POST /api/upload?name=NAME   the raw bytes of an image (PNG 8/16-bit, OpenEXR, Relief's .r16,
//                                GeoTIFF); needs X-Relief-Client. {name, path: "upload:NAME", width,
//                                height, format, bytes, session_bytes, limits}. An image stage's
//                                "path": "upload:NAME" then reads it (from memory) in that client's
//                                requests; the same NAME again replaces it.
//   POST /api/save      {recipe}    a zip of recipe.json and the uploads it names, its paths "NAME"
//                                   (relative to recipe.json: `relief generate recipe.json` reads them)
//   GET  /api/stats                 {running, admitted_bytes, work_budget_bytes, limits, cancelled,
//                                   refused}: what runs now and why work was stopped or refused
// Errors are JSON {"error": "path: message", "path": "path"} with a 4xx status; 409 means that a
// newer request of the same client (header X-Relief-Client) superseded this one. An internal
// failure (not the request's fault) is a 500 with {"error": "internal error: …"}.
//
// What the studio bounds (StudioSettings; `relief studio --help`). Generate, steps, export and volume:
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
//   * uploads: one file at most max_upload_bytes and max_upload_pixels (checked from its header
//     before decoding); one session's uploads at most max_session_upload_bytes held (bytes + 4 per
//     pixel); beyond max_upload_total_bytes for all sessions, the uploads of the sessions least
//     recently seen are dropped. Bytes that are not an image the studio reads: 415.
//   * files: the server never opens a file a request names (image paths other than "upload:NAME",
//     colour textures: 400 naming the field); uploads are decoded from memory.
// Work stops at the next check: between stages, and inside long stages and writers when they
// report progress (erosion rounds, flow phases, OBJ blocks), and between the row blocks of every
// row pass (at most 16 a pass). A long chain of fused row stages (more than 8 noise, island, … in
// a row) runs unfused, so that no pass holds more than 8 stages' work between two checks (the
// bytes are the same).
#include <cstddef>
#include <cstdint>
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
  // The process-wide buffer cache (relief/terrain.hpp: the large buffers of dropped layers, kept for
  // the next run) is held to the stage cache's budget here, and freed once no request has run for
  // this many seconds (0: never), so that an idle studio holds its stage cache, not spare buffers too.
  int cache_idle_s = 30;
  int threads = 0;                 // generation threads (0 = all cores)
  int max_stages = 64;             // stages per recipe (the presets have at most 10)
  int time_budget_s = 120;         // seconds a generate, steps or export request may run
  std::size_t work_mib = 0;        // memory budget of the requests running at once; 0 = automatic
  // Uploads (POST /api/upload): kept in memory per session (X-Relief-Client). An upload holds its
  // bytes plus its decoded raster (4 bytes per pixel); the limits are 413s naming the limit.
  std::size_t max_upload_bytes = std::size_t(32) << 20;           // one file's bytes
  std::uint64_t max_upload_pixels = std::uint64_t(4097) * 4097;   // one file's pixels (read from its header)
  std::size_t max_session_upload_bytes = std::size_t(256) << 20;  // held by one session's uploads
  std::size_t max_upload_total_bytes = std::size_t(1) << 30;      // held by all sessions (least recently used dropped)
};

// The memory budget for requests running at once (StudioSettings::work_mib): work_mib MiB, or when
// 0, a quarter of physical memory but at most 4 GiB (4 GiB when the memory is unknown).
std::uint64_t work_budget_bytes(const StudioSettings& s);

// Serves until SIGINT/SIGTERM; returns the exit code. Throws relief::Error when it cannot bind.
int run_studio(const StudioSettings& s);

}  // namespace relief::cli
