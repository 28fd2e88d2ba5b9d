// relief_mpi: the MPI implementation of the world build's transport (src/world_transport.hpp),
// compiled into its own module (CMake target relief_mpi, built only when CMake finds MPI) and
// loaded by `relief world` with dlopen under mpirun, so that relief_core and the relief binary never
// link libmpi. Not part of relief_core (CMakeLists.txt leaves src/world_mpi*.cpp out of it).
//
// MPI use: MPI_COMM_WORLD duplicated; MPI_THREAD_SERIALIZED (the world build calls the transport
// from several threads, one at a time); every wait is a nonblocking call tested in a loop that
// sleeps (10 µs growing to 0.2 or 1 ms) instead of MPI's blocking calls, which spin and would take the
// core from the ranks that work (2 ranks on 2 cores).
#include <dlfcn.h>
#include <mpi.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>

#include "world_transport.hpp"

namespace {

using relief::detail::WorldTransport;

// Sleeps between polls: 10 µs doubling to `cap` (200 µs for a reply to a request, 1 ms in
// collectives, where ranks wait for rank 0's world algorithms).
struct Backoff {
  int us = 10, cap = 1000;
  explicit Backoff(int cap_us = 1000) : cap(cap_us) {}
  void wait() {
    std::this_thread::sleep_for(std::chrono::microseconds(us));
    us = std::min(cap, us * 2);
  }
};

void check(int rc, const char* what) {
  if (rc == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING] = "";
  int len = 0;
  MPI_Error_string(rc, text, &len);
  throw std::runtime_error(std::string("MPI: ") + what + " failed: " + text);
}

void wait_for(MPI_Request& r, const char* what) {
  Backoff b;
  for (;;) {
    int done = 0;
    check(MPI_Test(&r, &done, MPI_STATUS_IGNORE), what);
    if (done) return;
    b.wait();
  }
}

class MpiTransport final : public WorldTransport {
 public:
  MpiTransport() {
    check(MPI_Comm_dup(MPI_COMM_WORLD, &comm_), "MPI_Comm_dup");
    MPI_Comm_set_errhandler(comm_, MPI_ERRORS_RETURN);
    check(MPI_Comm_rank(comm_, &rank_), "MPI_Comm_rank");
    check(MPI_Comm_size(comm_, &size_), "MPI_Comm_size");
  }
  ~MpiTransport() override {
    MPI_Comm_free(&comm_);
    MPI_Finalize();
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void send(int to, int tag, const std::string& bytes) override {
    if (bytes.size() > 0x7FFFFFFFu) throw std::runtime_error("MPI: a message of more than 2 GiB");
    MPI_Request r;
    check(MPI_Isend(bytes.data(), int(bytes.size()), MPI_BYTE, to, tag, comm_, &r), "MPI_Isend");
    wait_for(r, "MPI_Isend");
  }
  bool try_receive(int tag, int& from, std::string& bytes) override {
    int flag = 0;
    MPI_Status st;
    check(MPI_Iprobe(MPI_ANY_SOURCE, tag, comm_, &flag, &st), "MPI_Iprobe");
    if (!flag) return false;
    from = st.MPI_SOURCE;
    bytes = take(st);
    return true;
  }
  std::string receive(int from, int tag) override {
    Backoff b(200);
    for (;;) {
      int flag = 0;
      MPI_Status st;
      check(MPI_Iprobe(from, tag, comm_, &flag, &st), "MPI_Iprobe");
      if (flag) return take(st);
      b.wait();
    }
  }
  void broadcast(std::string& bytes) override {
    unsigned long long n = bytes.size();
    MPI_Request r;
    check(MPI_Ibcast(&n, 1, MPI_UNSIGNED_LONG_LONG, 0, comm_, &r), "MPI_Ibcast");
    wait_for(r, "MPI_Ibcast");
    if (n > 0x7FFFFFFFull) throw std::runtime_error("MPI: a broadcast of more than 2 GiB");
    bytes.resize(std::size_t(n));
    if (n == 0) return;
    check(MPI_Ibcast(bytes.data(), int(n), MPI_BYTE, 0, comm_, &r), "MPI_Ibcast");
    wait_for(r, "MPI_Ibcast");
  }
  void barrier() override {
    MPI_Request r;
    check(MPI_Ibarrier(comm_, &r), "MPI_Ibarrier");
    wait_for(r, "MPI_Ibarrier");
  }
  std::string description() const override {
    char lib[MPI_MAX_LIBRARY_VERSION_STRING] = "";
    int len = 0;
    MPI_Get_library_version(lib, &len);
    std::string s(lib, std::size_t(len));
    if (const auto eol = s.find_first_of(",\n"); eol != std::string::npos) s.resize(eol);
    int v = 0, sv = 0;
    MPI_Get_version(&v, &sv);
    return s + ", MPI " + std::to_string(v) + "." + std::to_string(sv);
  }

 private:
  std::string take(MPI_Status& st) {
    int n = 0;
    check(MPI_Get_count(&st, MPI_BYTE, &n), "MPI_Get_count");
    std::string bytes(std::size_t(n), '\0');
    check(MPI_Recv(bytes.data(), n, MPI_BYTE, st.MPI_SOURCE, st.MPI_TAG, comm_, MPI_STATUS_IGNORE), "MPI_Recv");
    return bytes;
  }
  MPI_Comm comm_ = MPI_COMM_NULL;
  int rank_ = 0, size_ = 1;
};

}  // namespace

extern "C" __attribute__((visibility("default"))) WorldTransport* relief_world_mpi_open(int abi, char* err, unsigned long err_len) {
  auto fail = [&](const std::string& why) -> WorldTransport* {
    if (err && err_len) std::snprintf(err, err_len, "%s", why.c_str());
    return nullptr;
  };
  if (abi != relief::detail::kWorldTransportAbi)
    return fail("the relief_mpi module was built for another version of relief (transport ABI " +
                std::to_string(relief::detail::kWorldTransportAbi) + ", asked for " + std::to_string(abi) + ")");
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (initialized || finalized) return fail("MPI was already started in this process (it starts once per process)");
  // Make libmpi's symbols global even if the loader did not (Open MPI's plugins need them).
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&MPI_Init_thread), &info) && info.dli_fname)
    ::dlopen(info.dli_fname, RTLD_NOW | RTLD_GLOBAL | RTLD_NOLOAD);
  int provided = 0;
  if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) return fail("MPI_Init_thread failed");
  if (provided < MPI_THREAD_SERIALIZED) {
    MPI_Finalize();
    return fail("this MPI library does not allow calls from several threads (MPI_THREAD_SERIALIZED)");
  }
  try {
    return new MpiTransport();
  } catch (const std::exception& e) {
    MPI_Finalize();
    return fail(e.what());
  }
}
