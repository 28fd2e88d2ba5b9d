// The world build's transport (src/world_transport.hpp): the in-process transport, the loader of
// the relief_mpi module (dlopen: relief_core and the relief binary never link MPI) and rank 0's
// dynamic work handout.
#include "world_transport.hpp"

#include <dlfcn.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "relief/error.hpp"
#include "relief/params.hpp"

namespace relief::detail {
namespace {

constexpr int kTagRequest = 1;  // rank > 0 → rank 0: 'R' (no result), 'S' + result, 'D'/'F' + status (F: failed)
constexpr int kTagReply = 2;    // rank 0 → rank > 0: the next task, 8 bytes little-endian (−1: none)

class InProcess final : public WorldTransport {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void send(int, int, const std::string&) override { throw std::logic_error("in-process transport: no other rank to send to"); }
  bool try_receive(int, int&, std::string&) override { return false; }
  std::string receive(int, int) override { throw std::logic_error("in-process transport: no other rank to receive from"); }
  void broadcast(std::string&) override {}
  void barrier() override {}
  std::string description() const override { return "in-process"; }
};

std::string encode_i64(std::int64_t v) {
  std::string s(8, '\0');
  for (int k = 0; k < 8; ++k) s[std::size_t(k)] = char((std::uint64_t(v) >> (8 * k)) & 0xFF);
  return s;
}
std::int64_t decode_i64(const std::string& s) {
  if (s.size() != 8) throw std::runtime_error("world transport: a task reply of " + std::to_string(s.size()) + " bytes");
  std::uint64_t v = 0;
  for (int k = 0; k < 8; ++k) v |= std::uint64_t(std::uint8_t(s[std::size_t(k)])) << (8 * k);
  return std::int64_t(v);
}


}  // namespace

std::unique_ptr<WorldTransport> in_process_transport() { return std::make_unique<InProcess>(); }

std::unique_ptr<WorldTransport> load_mpi_transport(const std::string& module_path, const std::string& field) {
  std::error_code ec;
  if (module_path.empty() || !std::filesystem::is_regular_file(module_path, ec))
    throw Error(field, "expected the MPI module at " + quote(module_path, 200) +
                           ", but there is no such file: this relief was built without MPI (install libopenmpi-dev and "
                           "openmpi-bin, e.g. with scripts/setup.sh, and rebuild), or the module was moved");
  // RTLD_GLOBAL: Open MPI's own plugins resolve libmpi's symbols from the global scope.
  void* h = ::dlopen(module_path.c_str(), RTLD_NOW | RTLD_GLOBAL);
  if (!h) {
    const char* why = ::dlerror();
    throw Error(field, "cannot load the MPI module " + quote(module_path, 200) + ": " + (why ? why : "unknown dlopen error"));
  }
  auto open = reinterpret_cast<WorldMpiOpen>(::dlsym(h, "relief_world_mpi_open"));
  if (!open) throw Error(field, quote(module_path, 200) + " is not a relief_mpi module (no relief_world_mpi_open)");
  char err[512] = "";
  WorldTransport* t = open(kWorldTransportAbi, err, sizeof err);
  if (!t) throw Error(field, std::string("MPI did not start: ") + (err[0] ? err : "no reason given"));
  return std::unique_ptr<WorldTransport>(t);  // the module stays loaded (MPI cannot be unloaded)
}

// ---- WorkHandout ----------------------------------------------------------------------------

WorkHandout::WorkHandout(WorldTransport& t, std::int64_t n, std::function<void(int, const std::string&)> on_result)
    : t_(t), n_(n), on_result_(std::move(on_result)) {
  if (t_.rank() == 0) {
    done_.assign(std::size_t(t_.size()), std::string());
    if (t_.size() > 1) server_ = std::thread([this] { serve(); });
  }
}

WorkHandout::~WorkHandout() {
  quit_ = true;
  if (server_.joinable()) server_.join();
}

std::int64_t WorkHandout::next(const std::string* result) {
  if (t_.rank() == 0) {
    if (result && on_result_) {
      std::lock_guard<std::mutex> lock(m_);
      on_result_(0, *result);
    }
    if (stop_) return -1;
    const std::int64_t k = next_++;
    return k < n_ ? k : -1;
  }
  std::lock_guard<std::mutex> lock(m_);
  if (stop_ && !result) return -1;
  t_.send(0, kTagRequest, result ? "S" + *result : std::string("R"));
  const std::int64_t k = decode_i64(t_.receive(0, kTagReply));
  if (k < 0) stop_ = true;  // the round is over for every lane of this rank
  return k;
}

void WorkHandout::serve() {
  // Rank 0: answers every request until each other rank has sent its status.
  Backoff b;
  while (!quit_ && finished_.load() < t_.size() - 1) {
    int from = -1;
    std::string msg;
    if (!t_.try_receive(kTagRequest, from, msg)) {
      b.wait();
      continue;
    }
    b = Backoff();
    if (msg.empty() || from <= 0 || from >= t_.size()) throw std::runtime_error("world transport: a malformed request");
    if (msg[0] == 'D' || msg[0] == 'F') {
      if (msg[0] == 'F') stop_ = true;  // no rank starts another task of this round
      done_[std::size_t(from)] = msg.substr(1);
      ++finished_;
      continue;
    }
    if (msg[0] == 'S' && on_result_) {
      std::lock_guard<std::mutex> lock(m_);
      try {
        on_result_(from, msg.substr(1));
      } catch (...) {  // kept for finish(); the round stops, the other ranks still get their answers
        if (!server_error_) server_error_ = std::current_exception();
        stop_ = true;
      }
    }
    std::int64_t k = -1;
    if (!stop_) {
      k = next_++;
      if (k >= n_) k = -1;
    }
    t_.send(from, kTagReply, encode_i64(k));
  }
}

std::vector<std::string> WorkHandout::finish(const std::string& done, bool failed) {
  if (t_.rank() != 0) {
    std::lock_guard<std::mutex> lock(m_);
    t_.send(0, kTagRequest, (failed ? "F" : "D") + done);
    return {};
  }
  if (server_.joinable()) server_.join();  // returns once every other rank has sent its status
  if (server_error_) std::rethrow_exception(server_error_);
  done_[0] = done;
  return done_;
}

}  // namespace relief::detail
