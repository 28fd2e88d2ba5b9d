#pragma once
// Output: where writers put their files, whole (put) or in pieces, in order, through an
// OutputStream (open), so that a large file (the OBJ's text) never has to be whole in memory; and
// MemoryOutput, the in-memory one (the studio, tests). Files on disk: relief/file_output.hpp.
#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

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

class MemoryOutput final : public Output {
 public:
  void put(const std::string& filename, std::string bytes) override { files[filename] = std::move(bytes); }
  std::map<std::string, std::string> files;
};

}  // namespace relief
