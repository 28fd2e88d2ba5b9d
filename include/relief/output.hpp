#pragma once
// Writers: take a Terrain and produce bytes, in memory (the studio) or as files (the CLI).
//
// A writer emits named files into an Output, either whole (put) or in pieces, in order, through an
// OutputStream (open), so that a large file (the OBJ's text) never has to be whole in memory.
// FileOutput writes each file to a temporary name in the target directory and renames it into
// place, so a crash or an error never leaves half a file where a previous good file stood.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "relief/export.hpp"
#include "relief/params.hpp"
#include "relief/terrain.hpp"

namespace relief {

// One file written in pieces, in order. close() finishes it (for a FileOutput: the data is in the
// temporary file; it becomes visible as the real name at once or at commit(), see FileOutput). A
// stream destroyed without close() (e.g. unwinding after an Error) leaves no file behind.
class OutputStream {
 public:
  virtual ~OutputStream() = default;
  virtual void write(std::string_view bytes) = 0;
  virtual void close() = 0;
};

class Output {
 public:
  virtual ~Output() = default;
  virtual void put(const std::string& filename, std::string bytes) = 0;
  // A file written in pieces. `size_hint` (bytes, 0 = unknown) lets an in-memory output reserve
  // room once. The default collects the pieces in memory and put()s them at close().
  virtual std::unique_ptr<OutputStream> open(const std::string& filename, std::size_t size_hint = 0);

  // Committing, in two phases, so that several outputs can change together (relief::generate
  // commits the output folder, the step pictures and a saved recipe as one): prepare() finishes
  // every pending file (and, when durable, flushes it) and throws Error if one cannot be written —
  // then no file has been replaced; publish() makes the prepared files visible. Outputs that
  // write at once (MemoryOutput, FileOutput in Immediate mode) do nothing in either.
  virtual void prepare() {}
  virtual void publish() {}
  void commit() {
    prepare();
    publish();
  }
};

// Commits several outputs as one: prepares every one of them, then publishes every one. An Error
// while preparing leaves every output's visible files as they were.
void commit_all(const std::vector<Output*>& outputs);

// Temporary files (FileOutput, write_file_atomic) are named ".NAME.tmp-PID-XXXXXX" beside their
// target. For a front end's signal handling (the CLI on SIGINT/SIGTERM): removes every temporary
// file this process has not yet renamed into place, waiting first for a commit's renames that are
// under way, so the folder holds all-old or all-new files and no temporaries. Async-signal-unsafe:
// call it from a normal thread (e.g. one that sigwait()s), then exit.
void remove_live_temporaries() noexcept;
// Removes the temporary files in `dir` left by processes that no longer run (killed, e.g. by
// SIGKILL, before they could clean up): only regular files named as above whose PID is not a
// running process. Returns how many it removed. FileOutput calls it on its folder when created.
std::size_t remove_dead_temporaries(const std::string& dir);

class MemoryOutput final : public Output {
 public:
  void put(const std::string& filename, std::string bytes) override { files[filename] = std::move(bytes); }
  std::map<std::string, std::string> files;
};

// Writes into `dir`, created (with missing parents) by the first file, so that a run that fails
// before writing anything leaves the file system unchanged. The constructor already throws
// Error("output", …) when the directory could not be created or written (its nearest existing
// ancestor is not a writable directory), and removes temporary files that dead runs left in it
// (remove_dead_temporaries). put() and open() may be called from several threads at once.
//
// Mode::Immediate: each put() (or stream close()) is atomic on its own: temporary file, (fsync,)
//   rename. A second file of the same name replaces the first.
// Mode::OnCommit: put() and streams write their temporary files at once (so writing overlaps the
//   encoding of other files), but every file becomes visible only at commit(), which renames them
//   into place in name order. Destroying the output without commit() (an Error in any writer)
//   removes the temporary files: a failed run changes no file. Two files of the same name are an
//   Error (two writers would race for it).
//
// Sync::Durable (the default) flushes each file to the disk (fsync) before its rename, so the new
// contents survive a power cut or kernel crash too; OnCommit starts each file's write-back as soon
// as it is finished. Sync::Atomic skips the flush: every file is still all-old or all-new for any
// failure of this process, and the kernel writes the data back on its own schedule. The flush
// costs the disk's write time, which for large meshes is most of a run (0.35 s for a 214 MB OBJ on
// the project's machine), so the CLI uses Atomic for generated files unless asked (`--sync`): they
// are reproducible from report.json's recipe and seed.
class FileOutput final : public Output {
 public:
  enum class Mode { Immediate, OnCommit };
  enum class Sync { Durable, Atomic };
  explicit FileOutput(std::string dir, Mode mode = Mode::Immediate, Sync sync = Sync::Durable);
  ~FileOutput() override;
  FileOutput(const FileOutput&) = delete;
  FileOutput& operator=(const FileOutput&) = delete;

