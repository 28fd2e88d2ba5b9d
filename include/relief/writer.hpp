#pragma once
// Writers: the registry of formats (`--formats` names), each a WriterDef that encodes a Terrain into
// named files of an Output. relief::generate (relief/generate.hpp) chooses and runs them; the
// encoders behind them are in relief/encode_mesh.hpp and relief/encode_image.hpp.
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "relief/export_options.hpp"
#include "relief/output_interface.hpp"
#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

struct WriteContext {
  std::uint64_t seed = 0;
  ExportOptions options;  // writer options (relief/export.hpp), validated by the caller
  // How the caller names an option in writers' errors: the flag the user typed ("--engine") or
  // the recipe path ("export.engine", the default when empty).
  OptionPath option_path;
  json recipe;  // resolved recipe (for report.json)
  json report;  // timings etc. (for report.json)
  std::function<void(std::string_view what, double fraction)> progress;
  // May be empty. Long writers (the volume's) call it between pieces of work and stop with
  // relief::Cancelled (pipeline.hpp) when it returns true; callable from any writer's thread
  // (relief::generate serialises it and forwards GenerateSettings::cancelled).
  std::function<bool()> cancelled;
};

struct WriterDef {
  std::string name;         // --formats name
  std::string description;  // one line
  std::vector<std::string> files;  // files it writes
  bool in_default_set = true;
  // Encodes the terrain and hands every file to the Output (names as in `files`; chunked and LOD
  // writers add numbered names).
  //   Reads:   the terrain (const; the layers and points the writer documents, `needs` naming
  //            those not every terrain has) and the context: options, seed, recipe and report.
  //   Throws:  relief::Error naming the offending field (an input the terrain lacks, an option the
  //            engine refuses, with ctx.option_path's spelling), Error("output", …) when a file
  //            cannot be encoded or written, std::bad_alloc. Files already handed to an OnCommit
  //            FileOutput stay invisible: relief::generate then commits nothing.
  //   Threads: relief::generate runs the chosen writers at once, one task each, on the same
  //            terrain and context with an Output of their own; a writer keeps no state between
  //            calls and may spread its own work over the caller's oneTBB arena. ctx.progress may
  //            be called from any of those threads (generate serialises it).
  //   Bytes:   a function of (terrain, ctx) alone: the same for any thread count and any order in
  //            which the writers finish (the report's timings aside).
  std::function<void(const Terrain&, const WriteContext&, Output&)> write;
  // When set and false for a terrain (e.g. no biome layer, no props), runs of the default set skip
  // the writer; named in --formats it runs anyway and its Error names what is missing.
  std::function<bool(const Terrain&)> applies = nullptr;
  // What the writer reads that not every terrain has: when it is named (not the default set or
  // "all") and applies() is false, relief::generate refuses with an Error saying this (e.g. "a flow
  // stage in the recipe (the 'flow' layer)"). Empty: the writer runs anyway (an empty props list is
  // a valid props.json).
  std::string needs;
  // Writers whose files this one's files name (the OBJ's MTL and the FBX name albedo.png): choosing
  // this writer chooses them too (relief::select_writers), so a written set is never incomplete.
  std::vector<std::string> implies;
};

const std::vector<WriterDef>& writer_registry();
const WriterDef* find_writer(std::string_view name);

}  // namespace relief
