// The tile work of a global phase spread over the ranks of a distributed world build
// (src/world_farm.hpp: what runs where, the protocol).
#include "world_farm.hpp"

#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <map>
#include <optional>
#include <stdexcept>

#include "relief/error.hpp"

namespace relief::detail {
namespace {

constexpr int kTagToRoot = 3;    // rank > 0 → rank 0: "C" + u32 lanes, "R" + result
constexpr int kTagToWorker = 4;  // rank 0 → rank > 0: "T" + task, "E"

void put_u32(std::string& s, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) s.push_back(char((v >> (8 * k)) & 0xFF));
}
void put_i64(std::string& s, std::int64_t v) {
  for (int k = 0; k < 8; ++k) s.push_back(char((std::uint64_t(v) >> (8 * k)) & 0xFF));
}
std::runtime_error malformed(const char* what) { return std::runtime_error(std::string("world transport: a malformed ") + what); }
// Reads from a message, checking its length.
struct Reader {
  std::string_view s;
  std::size_t at = 0;
  const char* what;
  std::uint64_t bytes(int n) {
    if (s.size() - at < std::size_t(n)) throw malformed(what);
    std::uint64_t v = 0;
    for (int k = 0; k < n; ++k) v |= std::uint64_t(std::uint8_t(s[at + std::size_t(k)])) << (8 * k);
    at += std::size_t(n);
    return v;
  }
  std::string_view text() {
    const std::size_t n = std::size_t(bytes(4));
    if (s.size() - at < n) throw malformed(what);
    const std::string_view v = s.substr(at, n);
    at += n;
    return v;
  }
  std::string_view rest() {
    const std::string_view v = s.substr(at);
    at = s.size();
    return v;
  }
};

// A failure as sent to rank 0: u8 kind (1 relief::Error, 2 Cancelled, 3 anything else), path, message.
std::string encode_failure(std::exception_ptr e) {
  std::string s;
  std::string path, message;
  int kind = 3;
  try {
    std::rethrow_exception(e);
  } catch (const Error& x) {
    kind = 1, path = x.path(), message = x.message();
  } catch (const Cancelled&) {
    kind = 2;
  } catch (const std::exception& x) {
    message = x.what();
  } catch (...) {
    message = "an unknown exception";
  }
  s.push_back(char(kind));
  put_u32(s, std::uint32_t(path.size()));
  s += path;
  s += message;
  return s;
}
std::exception_ptr decode_failure(Reader& r, int rank) {
  const int kind = int(r.bytes(1));
  const std::string path(r.text());
  const std::string message(r.rest());
  if (kind == 1) return std::make_exception_ptr(Error(path, message));
  if (kind == 2) return std::make_exception_ptr(Cancelled());
  return std::make_exception_ptr(std::runtime_error("rank " + std::to_string(rank) + ": " + message));
}


}  // namespace

struct TileFarm::Batch {
  const std::string& kernel;
  const std::vector<std::int64_t>& items;
  const std::function<std::string(std::int64_t)>& input;
  const FarmKernel& local;
  const std::function<void(std::int64_t, std::string)>& merge;
  std::size_t lanes = 1;  // this rank's
  int cap = 0;            // at most this many tasks at once at any rank (0: a rank's lanes)
  // Whether rank r (> 0) may take another task now (under m_).
  bool takes(const std::vector<int>& credit, const std::vector<int>& outstanding, std::size_t r) const {
    return credit[r] > 0 && (cap == 0 || outstanding[r] < cap);
  }
  std::size_t next = 0, merged = 0;
  std::vector<std::optional<std::string>> results;
  std::vector<std::exception_ptr> errors;
  std::vector<std::uint8_t> ready;
  std::int64_t in_flight = 0;  // handed out and not yet back (here or at another rank)
  std::exception_ptr failure;  // the first in order
  bool finished() const { return merged == items.size() || (failure && in_flight == 0); }
};

// Results wait for their turn to merge within a window of twice the lanes of every rank (under m_).
std::size_t TileFarm::window(const Batch& b) const {
  std::size_t lanes = b.lanes;
  for (std::size_t r = 1; r < credit_.size(); ++r) {
    const int n = std::max(0, credit_[r]) + outstanding_[r];
    lanes += std::size_t(b.cap > 0 ? std::min(n, b.cap) : n);
  }
  return 2 * lanes;
}