  void put(const std::string& filename, std::string bytes) override;
  std::unique_ptr<OutputStream> open(const std::string& filename, std::size_t size_hint = 0) override;
  // OnCommit: commit() (Output) makes every finished file visible: prepare() closes (Durable:
  // fsyncs) them all and throws Error("output", …) if a file cannot be written or made durable —
  // then no file has been replaced and the temporary files are gone; publish() renames them into
  // place in name order. Streams still open are not part of it. Immediate: both do nothing.
  void prepare() override;
  void publish() override;
  const std::vector<std::string>& written() const { return written_; }  // visible paths, in order
  std::uint64_t bytes_written() const { return bytes_; }

  // A finished temporary file waiting for commit(): its descriptor stays open until then.
  struct Pending {
    std::string filename, tmp, path;
    int fd = -1;
    std::uint64_t bytes = 0;
  };

 private:
  friend class FileOutputStream;
  std::string checked_path(const std::string& filename) const;
  void create_directory();  // on the first file (thread-safe)
  void finished(Pending p);  // a temporary file is complete: rename now or keep for commit()

  std::string dir_;
  Mode mode_;
  Sync sync_;
  std::mutex mutex_;
  std::vector<Pending> pending_;
  std::vector<std::string> reserved_;  // OnCommit: names opened or put so far
  bool created_ = false;
  std::vector<std::string> made_dirs_;  // directories create_directory() made, deepest first
  std::vector<std::string> written_;
  std::uint64_t bytes_ = 0;
};

// Atomically writes `bytes` to `path` (temporary file in the same directory, then rename).
void write_file_atomic(const std::string& path, std::string_view bytes);

struct WriteContext {
  std::uint64_t seed = 0;
  ExportOptions options;  // writer options (relief/export.hpp), validated by the caller
  // How the caller names an option in writers' errors: the flag the user typed ("--engine") or
  // the recipe path ("export.engine", the default when empty).
  OptionPath option_path;
  json recipe;  // resolved recipe (for report.json)
  json report;  // timings etc. (for report.json)
  std::function<void(std::string_view what, double fraction)> progress;
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

// ---- encoders (also used directly by tests and the studio) ---------------------------------
// 16-bit greyscale PNG of a one-channel layer, value = round(clamp(v, 0, 1) · 65535).
std::string encode_png_gray16(const Layer& l, int nx, int nz);
// 8-bit RGB PNG of a three-channel layer in 0..1.
std::string encode_png_rgb8(const Layer& l, int nx, int nz);
// 8-bit RGB PNG of width × height pixels, 3 bytes per pixel, row-major (row 0 at the top). Uses the
// SUB filter on every row (fast for large, flat-coloured images such as tilemap renders).
std::string encode_png_rgb8(const std::uint8_t* rgb, int width, int height);
// 8-bit greyscale PNG of a one-channel layer in 0..1.
std::string encode_png_gray8(const Layer& l, int nx, int nz);
// Little-endian unsigned 16-bit raw, same mapping as the PNG.
std::string encode_r16(const Layer& l);
// PNG of ready pixels: `channels` 1 (grey), 2 (grey+alpha), 3 (RGB) or 4 (RGBA) samples of
// `bit_depth` 8 or 16 bits (16-bit samples in host byte order), rows top to bottom.
std::string encode_png_pixels(const void* pixels, std::size_t bytes, int width, int height, int bit_depth, int channels);

}  // namespace relief
