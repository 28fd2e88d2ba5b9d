#pragma once
// The tile work of a global phase spread over the ranks of a distributed world build (issue 18:
// "exchanges perimeters for the exact global stages"). Rank 0 runs the world algorithm and keeps its
// global state (border levels, perimeter graphs); the tile solves of each batch (a fill round's class
// of tiles, ...) run on every rank: rank 0 sends a solve's input (the perimeter values it reads, a
// few kilobytes), the rank that runs it loads the tile from the shared store, solves it, writes what
// the tile stores itself and sends back the small result (the perimeter values it found), and rank 0
// merges the results in the batch's order. So the bytes are those of a build in one process for any
// rank count, and only perimeters cross the transport (hydraulic: a group's window of heights and
// the samples it changed). Inputs and results hold raw floats and integers: the ranks must share one
// architecture (as MPI_BYTE messages assume).
//
// A kernel is a pure function of (tile, input bytes): the same code runs a solve on rank 0 and on the
// other ranks. The other ranks know no algorithm state: they make kernels from the stage and their own
// WorldStageIO (make_farm_kernel, by the name in each task) and run what rank 0 sends until it ends
// the phase.
//
// Protocol (tags 3 and 4 of WorldTransport; WorkHandout uses 1 and 2):
//   rank r > 0 → 0 (tag 3): "C" + u32 lanes (once, when it starts serving: its credit), then for every
//     task "R" + i64 task + u8 ok + (ok: result bytes | error: u8 kind, u32 path length, path, message);
//   rank 0 → r (tag 4): "T" + i64 task + u32 kernel-name length + name + input bytes, or "E" (the
//     phase is over: rank 0 sends it once every task it gave r has come back and r's "C" has arrived).
// Rank 0 keeps at most `lanes` tasks at each rank, and hands out tasks in the batch's order to
// whichever lane (its own or a rank's) is free, within a window of the batch that bounds the results
// waiting for their turn to merge.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "relief/world.hpp"
#include "world_transport.hpp"

namespace relief::detail {

// Runs task `k` (a tile index, as the algorithm numbers them) from `input`; returns its result. May
// throw (relief::Error keeps its path across ranks; relief::Cancelled; anything else by its message).
using FarmKernel = std::function<std::string(std::int64_t k, std::string_view input)>;

class TileFarm {
 public:
  // Rank 0 (the one that runs the algorithm). `t.size()` = 1: run() computes every task here.
  explicit TileFarm(WorldTransport& t);
  ~TileFarm();  // end()
  TileFarm(const TileFarm&) = delete;
  TileFarm& operator=(const TileFarm&) = delete;

  int ranks() const { return t_.size(); }
  // For every k of `items`: result = kernel(k, input(k)), on this rank's task arena (kernel `local`)
  // or on another rank (the kernel named `kernel` there), and merge(k, result) in the order of
  // `items`, one at a time, on one of this rank's threads. input() is called under the same lock as
  // merge(), so it may read what merges write. The first failure in order (a kernel's or a merge's)
  // is rethrown once every task handed out has come back; no task starts after it. `local_lanes` > 0
  // caps the tasks every rank runs at once (a kernel that uses the rank's threads itself and whose
  // memory is large: stream power's blocks, one at a time per rank); 0: one per thread of a rank.
  void run(const std::string& kernel, const std::vector<std::int64_t>& items, const std::function<std::string(std::int64_t)>& input,
           const FarmKernel& local, const std::function<void(std::int64_t, std::string)>& merge, int local_lanes = 0);
  // Tasks each rank ran (index: rank), over every run().
  std::vector<std::int64_t> tasks_by_rank() const;
  // Ends the phase for the other ranks (their serve() returns). Called by the destructor too.
  void end();

