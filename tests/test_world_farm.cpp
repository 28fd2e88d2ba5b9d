// The tile farm of distributed global phases (src/world_farm.hpp) over an in-memory transport whose
// ranks are threads of this process: every task runs once, results merge in order whichever rank ran
// them, failures keep their kind and path and stop the run at their turn, and the other ranks always
// leave when rank 0 ends the phase. The flow kernel's messages decode to what was coded and a
// malformed one is an Error, never a read beyond its end. (The farm over Open MPI, with the fill and
// flow algorithms: tests/test_world_mpi.cpp.)
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <thread>

#include "relief/error.hpp"
#include "relief/recipe.hpp"
#include "relief/world.hpp"
#include "relief/world_flow.hpp"
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
    if (ranks > 1) {
      EXPECT_GT(sum - by_rank[0], 0);
    }
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

// The flow kernel's messages made by hand (the format of src/world_flow.cpp: a kind byte, then raw
// values, vectors as a u64 count and their elements).
struct Msg {
  std::string s;
  explicit Msg(char kind) : s(1, kind) {}
  template <class T>
  Msg& put(T v) {
    s.append(reinterpret_cast<const char*>(&v), sizeof v);
    return *this;
  }
  template <class T>
  Msg& vec(const std::vector<T>& v) {
    put(std::uint64_t(v.size()));
    s.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    return *this;
  }
};
bool flow_rejects(const std::string& bytes) {
  try {
    relief::detail::flow_message_recoded(bytes);
  } catch (const relief::Error& e) {
    return std::string(e.what()).find("malformed") != std::string::npos;
  }
  return false;
}
Msg s_input(std::uint32_t donors) {
  Msg m('S');
  m.vec(std::vector<float>{}).vec(std::vector<float>{});
  for (int k = 0; k < 5; ++k) m.put(std::uint8_t(k == 1));  // filled, first round, rivers, lakes, same height
  m.put(std::int32_t(-1));                                   // no table
  m.vec(std::vector<std::uint64_t>{5}).vec(std::vector<std::uint32_t>{donors}).vec(std::vector<std::uint8_t>{2});
  m.vec(std::vector<float>{0.5f}).vec(std::vector<float>{0.5f});
  m.vec(std::vector<std::uint8_t>{0}).vec(std::vector<std::uint8_t>{1}).vec(std::vector<std::uint8_t>{1});
  m.vec(std::vector<std::uint64_t>{7}).vec(std::vector<std::uint32_t>{0xFFFFFFFFu});
  m.vec(std::vector<std::uint8_t>{}).vec(std::vector<std::uint32_t>{});
  m.vec(std::vector<std::int64_t>{}).vec(std::vector<float>{}).vec(std::vector<std::uint8_t>{});
  return m;
}

