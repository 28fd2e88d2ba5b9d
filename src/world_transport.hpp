#pragma once
// The message passing a distributed world build needs (relief/world.hpp, WorldSettings::mpi_module;
// what runs where: the top of src/world.cpp), behind a small interface so that the single-process
// build needs no MPI at run time:
//   - in_process_transport(): rank 0 of 1, no messages (every build without MPI);
//   - load_mpi_transport(): the relief_mpi module (src/world_mpi.cpp, built only when CMake finds
//     MPI, linked to libmpi), loaded with dlopen; the relief binary and relief_core never link MPI.
// On top of it, WorkHandout hands out the tasks of one round (the tiles of a local phase)
// dynamically from rank 0, and carries each finished task's small result back to rank 0.
//
// Contracts of WorldTransport (both implementations):
//   - ranks 0..size()-1; rank 0 is the root (writes the manifest, runs the world algorithms);
//   - messages are byte strings (at most 2^31-1 bytes), matched by (source, tag) in send order
//     between two ranks (WorkHandout uses tags 1 and 2; nothing else sends point to point);
//   - calls may come from several threads, never at the same time (callers serialise them);
//   - every wait sleeps between polls (10 µs growing to 0.2 or 1 ms) rather than spinning, so ranks
//     waiting for rank 0 leave the cores to it;
//   - broadcast() and barrier() are collective: every rank calls them in the same order.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace relief::detail {

class WorldTransport {
 public:
  virtual ~WorldTransport() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Sends `bytes` to rank `to` (returns once the buffer may be reused).
  virtual void send(int to, int tag, const std::string& bytes) = 0;
  // A message with `tag` from any rank if one has arrived: true, its source and bytes; else false.
  virtual bool try_receive(int tag, int& from, std::string& bytes) = 0;
  // Waits for the next message with `tag` from rank `from`.
  virtual std::string receive(int from, int tag) = 0;
  // Rank 0's `bytes` to every rank (collective).
  virtual void broadcast(std::string& bytes) = 0;
  virtual void barrier() = 0;
  // "Open MPI 4.1.4, MPI 3.1" or "in-process".
  virtual std::string description() const = 0;
};

// Sleeps between polls: 10 µs, doubling to 200 µs (a server answers within about 0.2 ms, about 1 %
// of a 129² tile's time, for about 5000 cheap wake-ups a second). Reset it after useful work.
struct Backoff {
  int us = 10;
  void wait() {
    std::this_thread::sleep_for(std::chrono::microseconds(us));
    us = std::min(200, us * 2);
  }
};

// Rank 0 of 1.
std::unique_ptr<WorldTransport> in_process_transport();
// Loads the module at `module_path` (dlopen; kept loaded until the process exits) and starts MPI
// (MPI_Init_thread, MPI_THREAD_SERIALIZED; MPI_Finalize when the transport is destroyed). Throws
// Error(field, …) when the file is missing, is not a relief_mpi module of this version, or MPI
// does not start. MPI starts once per process: a second call throws.
std::unique_ptr<WorldTransport> load_mpi_transport(const std::string& module_path, const std::string& field);

// The module's one entry point, `relief_world_mpi_open`: on success a new transport (owned by the
// caller); on failure nullptr and a message in err[0..err_len). `abi` must be kWorldTransportAbi.
constexpr int kWorldTransportAbi = 1;
using WorldMpiOpen = WorldTransport* (*)(int abi, char* err, unsigned long err_len);

// One round of dynamic work: tasks 0..n-1, each run once, by one lane of one rank. Every rank makes
// a WorkHandout for the same round; its lanes (any number of threads per rank) call next() until it
// returns -1, then the rank calls finish() once. Rank 0 serves the other ranks' requests from a
// thread of its own while its lanes work (ranks > 0 ask rank 0 for each task, one request at a time
// per rank). A task's result (bytes) goes to `on_result` on rank 0 (called from one thread at a
// time), whichever rank ran it. stop() (any rank) ends the round early: no further task starts.
class WorkHandout {
 public:
  // on_result: rank 0 only (ignored elsewhere); (source rank, result bytes).
  WorkHandout(WorldTransport& t, std::int64_t n, std::function<void(int, const std::string&)> on_result);
  ~WorkHandout();  // joins rank 0's server thread (finish() not called: after stopping the round)
  WorkHandout(const WorkHandout&) = delete;
  WorkHandout& operator=(const WorkHandout&) = delete;
  // The result of the task just finished (nullptr: none), then the next task of this rank, or -1.
  std::int64_t next(const std::string* result);
  void stop() { stop_ = true; }
  // Ends the round on this rank. Ranks > 0 send `done` (their status) to rank 0 (`failed`: rank 0
  // stops the round for every rank, as stop() does); rank 0 waits
  // until every rank has finished and returns their statuses (index = rank; its own is `done`), or
  // rethrows what on_result threw for another rank's result.
  std::vector<std::string> finish(const std::string& done, bool failed = false);

 private:
  void serve();
  WorldTransport& t_;
  const std::int64_t n_;
  std::function<void(int, const std::string&)> on_result_;
  std::atomic<std::int64_t> next_{0};
  std::atomic<bool> stop_{false};
  std::mutex m_;                  // rank 0: on_result; ranks > 0: one request at a time
  std::vector<std::string> done_;  // rank 0: statuses by rank
  std::atomic<int> finished_{0};   // rank 0: ranks > 0 that sent their status
  std::atomic<bool> quit_{false};
  std::exception_ptr server_error_;  // rank 0: on_result threw for another rank's result
  std::thread server_;
};

}  // namespace relief::detail