TileFarm::TileFarm(WorldTransport& t) : t_(t) {
  credit_.assign(std::size_t(t_.size()), -1);
  outstanding_.assign(std::size_t(t_.size()), 0);
  tasks_by_rank_.assign(std::size_t(t_.size()), 0);
  credit_[0] = 0;
  if (t_.size() > 1) server_ = std::thread([this] { server(); });
}

TileFarm::~TileFarm() { end(); }

void TileFarm::end() {
  {
    std::lock_guard<std::mutex> lock(m_);
    ending_ = true;
  }
  if (server_.joinable()) server_.join();
}

std::vector<std::int64_t> TileFarm::tasks_by_rank() const {
  std::lock_guard<std::mutex> lock(m_);
  return tasks_by_rank_;
}

void TileFarm::run(const std::string& kernel, const std::vector<std::int64_t>& items,
                   const std::function<std::string(std::int64_t)>& input, const FarmKernel& local,
                   const std::function<void(std::int64_t, std::string)>& merge, int local_lanes) {
  if (items.empty()) return;
  Batch b{kernel, items, input, local, merge};
  b.lanes = std::size_t(std::max(1, tbb::this_task_arena::max_concurrency()));
  if (local_lanes > 0) b.lanes = std::min(b.lanes, std::size_t(local_lanes)), b.cap = local_lanes;
  b.results.resize(items.size());
  b.errors.resize(items.size());
  b.ready.assign(items.size(), 0);
  {
    std::unique_lock<std::mutex> lock(m_);
    if (server_error_) std::rethrow_exception(server_error_);
    // Every rank says how many lanes it has ("C") as it starts serving, right after the local phase
    // before this one; waiting for them (a few seconds at most) lets the first tasks go to every
    // rank rather than all to this one while the others are still starting.
    cv_.wait_for(lock, std::chrono::seconds(5), [&] {
      return server_error_ || std::all_of(credit_.begin(), credit_.end(), [](int c) { return c >= 0; });
    });
    batch_ = &b;
  }
  // Free lanes of the other ranks (under m_): while there are some, this rank's lanes leave the
  // next task to the server thread, which hands it out within a fraction of a millisecond, so that
  // every rank shares the work whatever the size of a task (the merges' order does not change).
  auto others_free = [&] {
    for (std::size_t r = 1; r < credit_.size(); ++r)
      if (b.takes(credit_, outstanding_, r)) return true;
    return false;
  };
  auto merge_ready = [&] {  // under m_
    while (!b.failure && b.merged < items.size() && b.ready[b.merged]) {
      const std::size_t p = b.merged;
      try {
        if (b.errors[p]) std::rethrow_exception(b.errors[p]);
        std::string res = std::move(*b.results[p]);
        b.results[p].reset();
        merge(items[p], std::move(res));
      } catch (...) {
        b.failure = std::current_exception();
      }
      ++b.merged;
    }
  };
  tbb::parallel_for(
      std::size_t(0), b.lanes,
      [&](std::size_t) {
        std::unique_lock<std::mutex> lock(m_);
        for (;;) {
          merge_ready();
          if (b.finished()) break;
          if (!b.failure && b.next < items.size() && b.next < b.merged + window(b) && (server_error_ || !others_free())) {
            const std::size_t p = b.next++;
            ++b.in_flight;
            ++tasks_by_rank_[0];
            std::optional<std::string> res;
            std::exception_ptr err;
            try {
              std::string in = input(items[p]);
              lock.unlock();
              try {
                // Isolated: while the kernel waits for its own parallel work (tile coding), this
                // thread must not pick up another lane of this loop, which only ends with the batch.
                tbb::this_task_arena::isolate([&] { res.emplace(local(items[p], in)); });
              } catch (...) {
                err = std::current_exception();
              }
              lock.lock();
            } catch (...) {
              err = std::current_exception();
            }
            b.results[p] = std::move(res);
            b.errors[p] = err;
            b.ready[p] = 1;
            --b.in_flight;
            cv_.notify_all();
            continue;
          }
          cv_.wait_for(lock, std::chrono::milliseconds(2));
        }
        cv_.notify_all();
      },
      tbb::simple_partitioner());
  std::exception_ptr failure;
  {
    std::lock_guard<std::mutex> lock(m_);
    batch_ = nullptr;
    failure = b.failure ? b.failure : server_error_;
  }
  if (failure) std::rethrow_exception(failure);
}