// The flow stage's kernel (src/world_flow.cpp) on a pass-A task of tile (0, 0) of a 65² world of
// 33² tiles: its input (the 67 heights of its grown ring, NaN where pass A reads none) and its
// result decode and code again to the same bytes; every shorter prefix, a count beyond the end and
// trailing bytes are rejected with an Error; a height that does not drain comes back as a status
// (not an exception) naming the sample.
TEST(FlowFarm, APassATaskAndItsResultRoundTripAndMalformedMessagesAreRejected) {
  relief::json doc = relief::load_preset("island");
  doc["stages"] = relief::json::array({relief::json{{"stage", "flow"}, {"river_area_km2", 0.02}}});
  doc["seed"] = 1;
  const relief::Recipe r = relief::parse_recipe(doc);
  int pit = 0;  // > 0: sample (10, 10) lowered into a pit
  relief::WorldStageIO io;
  io.grid = relief::world_grid(65, 65, 33);
  io.world = relief::world_frame(r, 65, 65);
  io.load = [&](std::int64_t X, std::int64_t Z) {
    const relief::WorldGrid::Window w = io.grid.window(X, Z);
    relief::WorldTile t;
    std::vector<float> h(std::size_t(w.nx) * std::size_t(w.nz));
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i) {
        const std::int64_t ix = w.ix0 + i, iz = w.iz0 + j;
        h[std::size_t(j) * std::size_t(w.nx) + std::size_t(i)] =
            0.6f + 0.002f * float(ix) + 0.0001f * float(iz) - (pit && ix == 10 && iz == 10 ? 0.01f : 0.0f);
      }
    t.layers["height"] = relief::Layer{1, std::move(h)};
    return t;
  };
  const FarmKernel kernel = relief::detail::make_farm_kernel("flow", io, r.stages[0]);
  // 'A', not filled, 67 NaN ring heights, no fill levels (u64 counts, raw floats).
  std::string input("A\0", 2);
  auto put_u64 = [&](std::uint64_t v) { input.append(reinterpret_cast<const char*>(&v), 8); };
  put_u64(67);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int k = 0; k < 67; ++k) input.append(reinterpret_cast<const char*>(&nan), 4);
  put_u64(0);
  const std::string result = kernel(0, input);
  ASSERT_GT(result.size(), 100u);
  EXPECT_EQ(result.substr(0, 2), std::string("a\0", 2));  // solved
  EXPECT_EQ(relief::detail::flow_message_recoded(input), input);
  EXPECT_EQ(relief::detail::flow_message_recoded(result), result);
  auto rejected = [](const std::string& bytes) {
    try {
      relief::detail::flow_message_recoded(bytes);
    } catch (const relief::Error& e) {
      return std::string(e.what()).find("malformed") != std::string::npos;
    }
    return false;
  };
  for (const std::string* m : std::initializer_list<const std::string*>{&input, &result})
    for (std::size_t n = 0; n < m->size(); ++n) ASSERT_TRUE(rejected(m->substr(0, n))) << n << " of " << m->size() << " bytes";
  EXPECT_TRUE(rejected(input + "x"));
  EXPECT_TRUE(rejected(result + "x"));
  std::string huge = input;
  huge[2] = '\xff';  // the ring's count: beyond the end
  EXPECT_TRUE(rejected(huge));
  EXPECT_THROW(kernel(0, huge), relief::Error);
  EXPECT_THROW(kernel(0, input.substr(0, 30)), relief::Error);
  std::string short_ring("A\0", 2);  // a ring of 66 heights: the kernel refuses it
  input.swap(short_ring);
  put_u64(66);
  for (int k = 0; k < 66; ++k) input.append(reinterpret_cast<const char*>(&nan), 4);
  put_u64(0);
  EXPECT_THROW(kernel(0, input), relief::Error);
  input.swap(short_ring);
  EXPECT_THROW(kernel(4, input), relief::Error);  // no tile 4 in a 2 × 2 world
  EXPECT_THROW(kernel(0, s_input(1).s), relief::Error);  // a pass-S task whose ring does not fit the tile
  pit = 1;
  const std::string not_draining = kernel(0, input);
  ASSERT_GE(not_draining.size(), 2u);
  EXPECT_EQ(not_draining.substr(0, 2), std::string("a\x01", 2));
  EXPECT_NE(not_draining.find("(10, 10)"), std::string::npos);
  EXPECT_EQ(relief::detail::flow_message_recoded(not_draining), not_draining);
}