  // A rank > 0, during a global phase: runs the tasks rank 0 sends on `lanes` threads, each entering
  // a task arena of `lanes` threads only to run a kernel (so a kernel running alone has them all), with
  // kernels from `make(name)` (each made once), until rank 0 ends the phase.
  static void serve(WorldTransport& t, int lanes, const std::function<FarmKernel(const std::string& name)>& make);

 private:
  struct Batch;
  void server();
  WorldTransport& t_;
  std::size_t window(const Batch& b) const;
  mutable std::mutex m_;  // everything below and the current batch
  std::condition_variable cv_;
  Batch* batch_ = nullptr;
  std::vector<int> credit_;       // free lanes per rank (-1: its "C" has not arrived)
  std::vector<int> outstanding_;  // tasks at each rank
  std::vector<std::int64_t> tasks_by_rank_;
  bool ending_ = false;
  std::exception_ptr server_error_;
  std::thread server_;
};

// The farm a world algorithm's tasks run on: the build's (WorldStageIO::farm), or, outside
// build_world (null), one of this process alone.
class FarmOf {
 public:
  explicit FarmOf(TileFarm* given) : farm_(given) {
    if (!farm_) {
      alone_ = in_process_transport();
      own_ = std::make_unique<TileFarm>(*alone_);
      farm_ = own_.get();
    }
  }
  TileFarm* operator->() const { return farm_; }

 private:
  std::unique_ptr<WorldTransport> alone_;  // declared first: destroyed after the farm it serves
  std::unique_ptr<TileFarm> own_;
  TileFarm* farm_;
};

// The kernel `name` of a distributed world algorithm, made from the stage and a rank's own io (the
// library's: "fill", src/world_fill.cpp; "hydraulic" and "stream-power", src/world_bounded.cpp; "flow"
// and "flow-fill", src/world_flow.cpp). Throws for an unknown name.
FarmKernel make_farm_kernel(const std::string& name, const WorldStageIO& io, const RecipeStage& stage);
FarmKernel fill_farm_kernel(const WorldStageIO& io, const RecipeStage& stage);       // "fill" (src/world_fill.cpp)
FarmKernel hydraulic_farm_kernel(const WorldStageIO& io, const RecipeStage& stage);  // "hydraulic" (src/world_bounded.cpp)
FarmKernel flow_farm_kernel(const WorldStageIO& io, const RecipeStage& stage);       // "flow" (src/world_flow.cpp)
FarmKernel flow_fill_farm_kernel(const WorldStageIO& io, const RecipeStage& stage);  // "flow-fill" (src/world_flow.cpp)
FarmKernel stream_power_farm_kernel(const WorldStageIO& io, const RecipeStage& stage);  // "stream-power" (src/world_bounded.cpp)
// A fill solve that stores nothing (src/world_fill.cpp): task t's input is the levels known for tile t's
// window perimeter (row-major floats), its result the filled tile's window perimeter; `load` gives the
// tile's heights. "flow-fill" is this kernel with the flow stage's sea level and epsilon.
FarmKernel fill_perimeter_kernel(const WorldGrid& g, float sea, float epsilon, const TileLoad& load);
// fill_depressions_tiled (relief/world.hpp) with its tile solves as tasks of `farm` named `kernel`
// (`local` on this rank: fill_perimeter_kernel's), storing no tile: ring(t, tile t's filled window
// perimeter) for every solve, in merge order (the same for any rank count): the last one of a tile is
// its final levels. For the flow stage's fallback fill (src/world_flow.cpp).
TiledFillStats fill_perimeters_on_farm(const WorldGrid& g, float sea, float epsilon, TileFarm& farm, const std::string& kernel,
                                       const FarmKernel& local, const std::function<void(double)>& progress,
                                       const std::function<void(std::int64_t, std::vector<float>)>& ring);
// A flow kernel's message (a task's input or a result) decoded and coded again, for tests: the same
// bytes for a well-formed message; an Error for a malformed one (src/world_flow.cpp).
std::string flow_message_recoded(std::string_view bytes);

}  // namespace relief::detail
