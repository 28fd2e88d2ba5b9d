#pragma once
// FileOutput and the commit machinery: each file is written to a temporary name in the target
// directory and renamed into place, so a crash or an error never leaves half a file where a
// previous good file stood; OnCommit outputs make a whole run's files visible together.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "relief/output_interface.hpp"

namespace relief {

// Temporary files (FileOutput, write_file_atomic) are named ".NAME.tmp-PID-XXXXXX" beside their
// target. For a front end's signal handling (the CLI on SIGINT/SIGTERM): removes every temporary
// file this process has not yet renamed into place and returns true; from then on no temporary is
// created and no commit starts (the caller exits). While a commit's renames are under way (they
// are its point of no return) it removes nothing and returns false: the caller lets the commit
// finish and asks again, or lets the run end. Either way the folder holds all-old or all-new
// files. Async-signal-unsafe: call it from a normal thread (e.g. one that sigwait()s).
bool remove_live_temporaries() noexcept;
// How many outputs have begun replacing their files (FileOutput::publish) in this process, ever:
// a front end that commits once (the CLI's `generate`) knows from it whether its commit has begun.
std::uint64_t commits_published() noexcept;
// Removes the temporary files in `dir` left by processes that no longer run (killed, e.g. by
// SIGKILL, before they could clean up): only regular files named as above whose PID is not a
// running process. A zombie (a killed process its parent has not reaped yet: state Z or X in
// /proc/PID/stat, as the ranks of a SIGKILLed mpirun are for a while) counts as not running.
// Returns how many it removed. FileOutput calls it on its folder when created.
std::size_t remove_dead_temporaries(const std::string& dir);

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
  // Immediate mode: stop listing the written paths (written() stays empty; bytes_written() still
  // counts), so that an output writing very many files (a world's tile store) keeps flat memory.
  void forget_written() {
    std::lock_guard<std::mutex> lock(mutex_);
    listing_ = false;
    any_written_ = any_written_ || !written_.empty();
    written_.clear();
    written_.shrink_to_fit();
  }
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
  bool listing_ = true;       // written_ is kept (forget_written turns it off)
  bool any_written_ = false;  // a file was made visible while not listing
  std::uint64_t bytes_ = 0;
};

// Atomically writes `bytes` to `path` (temporary file in the same directory, then rename).
void write_file_atomic(const std::string& path, std::string_view bytes);

}  // namespace relief