// Pass S's and the final pass's messages of the flow kernel, made by hand: each decodes and codes
// again to the same bytes; every shorter prefix, trailing bytes, inconsistent lengths and bad flags
// are rejected with an Error.
TEST(FlowFarm, PassSAndFinalPassMessagesRoundTripAndMalformedOnesAreRejected) {
  const std::string in = s_input(1).s;
  Msg s_result('s');
  s_result.vec(std::vector<std::uint8_t>{1}).vec(std::vector<std::uint8_t>{1}).vec(std::vector<float>{0.5f});
  s_result.vec(std::vector<std::int64_t>{5}).vec(std::vector<float>{0.25f}).vec(std::vector<std::int64_t>{}).vec(std::vector<float>{});
  Msg f_result('f');
  f_result.put(std::uint64_t(9)).put(std::uint64_t(1));  // max count, one river piece:
  f_result.put(std::int64_t(100)).put(std::int32_t(2)).put(std::int64_t(-1)).vec(std::vector<char>{'s', 'e', 'a'});
  f_result.put(std::uint64_t(1));  // one vertex (5 doubles)
  for (double v : {1.0, 2.0, 3.0, 4.0, 5.0}) f_result.put(v);
  f_result.vec(std::vector<std::int64_t>{100});
  f_result.vec(std::vector<std::uint32_t>{3}).vec(std::vector<std::int64_t>{100}).vec(std::vector<float>{0.5f}).vec(std::vector<float>{0.4f});
  f_result.vec(std::vector<std::uint64_t>{9}).vec(std::vector<std::uint8_t>{1});
  for (const std::string& m : {in, s_result.s, f_result.s}) {
    SCOPED_TRACE(std::string(1, m[0]));
    EXPECT_EQ(relief::detail::flow_message_recoded(m), m);
    for (std::size_t n = 0; n < m.size(); ++n) ASSERT_TRUE(flow_rejects(m.substr(0, n))) << n << " of " << m.size() << " bytes";
    EXPECT_TRUE(flow_rejects(m + "x"));
  }
  // Several river pieces: coded in the order of their keys (the hash map's order would make the
  // coding of one result vary).
  Msg f_many('f');
  f_many.put(std::uint64_t(9)).put(std::uint64_t(5));
  for (std::int64_t at : {7, 100, 205, 3000, 40001}) {
    f_many.put(at).put(std::int32_t(1)).put(std::int64_t(at == 40001 ? -1 : at + 1)).vec(std::vector<char>{'s', 'e', 'a'});
    f_many.put(std::uint64_t(1));
    for (double v : {1.0, 2.0, 3.0, 4.0, double(at)}) f_many.put(v);
  }
  f_many.vec(std::vector<std::int64_t>{7});
  f_many.vec(std::vector<std::uint32_t>{}).vec(std::vector<std::int64_t>{}).vec(std::vector<float>{}).vec(std::vector<float>{});
  f_many.vec(std::vector<std::uint64_t>{}).vec(std::vector<std::uint8_t>{});
  EXPECT_EQ(relief::detail::flow_message_recoded(f_many.s), f_many.s);
  EXPECT_TRUE(flow_rejects(s_input(2).s));  // two donors, one order
  std::string flag = in;
  flag[1 + 8 + 8] = 2;  // the "filled" flag
  EXPECT_TRUE(flow_rejects(flag));
  EXPECT_TRUE(flow_rejects(std::string("Q")));
}
}  // namespace

namespace {
// Heights with pits of a `n`² world (0.45 to 0.85: above the island's sea level).
float pitted(std::int64_t ix, std::int64_t iz) {
  return 0.6f + 0.0005f * float(ix) + 0.1f * std::sin(0.37f * float(ix)) * std::cos(0.29f * float(iz)) + 0.05f * std::sin(0.11f * float(ix + 2 * iz));
}
relief::WorldStageIO pitted_io(const relief::Recipe& r, std::int64_t n, int tile) {
  relief::WorldStageIO io;
  io.grid = relief::world_grid(n, n, tile);
  io.world = relief::world_frame(r, n, n);
  const relief::WorldGrid g = io.grid;
  io.load = [g](std::int64_t X, std::int64_t Z) {
    const relief::WorldGrid::Window w = g.window(X, Z);
    relief::WorldTile t;
    std::vector<float> h(std::size_t(w.nx) * std::size_t(w.nz));
    for (int j = 0; j < w.nz; ++j)
      for (int i = 0; i < w.nx; ++i) h[std::size_t(j) * std::size_t(w.nx) + std::size_t(i)] = pitted(w.ix0 + i, w.iz0 + j);
    t.layers["height"] = relief::Layer{1, std::move(h)};
    return t;
  };
  return io;
}
std::vector<float> ring_of(const relief::WorldGrid::Window& w, const std::vector<float>& f) {
  std::vector<float> r;
  for (int j = 0; j < w.nz; ++j)
    for (int i = 0; i < w.nx; ++i)
      if (i == 0 || j == 0 || i == w.nx - 1 || j == w.nz - 1) r.push_back(f[std::size_t(j) * std::size_t(w.nx) + std::size_t(i)]);
  return r;
}
std::string bytes_of(const std::vector<float>& v) { return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float)); }
relief::Recipe flow_recipe() {
  relief::json doc = relief::load_preset("island");
  doc["stages"] = relief::json::array({relief::json{{"stage", "flow"}, {"river_area_km2", 0.02}, {"epsilon_m", 0.01}}});
  doc["seed"] = 1;
  return relief::parse_recipe(doc);
}
// The final window perimeter of every tile in the library's fill_depressions_tiled, with the flow
// stage's sea level and epsilon (as world_flow's fallback).
std::vector<std::vector<float>> library_rings(const relief::WorldStageIO& io, const relief::Recipe& r, bool& changed) {
  const float sea = float(io.world.sea_level), eps = float(0.01 / io.world.height_m);
  std::vector<std::vector<float>> rings(std::size_t(io.grid.count()));
  changed = false;
  relief::fill_depressions_tiled(
      io.grid, sea, eps, [&](std::int64_t X, std::int64_t Z) { return io.load(X, Z).layers.at("height").data; },
      [&](std::int64_t X, std::int64_t Z, std::vector<float> f) {
        const relief::WorldGrid::Window w = io.grid.window(X, Z);
        changed = changed || f != io.load(X, Z).layers.at("height").data;
        rings[std::size_t(Z * io.grid.tiles_x + X)] = ring_of(w, f);
      },
      {});
  (void)r;
  return rings;
}
}  // namespace