void TileFarm::server() {
  Backoff idle;
  try {
    for (;;) {
      bool busy = false;
      int from = -1;
      std::string msg;
      if (t_.try_receive(kTagToRoot, from, msg)) {
        busy = true;
        if (from <= 0 || from >= t_.size() || msg.empty()) throw malformed("farm message");
        Reader r{msg, 1, "farm message"};
        std::lock_guard<std::mutex> lock(m_);
        if (msg[0] == 'C') {
          if (credit_[std::size_t(from)] >= 0) throw malformed("farm credit (sent twice)");
          credit_[std::size_t(from)] = int(std::min<std::uint64_t>(r.bytes(4), 64));
          cv_.notify_all();
        } else if (msg[0] == 'R') {
          const std::int64_t p = std::int64_t(r.bytes(8));
          const bool ok = r.bytes(1) != 0;
          if (!batch_ || outstanding_[std::size_t(from)] <= 0 || p < 0 || std::size_t(p) >= batch_->items.size() ||
              batch_->ready[std::size_t(p)])
            throw malformed("farm result (no such task)");
          if (ok)
            batch_->results[std::size_t(p)].emplace(r.rest());
          else
            batch_->errors[std::size_t(p)] = decode_failure(r, from);
          batch_->ready[std::size_t(p)] = 1;
          --batch_->in_flight;
          --outstanding_[std::size_t(from)];
          ++credit_[std::size_t(from)];
          cv_.notify_all();
        } else {
          throw malformed("farm message");
        }
      }
      {
        std::unique_lock<std::mutex> lock(m_);
        // Hand out tasks to ranks with free lanes, in order, within the window.
        for (std::size_t rk = 1; batch_ && rk < credit_.size(); ++rk) {
          Batch& b = *batch_;
          while (b.takes(credit_, outstanding_, rk) && !b.failure && b.next < b.items.size() && b.next < b.merged + window(b)) {
            const std::size_t p = b.next++;
            std::string task = "T";
            put_i64(task, std::int64_t(p));
            put_i64(task, b.items[p]);
            put_u32(task, std::uint32_t(b.kernel.size()));
            task += b.kernel;
            try {
              task += b.input(b.items[p]);
            } catch (...) {
              b.errors[p] = std::current_exception();
              b.ready[p] = 1;
              cv_.notify_all();
              continue;
            }
            t_.send(int(rk), kTagToWorker, task);
            --credit_[rk];
            ++outstanding_[rk];
            ++b.in_flight;
            ++tasks_by_rank_[rk];
            busy = true;
          }
        }
        if (busy) cv_.notify_all();  // this rank's lanes wait while other ranks have free lanes
        if (ending_) {
          bool quiet = true;
          for (std::size_t rk = 1; rk < credit_.size(); ++rk) quiet = quiet && credit_[rk] >= 0 && outstanding_[rk] == 0;
          if (quiet) {
            for (int rk = 1; rk < t_.size(); ++rk) t_.send(rk, kTagToWorker, "E");
            return;
          }
        }
      }
      if (busy)
        idle = Backoff();
      else
        idle.wait();
    }
  } catch (...) {
    std::lock_guard<std::mutex> lock(m_);
    server_error_ = std::current_exception();
    if (batch_) {
      if (!batch_->failure) batch_->failure = server_error_;
      // No result of another rank will arrive now: the batch ends once this rank's lanes are done.
      for (std::size_t rk = 1; rk < outstanding_.size(); ++rk) batch_->in_flight -= outstanding_[rk], outstanding_[rk] = 0;
    }
    cv_.notify_all();
  }
}

