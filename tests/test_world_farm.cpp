// The tile farm of distributed global phases (src/world_farm.hpp) over an in-memory transport whose
// ranks are threads of this process: every task runs once, results merge in order whichever rank ran
// them, failures keep their kind and path and stop the run at their turn, and the other ranks always
// leave when rank 0 ends the phase. (The farm over Open MPI, with the fill algorithm:
// tests/test_world_mpi.cpp.)
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

#include "relief/error.hpp"
#include "world_farm.hpp"

namespace {

using relief::detail::FarmKernel;
using relief::detail::TileFarm;
using relief::detail::WorldTransport;

// Messages by (destination, tag), in send order.
struct Hub {
  std::mutex m;
  std::map<std::pair<int, int>, std::deque<std::pair<int, std::string>>> q;
  std::atomic<long> sent{0};
};

class Loopback final : public WorldTransport {
 public:
  Loopback(Hub& h, int rank, int size) : h_(h), rank_(rank), size_(size) {}
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void send(int to, int tag, const std::string& bytes) override {
    std::lock_guard<std::mutex> lock(h_.m);
    h_.q[{to, tag}].emplace_back(rank_, bytes);
    ++h_.sent;
  }
  bool try_receive(int tag, int& from, std::string& bytes) override {
    std::lock_guard<std::mutex> lock(h_.m);
    auto& d = h_.q[{rank_, tag}];
    if (d.empty()) return false;
    from = d.front().first;
    bytes = std::move(d.front().second);
    d.pop_front();
    return true;
  }
  std::string receive(int, int) override { throw std::logic_error("not used by the farm"); }
  void broadcast(std::string&) override { throw std::logic_error("not used by the farm"); }
  void barrier() override { throw std::logic_error("not used by the farm"); }
  std::string description() const override { return "loopback"; }