// The "flow-fill" kernel (world_flow's fallback fill, src/world_flow.cpp) made by make_farm_kernel
// from the flow stage: on a world of one tile, from no known levels (what a first round sends), its
// result is the window perimeter of the library's fill with the flow stage's epsilon; a task of a
// tile outside the world, a perimeter one float short or one byte long are refused with an exception.
TEST(FlowFarm, TheFlowFillKernelGivesTheLibraryFillsPerimeterAndRefusesMalformedTasks) {
  const relief::Recipe r = flow_recipe();
  const relief::WorldStageIO io = pitted_io(r, 33, 33);  // one tile
  bool changed = false;
  const std::vector<std::vector<float>> rings = library_rings(io, r, changed);
  ASSERT_TRUE(changed);  // the heights have depressions
  const FarmKernel kernel = relief::detail::make_farm_kernel("flow-fill", io, r.stages[0]);
  const std::vector<float> none(rings[0].size(), std::numeric_limits<float>::infinity());
  const std::string input = bytes_of(none);
  EXPECT_EQ(kernel(0, input), bytes_of(rings[0]));
  EXPECT_ANY_THROW(kernel(1, input));   // no tile 1
  EXPECT_ANY_THROW(kernel(-1, input));
  EXPECT_ANY_THROW(kernel(0, input.substr(0, input.size() - 4)));
  EXPECT_ANY_THROW(kernel(0, input + "x"));
  EXPECT_ANY_THROW(kernel(0, std::string()));
}

// world_flow's fallback fill over the farm (fill_perimeters_on_farm, kernel "flow-fill") on 2 ranks:
// rank 1 makes its kernels by name from the flow stage and runs some of the solves; the last ring of
// every tile is the library fill's final window perimeter, as on 1 rank.
TEST(FlowFarm, TheFallbackFillOverTheFarmGivesTheLibrarysRingsOnOneAndTwoRanks) {
  const relief::Recipe r = flow_recipe();
  const relief::WorldStageIO io = pitted_io(r, 129, 33);  // 4 × 4 tiles
  bool changed = false;
  const std::vector<std::vector<float>> want = library_rings(io, r, changed);
  ASSERT_TRUE(changed);
  for (int ranks : {1, 2}) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks");
    std::mutex m;
    std::set<std::string> names;
    std::vector<std::vector<float>> rings(want.size());
    std::vector<std::int64_t> by_rank;
    relief::TiledFillStats st;
    const std::exception_ptr e = with_ranks(
        ranks,
        [&](const std::string& name) {
          {
            std::lock_guard<std::mutex> lock(m);
            names.insert(name);
          }
          return relief::detail::make_farm_kernel(name, io, r.stages[0]);
        },
        [&](TileFarm& farm) {
          const FarmKernel k = relief::detail::flow_fill_farm_kernel(io, r.stages[0]);
          const FarmKernel slow = [k](std::int64_t t, std::string_view in) {  // so that rank 1 gets tasks
            std::this_thread::sleep_for(std::chrono::milliseconds(3));
            return k(t, in);
          };
          const float sea = float(io.world.sea_level), eps = float(0.01 / io.world.height_m);
          st = relief::detail::fill_perimeters_on_farm(io.grid, sea, eps, farm, "flow-fill", slow, {},
                                                       [&](std::int64_t t, std::vector<float> ring) { rings.at(std::size_t(t)) = std::move(ring); });
          by_rank = farm.tasks_by_rank();
        });
    ASSERT_FALSE(e);
    for (std::size_t t = 0; t < want.size(); ++t) EXPECT_EQ(rings[t], want[t]) << "tile " << t;
    ASSERT_EQ(by_rank.size(), std::size_t(ranks));
    std::int64_t sum = 0;
    for (std::int64_t n : by_rank) sum += n;
    EXPECT_EQ(sum, st.tile_solves);
    EXPECT_GE(st.tile_solves, 16);
    if (ranks == 2) {
      EXPECT_GT(by_rank[1], 0);
      EXPECT_EQ(names, std::set<std::string>{"flow-fill"});
    }
  }
}