void TileFarm::serve(WorldTransport& t, int lanes, const std::function<FarmKernel(const std::string& name)>& make) {
  lanes = std::max(1, std::min(lanes, 64));
  struct Task {
    std::int64_t p, k;
    std::string kernel, input;
  };
  std::mutex m;
  std::condition_variable cv;
  std::deque<Task> tasks;
  std::deque<std::string> results;
  bool ended = false;
  std::exception_ptr comm_error;
  std::map<std::string, FarmKernel> kernels;  // made once per name (under km)
  std::mutex km;
  {
    std::string credit = "C";
    put_u32(credit, std::uint32_t(lanes));
    t.send(0, kTagToRoot, credit);
  }
  // One thread talks to rank 0 (the transport's calls never overlap); the lanes compute.
  std::thread comm([&] {
    Backoff idle;
    try {
      for (;;) {
        bool busy = false;
        std::string out;
        {
          std::lock_guard<std::mutex> lock(m);
          if (!results.empty()) out = std::move(results.front()), results.pop_front();
        }
        if (!out.empty()) {
          t.send(0, kTagToRoot, out);
          busy = true;
        }
        int from = -1;
        std::string msg;
        if (t.try_receive(kTagToWorker, from, msg)) {
          busy = true;
          if (from != 0 || msg.empty()) throw malformed("farm task");
          if (msg[0] == 'E') {
            std::lock_guard<std::mutex> lock(m);
            ended = true;
            cv.notify_all();
            return;
          }
          if (msg[0] != 'T') throw malformed("farm task");
          Reader r{msg, 1, "farm task"};
          Task task;
          task.p = std::int64_t(r.bytes(8));
          task.k = std::int64_t(r.bytes(8));
          task.kernel = std::string(r.text());
          task.input = std::string(r.rest());
          std::lock_guard<std::mutex> lock(m);
          tasks.push_back(std::move(task));
          cv.notify_one();
        }
        if (busy)
          idle = Backoff();
        else
          idle.wait();
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(m);
      comm_error = std::current_exception();
      ended = true;
      cv.notify_all();
    }
  });
  // The lanes are threads of their own that enter the rank's arena only to run a kernel: a lane
  // waiting for a task holds none of the arena's threads, so a kernel that runs alone (stream power's
  // blocks, one at a time per rank) has all of them for its own parallel work.
  tbb::task_arena arena(lanes);
  auto lane = [&] {
    for (;;) {
      Task task;
      {
        std::unique_lock<std::mutex> lock(m);
        cv.wait(lock, [&] { return ended || !tasks.empty(); });
        if (tasks.empty()) return;
        task = std::move(tasks.front());
        tasks.pop_front();
      }
      std::string res = "R";
      put_i64(res, task.p);
      try {
        FarmKernel kernel;
        {
          std::lock_guard<std::mutex> lock(km);
          auto it = kernels.find(task.kernel);
          if (it == kernels.end()) it = kernels.emplace(task.kernel, make(task.kernel)).first;
          kernel = it->second;
        }
        std::string out;  // isolated, as on rank 0: no other lane's work runs inside the kernel's waits
        arena.execute([&] { tbb::this_task_arena::isolate([&] { out = kernel(task.k, task.input); }); });
        res.push_back(char(1));
        res += out;
      } catch (...) {
        res.resize(9);
        res.push_back(char(0));
        res += encode_failure(std::current_exception());
      }
      std::lock_guard<std::mutex> lock(m);
      results.push_back(std::move(res));
    }
  };
  std::vector<std::thread> lanes_run;
  for (int l = 1; l < lanes; ++l) lanes_run.emplace_back(lane);
  lane();  // this thread is a lane too
  for (std::thread& l : lanes_run) l.join();
  comm.join();
  if (comm_error) std::rethrow_exception(comm_error);
}

FarmKernel make_farm_kernel(const std::string& name, const WorldStageIO& io, const RecipeStage& stage) {
  if (name == "fill") return fill_farm_kernel(io, stage);
  if (name == "hydraulic") return hydraulic_farm_kernel(io, stage);
  if (name == "flow") return flow_farm_kernel(io, stage);
  if (name == "flow-fill") return flow_fill_farm_kernel(io, stage);
  if (name == "stream-power") return stream_power_farm_kernel(io, stage);
  throw std::runtime_error("world transport: no farm kernel named " + name);
}

}  // namespace relief::detail