 private:
  Hub& h_;
  int rank_, size_;
};

// The kernel every rank runs: "square" of the tile index, after `delay_us` (so that tasks spread).
FarmKernel square_kernel(int delay_us, std::int64_t fail_at = -1) {
  return [=](std::int64_t k, std::string_view input) -> std::string {
    std::this_thread::sleep_for(std::chrono::microseconds(delay_us));
    if (k == fail_at) throw relief::Error("tile", "tile " + std::to_string(k) + " is damaged");
    return std::string(input) + ":" + std::to_string(k * k);
  };
}

// Runs `root` on rank 0 (its farm, on an arena of 2 threads) and serve() on ranks 1..ranks-1 with
// 2 lanes each and kernels from `make`; returns what rank 0 threw (null: nothing) and checks that
// every other rank left serve() without an error and that no message is left unread.
std::exception_ptr with_ranks(int ranks, const std::function<FarmKernel(const std::string&)>& make,
                              const std::function<void(TileFarm&)>& root) {
  Hub hub;
  std::vector<std::thread> workers;
  std::vector<std::exception_ptr> worker_errors(std::size_t(ranks), nullptr);
  for (int r = 1; r < ranks; ++r)
    workers.emplace_back([&, r] {
      Loopback t(hub, r, ranks);
      try {
        TileFarm::serve(t, 2, make);
      } catch (...) {
        worker_errors[std::size_t(r)] = std::current_exception();
      }
    });
  std::exception_ptr thrown;
  {
    Loopback t0(hub, 0, ranks);
    TileFarm farm(t0);
    tbb::task_arena arena(2);
    try {
      arena.execute([&] { root(farm); });
    } catch (...) {
      thrown = std::current_exception();
    }
  }  // ~TileFarm ends the phase
  for (std::thread& w : workers) w.join();
  for (int r = 1; r < ranks; ++r) EXPECT_FALSE(worker_errors[std::size_t(r)]) << "rank " << r;
  for (auto& [key, d] : hub.q) EXPECT_TRUE(d.empty()) << "messages left for rank " << key.first << " tag " << key.second;
  return thrown;
}

std::vector<std::int64_t> iota_items(std::int64_t n, std::int64_t step = 1) {
  std::vector<std::int64_t> v;
  for (std::int64_t k = 0; k < n; ++k) v.push_back(7 + k * step);
  return v;
}

TEST(TileFarm, EveryTaskRunsOnceAndMergesInOrderOnAnyNumberOfRanks) {
  for (int ranks : {1, 2, 4}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const std::vector<std::int64_t> items = iota_items(60, 3);
    std::vector<std::int64_t> by_rank;
    std::vector<std::string> merged;
    const std::exception_ptr e = with_ranks(
        ranks, [](const std::string& name) { return name == "square" ? square_kernel(500) : FarmKernel(); },
        [&](TileFarm& farm) {
          const FarmKernel local = square_kernel(500);
          for (int batch = 0; batch < 3; ++batch)  // several runs in one phase
            farm.run(
                "square", items, [&](std::int64_t k) { return "in" + std::to_string(k + batch); }, local,
                [&](std::int64_t k, std::string r) { merged.push_back(std::to_string(k) + "=" + r); });
          by_rank = farm.tasks_by_rank();
        });
    ASSERT_FALSE(e);
    ASSERT_EQ(merged.size(), 3 * items.size());
    for (int batch = 0; batch < 3; ++batch)
      for (std::size_t p = 0; p < items.size(); ++p) {
        const std::int64_t k = items[p];
        EXPECT_EQ(merged[std::size_t(batch) * items.size() + p],
                  std::to_string(k) + "=in" + std::to_string(k + batch) + ":" + std::to_string(k * k));
      }
    ASSERT_EQ(by_rank.size(), std::size_t(ranks));
    std::int64_t sum = 0;
    for (std::int64_t n : by_rank) sum += n;
    EXPECT_EQ(sum, 3 * std::int64_t(items.size()));
    // With 0.5 ms per task and 180 tasks, the other ranks' lanes get work.
    if (ranks > 1) EXPECT_GT(sum - by_rank[0], 0);
  }
}

TEST(TileFarm, TheFirstFailureInOrderIsThrownWithItsPathAndNothingMergesAfterIt) {
  for (int ranks : {1, 3}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    const std::vector<std::int64_t> items = iota_items(40);  // 7..46
    std::vector<std::int64_t> merged;
    // Tiles 20 and 30 fail, wherever they run; 20 comes first.
    auto kernel = [](std::int64_t k, std::string_view in) -> std::string {
      std::this_thread::sleep_for(std::chrono::microseconds(300));
      if (k == 20 || k == 30) throw relief::Error("tile", "tile " + std::to_string(k) + " is damaged");
      return std::string(in);
    };
    const std::exception_ptr e = with_ranks(
        ranks, [&](const std::string&) { return FarmKernel(kernel); },
        [&](TileFarm& farm) {
          farm.run("k", items, [](std::int64_t) { return std::string(); }, kernel,
                   [&](std::int64_t k, std::string) { merged.push_back(k); });
        });
    ASSERT_TRUE(e);
    try {
      std::rethrow_exception(e);
    } catch (const relief::Error& x) {
      EXPECT_EQ(x.path(), "tile");
      EXPECT_NE(std::string(x.message()).find("tile 20 is damaged"), std::string::npos) << x.message();
    }
    ASSERT_EQ(merged.size(), 13u);  // 7..19
    EXPECT_EQ(merged.back(), 19);
  }
}

TEST(TileFarm, AMergeThatThrowsStopsTheRunAndTheOtherRanksStillLeave) {
  const std::vector<std::int64_t> items = iota_items(30);
  int merges = 0;
  const std::exception_ptr e = with_ranks(
      3, [](const std::string&) { return square_kernel(200); },
      [&](TileFarm& farm) {
        farm.run("square", items, [](std::int64_t) { return std::string(); }, square_kernel(200), [&](std::int64_t k, std::string) {
          ++merges;
          if (k == 10) throw std::runtime_error("merge failed at 10");
        });
      });
  ASSERT_TRUE(e);
  EXPECT_EQ(merges, 4);  // 7, 8, 9, 10
}

TEST(TileFarm, AKernelThatARankCannotMakeFailsTheRunWithTheRanksMessage) {
  const std::vector<std::int64_t> items = iota_items(40);
  const std::exception_ptr e = with_ranks(
      2, [](const std::string& name) -> FarmKernel { throw std::runtime_error("no farm kernel named " + name); },
      [&](TileFarm& farm) {
        farm.run("nope", items, [](std::int64_t) { return std::string(); }, square_kernel(1000), [](std::int64_t, std::string) {});
      });
  ASSERT_TRUE(e);
  try {
    std::rethrow_exception(e);
  } catch (const std::runtime_error& x) {
    EXPECT_NE(std::string(x.what()).find("rank 1: no farm kernel named nope"), std::string::npos) << x.what();
  }
}

TEST(TileFarm, APhaseWithNoRunStillReleasesTheOtherRanks) {
  EXPECT_FALSE(with_ranks(4, [](const std::string&) { return square_kernel(0); }, [](TileFarm&) {}));
}

TEST(TileFarm, CancelledOnAnotherRankIsCancelledHere) {
  const std::vector<std::int64_t> items = iota_items(20);
  auto cancelled = [](std::int64_t, std::string_view) -> std::string {
    std::this_thread::sleep_for(std::chrono::microseconds(300));
    throw relief::Cancelled();
  };
  const std::exception_ptr e = with_ranks(
      2, [&](const std::string&) { return FarmKernel(cancelled); },
      [&](TileFarm& farm) { farm.run("c", items, [](std::int64_t) { return std::string(); }, cancelled, [](std::int64_t, std::string) {}); });
  ASSERT_TRUE(e);
  EXPECT_THROW(std::rethrow_exception(e), relief::Cancelled);
}

}  // namespace

namespace {
// A rank that sends rank 0 something that is not a farm message: rank 0's run ends with an error
// naming it (instead of waiting for results that will never come), and its farm still ends.
TEST(TileFarm, AMalformedMessageFromARankFailsTheRunInsteadOfHanging) {
  Hub hub;
  {
    Loopback t1(hub, 1, 2);
    t1.send(0, 3, std::string("C\x02\x00\x00\x00", 5));  // credit for 2 lanes: rank 0 sends it 2 tasks,
    t1.send(0, 3, std::string("Znonsense"));                 // which never come back: then this
  }
  Loopback t0(hub, 0, 2);
  std::exception_ptr e;
  {
    TileFarm farm(t0);
    tbb::task_arena arena(2);
    const std::vector<std::int64_t> items = iota_items(50);
    try {
      arena.execute([&] {
        farm.run("square", items, [](std::int64_t) { return std::string(); }, square_kernel(2000), [](std::int64_t, std::string) {});
      });
    } catch (...) {
      e = std::current_exception();
    }
  }
  ASSERT_TRUE(e);
  try {
    std::rethrow_exception(e);
  } catch (const std::runtime_error& x) {
    EXPECT_NE(std::string(x.what()).find("malformed"), std::string::npos) << x.what();
  }
}
}  // namespace