// A result from another rank damaged on its way (one bit of one result of rank 1 flipped, at a place
// that changes from trial to trial) through a real flow run without fill on 2 ranks (the fallback
// fill's and flow's three passes): rank 0 either stops with a relief::Error or takes the result as
// it reads (a changed height or count is still a valid message). It never crashes, never hangs and
// never reads outside its arrays (the sanitizer pass runs this test too), and some damage is caught.
TEST(FlowFarm, ADamagedResultFromAnotherRankIsAnErrorNeverACrash) {
  const relief::Recipe r = flow_recipe();
  relief::WorldStageIO io = pitted_io(r, 129, 33);  // 4 × 4 tiles with depressions: no fill before flow
  std::mutex m;
  std::map<std::int64_t, std::vector<float>> stored;
  io.store = [&](std::int64_t X, std::int64_t Z, relief::WorldTile t) {
    std::lock_guard<std::mutex> lock(m);
    stored[Z * 4 + X] = t.layers.at("height").data;
  };
  const relief::WorldStageAlgorithm flow =
      relief::world_flow([](const relief::Frame&, std::vector<relief::River>, std::vector<relief::Lake>) {});
  std::atomic<std::int64_t> flipped{-1};  // the tile whose result was damaged (-1: none)
  auto run = [&](int ranks, std::int64_t victim, std::uint64_t where, std::int64_t* results) {
    std::atomic<std::int64_t> count{0};
    flipped = -1;
    const std::exception_ptr e = with_ranks(
        ranks,
        [&](const std::string& name) -> FarmKernel {
          const FarmKernel k = relief::detail::make_farm_kernel(name, io, r.stages[0]);
          return [k, &count, &flipped, victim, where](std::int64_t t, std::string_view in) {
            std::string out = k(t, in);
            if (count++ == victim && !out.empty()) {
              out[std::size_t(where % out.size())] ^= char(1 << ((where >> 40) & 7));
              flipped = t;
            }
            return out;
          };
        },
        [&](TileFarm& farm) {
          relief::WorldStageIO here = io;
          here.farm = &farm;
          flow(here, r.stages[0], 0);
        });
    if (results) *results = count;
    return e;
  };
  std::int64_t results = 0;
  ASSERT_FALSE(run(2, -1, 0, &results));  // nothing damaged: the run succeeds
  ASSERT_GT(results, 8) << "rank 1 ran too few tasks for the test to mean anything";
  // Which of rank 1's results is damaged depends on the hand-out's timing (the byte and bit are a
  // fixed xorshift sequence); a trial whose rank 1 ran fewer tasks than the victim's index damages
  // nothing and is counted apart. A failure names the trial, the tile and the byte.
  int errors = 0, taken = 0, undamaged = 0;
  std::uint64_t x = 0x9E3779B97F4A7C15ull;
  for (int trial = 0; trial < 120; ++trial) {
    x ^= x << 13, x ^= x >> 7, x ^= x << 17;  // xorshift
    const std::exception_ptr e = run(2, std::int64_t(x % std::uint64_t(results)), x >> 8, nullptr);
    if (flipped < 0) {
      ++undamaged;
      EXPECT_FALSE(e) << "trial " << trial << ": nothing was damaged, yet the run failed";
      continue;
    }
    if (!e) {
      ++taken;
      continue;
    }
    try {
      std::rethrow_exception(e);
    } catch (const relief::Error& err) {
      ++errors;
      EXPECT_FALSE(std::string(err.what()).empty());
    } catch (const std::exception& err) {
      ADD_FAILURE() << "trial " << trial << " (tile " << flipped << ", byte " << (x >> 8) << "): not a relief::Error: " << err.what();
    }
  }
  std::printf("damaged results: %d refused with an Error, %d taken as they read; %d trials damaged nothing\n", errors,
              taken, undamaged);
  EXPECT_GT(errors + taken, 80) << "too few trials damaged a result";
  EXPECT_GT(errors, 0);
}

// A farm run capped at one task per rank (TileFarm::run's local_lanes, as stream power's blocks are:
// a kernel that uses a rank's threads itself): no rank, rank 0 included, ever runs two at once, and
// the other ranks still get work; the merges stay in order.
TEST(TileFarm, ALaneCapKeepsEveryRankToThatManyTasksAtOnce) {
  struct Count {
    std::atomic<int> now{0}, most{0};
  };
  std::mutex m;
  std::vector<std::shared_ptr<Count>> counts;  // one per kernel made (one per rank)
  auto counted = [&]() -> FarmKernel {
    auto c = std::make_shared<Count>();
    {
      std::lock_guard<std::mutex> lock(m);
      counts.push_back(c);
    }
    const FarmKernel inner = square_kernel(300);
    return [c, inner](std::int64_t k, std::string_view in) {
      const int n = ++c->now;
      int most = c->most.load();
      while (n > most && !c->most.compare_exchange_weak(most, n)) {
      }
      std::string r = inner(k, in);
      --c->now;
      return r;
    };
  };
  const std::vector<std::int64_t> items = iota_items(80);
  std::vector<std::int64_t> merged, by_rank;
  const std::exception_ptr e = with_ranks(
      3, [&](const std::string&) { return counted(); },
      [&](TileFarm& farm) {
        farm.run(
            "square", items, [](std::int64_t k) { return std::to_string(k); }, counted(),
            [&](std::int64_t k, std::string) { merged.push_back(k); }, 1);
        by_rank = farm.tasks_by_rank();
      });
  ASSERT_FALSE(e);
  EXPECT_EQ(merged, items);
  ASSERT_EQ(counts.size(), 3u);  // rank 0's local kernel and one per other rank
  for (const auto& c : counts) EXPECT_EQ(c->most.load(), 1);
  ASSERT_EQ(by_rank.size(), 3u);
  EXPECT_GT(by_rank[1] + by_rank[2], 0);
}

// Stream power's block kernel (world_stream_power's refinement, src/world_bounded.cpp, "stream-power")
// on hand-made tasks: a block of 9 × 8 samples in a 33² world, 2 steps, the first sweep's coarse
// inflow. The same task gives the same bytes; the last sweep's result is the solved window, the
// ring's change shows in it; a sweep that gives a neighbour its records returns one segment whose
// length says its size (in the last sweep, before the window); every shorter prefix of a task, a trailing byte, a window outside the world
// and a neighbour's window outside it are refused with an exception, never a read beyond the end.
TEST(StreamPowerFarm, ABlockTaskSolvesItsWindowAndMalformedTasksAreRefused) {
  relief::json doc = relief::load_preset("eroded-mountains");
  doc["stages"] = relief::json::array({relief::json{{"stage", "stream_power"}, {"steps", 2}}});
  const relief::Recipe r = relief::parse_recipe(doc);
  relief::WorldStageIO io;
  io.grid = relief::world_grid(33, 33, 33);
  io.world = relief::world_frame(r, 33, 33);
  const FarmKernel kernel = relief::detail::make_farm_kernel("stream-power", io, r.stages[0]);
  const int wnx = 9, wnz = 8, K = 2, steps = 2, R = 2 * wnx + 2 * (wnz - 2);
  // A task as world_stream_power writes it: `prev` a later sweep (the ring held at `held` where a
  // neighbour owns it, their inflow per step) instead of the first (coarse inflow).
  struct Opt {
    bool prev = false;
    double held = 0.5;  // the ring levels travel as doubles (since session 20)
    int steps = 2, nouts = -1;  // -1: none in the last sweep, one otherwise
    std::uint32_t target = 4 * 9 + 7;
    std::uint8_t owned = 1;
  };
  auto task = [&](std::int64_t x0, std::int64_t z0, bool last, double change, std::int64_t nx0 = 12, Opt o = Opt()) {
    std::string t;
    auto put = [&](const auto& v) { t.append(reinterpret_cast<const char*>(&v), sizeof(v)); };
    const std::uint32_t nouts = o.nouts >= 0 ? std::uint32_t(o.nouts) : (last ? 0u : 1u);
    put(x0), put(z0), put(std::int32_t(wnx)), put(std::int32_t(wnz)), put(std::int32_t(K)), put(std::int32_t(o.steps));
    put(std::uint8_t(o.prev)), put(std::uint8_t(last)), put(nouts);
    for (int j = 0; j < wnz; ++j)
      for (int i = 0; i < wnx; ++i) put(0.40f + 0.02f * float(i) + 0.01f * float(j));
    for (int k = 1; k <= K; ++k)
      for (int q = 0; q < R; ++q) put(change * k);
    if (o.prev) {
      for (int half = 0; half < 2; ++half)  // levels seen, then solved, per step and ring sample
        for (int q = 0; q < o.steps * R; ++q) put(o.held);
      for (int q = 0; q < R; ++q) put(std::uint8_t(o.owned));  // a neighbour owns every ring sample (or none)
      put(std::uint32_t(1));
      for (int k = 1; k < o.steps; ++k) put(std::uint32_t(0));  // inflow: one entry at step 0
    } else {
      put(std::uint32_t(1)), put(std::uint32_t(0)), put(std::uint32_t(0));  // coarse inflow: one entry at snapshot 0
    }
    put(std::uint32_t(4 * wnx + 4)), put(2.0f);  // at sample (4, 4), 2 cells
    for (std::uint32_t n = 0; n < nouts; ++n) {
      put(nx0), put(z0), put(std::int32_t(wnx)), put(std::int32_t(wnz));  // the neighbour's window
      put(std::uint32_t(2));                                               // two targets
      put(o.target), put(std::uint32_t(5 * wnx + 7));
    }
    return t;
  };
  const std::string last = task(4, 6, true, 0.0);
  const std::string solved = kernel(0, last);
  ASSERT_EQ(solved.size(), std::size_t(4 * wnx * wnz));
  EXPECT_EQ(kernel(0, last), solved);
  EXPECT_NE(kernel(0, task(4, 6, true, 1e-3)), solved);  // the ring follows the coarse change
  const std::string give = task(4, 6, false, 0.0);
  const std::string records = kernel(0, give);
  ASSERT_GE(records.size(), 8u);
  std::uint64_t len = 0;
  std::memcpy(&len, records.data(), 8);
  EXPECT_EQ(len, records.size() - 8);
  EXPECT_GE(len, std::uint64_t(2 * steps * 2 * 8 + steps * 4));  // levels seen and solved of 2 targets, counts
  for (const std::string* m : {&last, &give})
    for (std::size_t n = 0; n < m->size(); ++n) ASSERT_ANY_THROW(kernel(0, m->substr(0, n))) << n << " of " << m->size() << " bytes";
  EXPECT_ANY_THROW(kernel(0, last + "x"));
  EXPECT_ANY_THROW(kernel(0, task(30, 6, true, 0.0)));          // beyond the world's edge
  EXPECT_ANY_THROW(kernel(0, task(-1, 6, true, 0.0)));
  EXPECT_ANY_THROW(kernel(0, task(4, 6, false, 0.0, 40)));      // the neighbour's window outside it
  // A later sweep: the ring is held at its owners' levels, whatever the coarse change; a ring that no
  // neighbour owns (the world's edge) follows the coarse change.
  Opt later;
  later.prev = true;
  const std::string held = kernel(0, task(4, 6, true, 0.0, 12, later));
  ASSERT_EQ(held.size(), solved.size());
  EXPECT_EQ(kernel(0, task(4, 6, true, 1e-3, 12, later)), held);
  later.held = 0.45;
  EXPECT_NE(kernel(0, task(4, 6, true, 0.0, 12, later)), held);
  later.held = 0.5;
  Opt edge = later;
  edge.owned = 0;
  EXPECT_EQ(kernel(0, task(4, 6, true, 0.0, 12, edge)), solved);  // as the first sweep with no change
  EXPECT_NE(kernel(0, task(4, 6, true, 1e-3, 12, edge)), kernel(0, task(4, 6, true, 0.0, 12, edge)));
  edge.owned = 2;  // an owner flag is 0 or 1
  EXPECT_ANY_THROW(kernel(0, task(4, 6, true, 0.0, 12, edge)));
  const std::string later_give = task(4, 6, false, 0.0, 12, later);
  EXPECT_GE(kernel(0, later_give).size(), 8u);
  for (std::size_t n = 0; n < later_give.size(); n += 7) ASSERT_ANY_THROW(kernel(0, later_give.substr(0, n))) << n;
  // The last sweep gives the neighbours whose turn comes later their records too: the same segment
  // as an earlier sweep's, then the solved window.
  Opt both;
  both.nouts = 1;
  const std::string both_out = kernel(0, task(4, 6, true, 0.0, 12, both));
  ASSERT_EQ(both_out.size(), records.size() + solved.size());
  EXPECT_EQ(both_out.substr(0, records.size()), records);
  EXPECT_EQ(both_out.substr(records.size()), solved);
  // Refused: steps other than the stage's, more than 8 neighbours, a target outside the window.
  Opt bad;
  bad.steps = 3;
  EXPECT_ANY_THROW(kernel(0, task(4, 6, true, 0.0, 12, bad)));
  bad = Opt();
  bad.nouts = 9;
  EXPECT_ANY_THROW(kernel(0, task(4, 6, false, 0.0, 12, bad)));
  bad = Opt();
  bad.target = std::uint32_t(wnx * wnz);
  EXPECT_ANY_THROW(kernel(0, task(4, 6, false, 0.0, 12, bad)));
}

// A kernel that runs alone on another rank (a capped run: stream power's blocks) has that rank's
// threads for its own parallel work: the lanes waiting for a task hold none of them. The kernel's
// two parallel halves must meet (each waits up to 3 s for the other): with the rank's second thread
// held by an idle lane (as before session 18), they never did.
TEST(TileFarm, AKernelAloneOnAnotherRankHasTheRanksThreads) {
  tbb::global_control enough(tbb::global_control::max_allowed_parallelism, 8);  // workers for every rank's arena
  const FarmKernel meet = [](std::int64_t, std::string_view) {
    std::atomic<int> arrived{0};
    std::atomic<bool> met{true};
    tbb::parallel_for(
        0, 2,
        [&](int) {
          ++arrived;
          const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(3);
          while (arrived.load() < 2)
            if (std::chrono::steady_clock::now() > until) {
              met = false;
              break;
            } else {
              std::this_thread::yield();
            }
        },
        tbb::simple_partitioner());
    return std::string(met ? "met" : "alone");
  };
  std::vector<std::string> results;
  std::vector<std::int64_t> by_rank;
  const std::exception_ptr e = with_ranks(
      2, [&](const std::string&) { return meet; },
      [&](TileFarm& farm) {
        farm.run(
            "meet", iota_items(6), [](std::int64_t) { return std::string(); }, meet,
            [&](std::int64_t, std::string r) { results.push_back(r); }, 1);
        by_rank = farm.tasks_by_rank();
      });
  ASSERT_FALSE(e);
  ASSERT_EQ(results.size(), 6u);
  for (const std::string& r : results) EXPECT_EQ(r, "met");
  ASSERT_EQ(by_rank.size(), 2u);
  EXPECT_GT(by_rank[1], 0);
}
