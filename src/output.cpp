#include <signal.h>
// Outputs (FileOutput, atomic file writes) and the byte encoders: PNG (via libspng) and raw r16.
//
// Atomic writes: the bytes go to a temporary file `.NAME.tmp-XXXXXX` in the target directory
// (same file system, so rename(2) is atomic), are flushed with fsync (unless the output is
// Sync::Atomic), then renamed onto NAME.
// Any failure removes the temporary file and leaves a previous NAME untouched. FileOutput's
// OnCommit mode writes every temporary file as soon as it is encoded (overlapping the encoding of
// the others) and renames them all at the end, so that a failed run changes no file at all.
#include <fcntl.h>
#include <spng.h>
#include <zlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <set>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include "relief/error.hpp"
#include "relief/output.hpp"

namespace fs = std::filesystem;

namespace relief {
namespace {

std::string errno_text(int e) { return std::error_code(e, std::generic_category()).message(); }

// Suffix for temporary names: unique within the process (counter) and across processes (pid,
// clock). O_EXCL makes a collision an EEXIST, which we retry.
// Every temporary file this process has open or finished but not yet renamed or removed, so that
// a signal handler's thread can remove them (remove_live_temporaries) before the process exits.
std::mutex& live_mutex() {
  static std::mutex m;
  return m;
}
std::set<std::string>& live_temps() {
  static std::set<std::string> s;
  return s;
}
std::atomic<int> publishing{0};            // commits whose renames are under way
std::atomic<std::uint64_t> published{0};   // outputs whose renames have begun, ever (commits_published)
bool closed_for_exit = false;  // set by remove_live_temporaries (under live_mutex): no new temporaries
// Starts a commit's renames (counted in `publishing`, see remove_live_temporaries); refused once
// the process is being interrupted. `where` completes "cannot replace files…".
void begin_publishing(const std::string& where) {
  std::lock_guard<std::mutex> live(live_mutex());
  if (closed_for_exit) throw Error("output", "cannot replace files" + where + ": the run is being interrupted");
  ++publishing;
}
void untrack(const std::string& tmp) noexcept {
  try {
    std::lock_guard<std::mutex> lock(live_mutex());
    live_temps().erase(tmp);
  } catch (...) {
  }
}

std::string temp_suffix(unsigned attempt) {
  static std::atomic<std::uint64_t> counter{0};
  std::uint64_t x = std::uint64_t(::getpid()) * 0x9E3779B97F4A7C15ull ^
                    std::uint64_t(std::chrono::steady_clock::now().time_since_epoch().count()) ^
                    (counter.fetch_add(1) + attempt) * 0xBF58476D1CE4E5B9ull;
  x ^= x >> 31;
  x *= 0x94D049BB133111EBull;
  x ^= x >> 29;
  static const char digits[] = "abcdefghijklmnopqrstuvwxyz0123456789";
  std::string s(6, 'x');
  for (char& c : s) {
    c = digits[x % 36];
    x /= 36;
  }
  return s;
}

// ---- pixel conversion ----------------------------------------------------------------------
// clamp(v, 0, 1) with NaN mapped to 0 (std::clamp would pass NaN through, and converting NaN to
// an integer is undefined behaviour).
inline double unit(float v) {
  double d = v;
  if (!(d > 0.0)) return 0.0;
  return d < 1.0 ? d : 1.0;
}
inline std::uint16_t to_u16(float v) { return std::uint16_t(unit(v) * 65535.0 + 0.5); }
inline std::uint8_t to_u8(float v) { return std::uint8_t(unit(v) * 255.0 + 0.5); }

void check_layer(const Layer& l, int nx, int nz, int channels, const char* what) {
  if (l.channels != channels)
    throw Error("layer", std::string(what) + ": layer has " + std::to_string(l.channels) + " channel(s), expected " +
                             std::to_string(channels));
  if (nx < 1 || nz < 1)
    throw Error("layer", std::string(what) + ": invalid size " + std::to_string(nx) + "x" + std::to_string(nz));
  const std::size_t want = std::size_t(nx) * std::size_t(nz) * std::size_t(channels);
  if (l.data.size() != want)
    throw Error("layer", std::string(what) + ": layer has " + std::to_string(l.data.size()) + " values, expected " +
                             std::to_string(want) + " (" + std::to_string(nx) + "x" + std::to_string(nz) + "x" +
                             std::to_string(channels) + ")");
}

// PNG compression settings, chosen by measurement (bench/png_settings.cpp, `relief_png_settings`):
// the four core presets (island, hills, mountains, desert) at 1025², seed 7, libspng 0.7.3 over
// zlib 1.2.13; bytes and CPU ms of the encoding thread (medians of 3 runs), summed over the four
// presets. The right-hand columns are color.png + albedo.png together.
//
//   level, strategy, row filter            16-bit height.png     |  8-bit RGB colour + albedo
//                                             bytes       ms     |     bytes       ms
//   4, Z_FILTERED, adaptive (until now)     5 529 880    386     |   7 561 910    775
//   1, Z_RLE, none                          7 876 072     59     |  19 822 764    157
//   1, Z_RLE, Sub                           5 854 471     65     |   8 747 765    217
//   1, Z_RLE, Up                            5 928 111     66     |   9 201 379    203
//   1, Z_RLE, Paeth            (chosen)     5 636 317     96     |   7 689 523    277
//   1, Z_FILTERED, Sub                      5 607 396    120     |   8 665 915    231
//   2, default, Sub                         5 548 827    132     |   8 290 116    279
//   3, Z_FILTERED, Sub                      5 472 163    190     |   7 791 705    466
//   4, default, Up                          5 579 700    201     |   7 586 112    393
//   6, default, Up                          5 546 280    358     |   7 078 660   1369
//   6, default, adaptive                    5 546 780    592     |   7 054 463   1771
//
// Z_RLE (matches at distance 1 only, no hash chains) after the Paeth predictor: 1.9 % more bytes
// on heights and 1.7 % on colour than the old settings, for a quarter (heights) and a third
// (colour) of the time. With Z_RLE the level only chooses stored (0) or compressed, so level 1
// says what happens. The adaptive filter choice alone costs about 25 ms per 1025² image and gains
// under 0.2 % over Paeth. Per image (KB / ms, chosen vs old): island height 1341/24 vs 1330/96,
// colour 1207/38 vs 1168/110, albedo 574/31 vs 622/82 (smaller); the worst case is the desert's
// hillshaded colour, 1383/35 vs 1213/101 (+14 %).
struct PngSettings {
  int level, strategy, filter_choice;  // strategy −1: libspng's default (Z_FILTERED)
};
constexpr PngSettings kPngLayers{1, Z_RLE, SPNG_FILTER_CHOICE_PAETH};  // height.png, color.png, albedo.png
// Other images (8-bit grey, normal maps, splat maps, engine tiles: not measured again here).
constexpr PngSettings kPngOther{4, -1, SPNG_FILTER_CHOICE_ALL};

std::string encode_png(const void* pixels, std::size_t len, int w, int h, int bit_depth, int color_type,
                       PngSettings settings = kPngOther) {
  std::unique_ptr<spng_ctx, decltype(&spng_ctx_free)> ctx(spng_ctx_new(SPNG_CTX_ENCODER), &spng_ctx_free);
  if (!ctx) throw Error("output", "PNG encoder: out of memory");
  auto check = [](int r) {
    if (r) throw Error("output", std::string("PNG encoding failed: ") + spng_strerror(r));
  };
  check(spng_set_option(ctx.get(), SPNG_ENCODE_TO_BUFFER, 1));
  check(spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_LEVEL, settings.level));
  if (settings.strategy >= 0) check(spng_set_option(ctx.get(), SPNG_IMG_COMPRESSION_STRATEGY, settings.strategy));
  check(spng_set_option(ctx.get(), SPNG_FILTER_CHOICE, settings.filter_choice));
  spng_ihdr ihdr{};
  ihdr.width = std::uint32_t(w);
  ihdr.height = std::uint32_t(h);
  ihdr.bit_depth = std::uint8_t(bit_depth);
  ihdr.color_type = std::uint8_t(color_type);
  check(spng_set_ihdr(ctx.get(), &ihdr));
  // SPNG_FMT_PNG: samples in the PNG's layout, 16-bit samples in host byte order.
  check(spng_encode_image(ctx.get(), pixels, len, SPNG_FMT_PNG, SPNG_ENCODE_FINALIZE));
  std::size_t out_len = 0;
  int err = 0;
  void* buf = spng_get_png_buffer(ctx.get(), &out_len, &err);
  if (!buf) check(err ? err : SPNG_EINTERNAL);
  std::string out(static_cast<const char*>(buf), out_len);
  std::free(buf);
  return out;
}

}  // namespace

// ---- files --------------------------------------------------------------------------------

namespace {

// A temporary file `.NAME.tmp-XXXXXX` beside `path`, created with O_EXCL (mode 0666 & ~umask, like
// any freshly created file; mkstemp would give 0600).
struct TempFile {
  std::string path, tmp;
  int fd = -1;
  bool preallocated = false;  // blocks reserved past the end (FALLOC_FL_KEEP_SIZE): trim at close
};

// Files whose size is known (put) or estimated (streams) from this size on get their blocks
// allocated before the first write (fallocate). The blocks are then not "delayed allocation", so
// on ext4 replacing a previous file of the same name does not flush the new one to disk inside
// rename(2) (auto_da_alloc: 0.29 s for the island's 214 MB OBJ here); the data is written back
// later, or before the rename with Sync::Durable. Also one extent instead of many. File systems
// without fallocate (tmpfs, some network ones) simply skip it.
constexpr std::size_t kPreallocateMin = std::size_t(1) << 20;

TempFile create_temp(const std::string& path) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const std::string base = target.filename().string();
  if (base.empty() || base == "." || base == "..") throw Error("output", "invalid file name '" + path + "'");
  TempFile t;
  t.path = path;
  // Creating and registering happen under one lock, so remove_live_temporaries sees every file.
  std::lock_guard<std::mutex> lock(live_mutex());
  if (closed_for_exit) throw Error("output", "cannot write to '" + path + "': the run is being interrupted");
  for (unsigned attempt = 0; attempt < 100 && t.fd < 0; ++attempt) {
    // ".NAME.tmp-PID-XXXXXX": the PID tells a later run whether the writer is still alive
    // (remove_dead_temporaries).
    t.tmp = (dir / ("." + base + ".tmp-" + std::to_string(::getpid()) + "-" + temp_suffix(attempt))).string();
    t.fd = ::open(t.tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (t.fd >= 0) live_temps().insert(t.tmp);
    if (t.fd < 0 && errno != EEXIST) throw Error("output", "cannot write to '" + path + "': " + errno_text(errno));
  }
  if (t.fd < 0) throw Error("output", "cannot write to '" + path + "': no free temporary name");
  return t;
}

// Closes and removes a temporary file (no-throw; used on every failure path).
void discard(int& fd, const std::string& tmp) noexcept {
  if (fd >= 0) ::close(fd);
  fd = -1;
  std::error_code ignore;
  if (!tmp.empty()) {
    fs::remove(tmp, ignore);
    untrack(tmp);
  }
}

// Writes everything or returns the errno of the failure (0 on success).
int write_all(int fd, const char* p, std::size_t left) {
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    p += n;
    left -= std::size_t(n);
  }
  return 0;
}

// (fsync,) close, rename onto the real name; on failure the temporary file is removed and an
// Error naming the path is thrown. When durable, the data is on disk before the rename makes it
// visible.
void finish_now(int& fd, const std::string& tmp, const std::string& path, bool durable) {
  auto fail = [&](const std::string& what, int e) {
    discard(fd, tmp);
    throw Error("output", what + " '" + path + "': " + errno_text(e));
  };
  if (durable && ::fsync(fd) != 0) fail("cannot write", errno);
  const int closed = ::close(fd);
  fd = -1;
  if (closed != 0) fail("cannot write", errno);
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) fail("cannot replace", ec.value());
  untrack(tmp);
}

}  // namespace

std::unique_ptr<OutputStream> Output::open(const std::string& filename, std::size_t size_hint) {
  // Collects the pieces; the file appears (through put) only at close().
  class Collect final : public OutputStream {
   public:
    Collect(Output& out, std::string name, std::size_t hint) : out_(out), name_(std::move(name)) { bytes_.reserve(hint); }
    void write(std::string_view b) override { bytes_.append(b); }
    void close() override {
      if (closed_) return;
      closed_ = true;
      out_.put(name_, std::move(bytes_));
    }

   private:
    Output& out_;
    std::string name_, bytes_;
    bool closed_ = false;
  };
  return std::make_unique<Collect>(*this, filename, size_hint);
}

void write_file_atomic(const std::string& path, std::string_view bytes) {
  TempFile t = create_temp(path);
  if (const int e = write_all(t.fd, bytes.data(), bytes.size())) {
    discard(t.fd, t.tmp);
    throw Error("output", "cannot write '" + path + "': " + errno_text(e));
  }
  finish_now(t.fd, t.tmp, path, true);
}

// A FileOutput's stream: the pieces go straight into the temporary file.
class FileOutputStream final : public OutputStream {
 public:
  FileOutputStream(FileOutput& owner, std::string filename, TempFile t)
      : owner_(owner), filename_(std::move(filename)), t_(std::move(t)) {}
  ~FileOutputStream() override { discard(t_.fd, t_.tmp); }
  void write(std::string_view b) override {
    if (t_.fd < 0) throw Error("output", "write to '" + t_.path + "' after close");
    if (const int e = write_all(t_.fd, b.data(), b.size())) {
      discard(t_.fd, t_.tmp);
      throw Error("output", "cannot write '" + t_.path + "': " + errno_text(e));
    }
    bytes_ += b.size();
  }
  void close() override {
    if (t_.fd < 0) return;
    // Give back the blocks reserved past what was written (an estimate may be too large).
    if (t_.preallocated && ::ftruncate(t_.fd, off_t(bytes_)) != 0) {
      const int e = errno;
      discard(t_.fd, t_.tmp);
      throw Error("output", "cannot write '" + t_.path + "': " + errno_text(e));
    }
    FileOutput::Pending p{filename_, std::move(t_.tmp), t_.path, t_.fd, bytes_};
    t_.fd = -1;  // the FileOutput owns the file from here on
    t_.tmp.clear();
    owner_.finished(std::move(p));
  }

 private:
  FileOutput& owner_;
  std::string filename_;
  TempFile t_;
  std::uint64_t bytes_ = 0;
};

FileOutput::FileOutput(std::string dir, Mode mode, Sync sync) : dir_(std::move(dir)), mode_(mode), sync_(sync) {
  if (dir_.empty()) dir_.push_back('.');  // (not `= "."`: GCC 12 -Wrestrict false positive, PR 105329)
  // Nothing is created here, so that a run which fails before its first file leaves the file
  // system as it was: check that the directory, or else its nearest existing ancestor (where the
  // first file will create the rest), is a directory we can write into.
  std::error_code ec;
  fs::path existing = fs::path(dir_);
  while (!fs::exists(existing, ec)) {
    const fs::path parent = existing.parent_path();
    if (parent.empty() || parent == existing) {
      existing = ".";
      break;
    }
    existing = parent;
  }
  if (!fs::is_directory(existing, ec))
    throw Error("output", "cannot create directory '" + dir_ + "': " +
                              (existing == fs::path(dir_) ? std::string("exists and is not a directory")
                                                          : "'" + existing.string() + "' is not a directory"));
  // W_OK|X_OK: we need to create entries in it. (root passes access(); a read-only file system
  // still reports EROFS.)
  if (::access(existing.c_str(), W_OK | X_OK) != 0)
    throw Error("output", "cannot write to '" + existing.string() + "': " + errno_text(errno));
  // Temporary files of runs that died (SIGKILL, power cut) before renaming or removing them.
  if (existing == fs::path(dir_)) remove_dead_temporaries(dir_);
}

void FileOutput::create_directory() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (created_) return;
  std::error_code ec;
  // Remember the directories this creates (deepest first), to remove them again if the run fails.
  for (fs::path p = fs::path(dir_); !p.empty() && !fs::exists(p, ec); p = p.parent_path()) {
    made_dirs_.push_back(p.string());
    if (p.parent_path() == p) break;
  }
  fs::create_directories(dir_, ec);
  if (ec) throw Error("output", "cannot create directory '" + dir_ + "': " + ec.message());
  if (!fs::is_directory(dir_, ec))
    throw Error("output", "cannot create directory '" + dir_ + "': " +
                              (ec ? ec.message() : std::string("exists and is not a directory")));
  created_ = true;
}

FileOutput::~FileOutput() {
  for (Pending& p : pending_) discard(p.fd, p.tmp);
  // A run that made no file visible leaves no directory it created (fs::remove only removes
  // empty directories: a file someone else put there keeps it).
  if (written_.empty() && !any_written_) {
    std::error_code ec;
    for (const std::string& d : made_dirs_) fs::remove(d, ec);
  }
}

std::string FileOutput::checked_path(const std::string& filename) const {
  // Writers emit plain names; refuse anything that would escape the directory.
  if (filename.empty() || filename == "." || filename == ".." || filename.find('/') != std::string::npos ||
      filename.find('\0') != std::string::npos)
    throw Error("output", "invalid file name '" + filename + "'");
  return (fs::path(dir_) / filename).string();
}

std::unique_ptr<OutputStream> FileOutput::open(const std::string& filename, std::size_t size_hint) {
  const std::string path = checked_path(filename);
  create_directory();
  if (mode_ == Mode::OnCommit) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::find(reserved_.begin(), reserved_.end(), filename) != reserved_.end())
      throw Error("output", "two outputs named '" + filename + "' in one run");
    reserved_.push_back(filename);
  }
  TempFile t = create_temp(path);
  if (size_hint >= kPreallocateMin) t.preallocated = ::fallocate(t.fd, FALLOC_FL_KEEP_SIZE, 0, off_t(size_hint)) == 0;
  return std::make_unique<FileOutputStream>(*this, filename, std::move(t));
}

void FileOutput::put(const std::string& filename, std::string bytes) {
  auto s = open(filename, bytes.size());
  s->write(bytes);
  s->close();
}

void FileOutput::finished(Pending p) {
  if (mode_ == Mode::Immediate) {
    finish_now(p.fd, p.tmp, p.path, sync_ == Sync::Durable);
    std::lock_guard<std::mutex> lock(mutex_);
    if (listing_)
      written_.push_back(p.path);
    else
      any_written_ = true;
    bytes_ += p.bytes;
    return;
  }
  // Durable: start the write-back now (asynchronous), so that commit()'s fsync finds little left
  // to do. Only a hint: its failure is caught by the fsync.
  if (sync_ == Sync::Durable) ::sync_file_range(p.fd, 0, 0, SYNC_FILE_RANGE_WRITE);
  std::lock_guard<std::mutex> lock(mutex_);
  pending_.push_back(std::move(p));
}

void FileOutput::prepare() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::sort(pending_.begin(), pending_.end(), [](const Pending& a, const Pending& b) { return a.filename < b.filename; });
  // Every file written (and, when durable, on disk) first; only then does any real name change.
  for (Pending& p : pending_) {
    if (p.fd < 0) continue;  // prepared before
    int e = sync_ == Sync::Durable && ::fsync(p.fd) != 0 ? errno : 0;
    if (::close(p.fd) != 0 && !e) e = errno;
    p.fd = -1;
    if (e) {
      const std::string path = p.path;
      for (Pending& q : pending_) discard(q.fd, q.tmp);
      pending_.clear();
      throw Error("output", "cannot write '" + path + "': " + errno_text(e));
    }
  }
}

void FileOutput::publish() {
  std::lock_guard<std::mutex> lock(mutex_);
  begin_publishing(" in '" + dir_ + "'");
  ++published;
  struct Done {
    bool on = true;
    void end() {
      if (on) --publishing;
      on = false;
    }
    ~Done() { end(); }
  } done;
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    std::error_code ec;
    fs::rename(pending_[k].tmp, pending_[k].path, ec);
    if (ec) {
      // rename(2) within one directory of one file system does not fail short of a vanished
      // directory or a full inode table; the files renamed before this one stay replaced.
      const std::string path = pending_[k].path;
      done.end();
      for (std::size_t r = k; r < pending_.size(); ++r) discard(pending_[r].fd, pending_[r].tmp);
      pending_.clear();
      throw Error("output", "cannot replace '" + path + "': " + ec.message());
    }
    written_.push_back(pending_[k].path);
    bytes_ += pending_[k].bytes;
  }
  done.end();  // before untrack, which waits for the lock an exiting process may hold
  for (const Pending& p : pending_) untrack(p.tmp);  // after the renames: may wait for an exiting process
  pending_.clear();
}

bool remove_live_temporaries() noexcept {
  // Takes the registry's lock and, when it removes the temporaries, keeps it: no temporary is
  // created, and no commit starts, after this. A commit under way (its renames started) is the
  // run's point of no return: then nothing is removed and the caller is told to let it finish.
  live_mutex().lock();
  if (publishing.load() > 0) {
    live_mutex().unlock();
    return false;
  }
  closed_for_exit = true;
  for (const std::string& t : live_temps()) ::unlink(t.c_str());
  live_temps().clear();
  return true;
}

std::uint64_t commits_published() noexcept { return published.load(); }

namespace {
// Whether process `pid` can still write: it exists and is not a zombie (a process killed whose
// parent has not reaped it yet, e.g. an MPI rank whose mpirun was killed: kill(pid, 0) still
// succeeds for it, but it will never rename or remove its temporary files).
bool process_alive(long pid) {
  if (::kill(pid_t(pid), 0) != 0 && errno == ESRCH) return false;
  char path[48];
  std::snprintf(path, sizeof path, "/proc/%ld/stat", pid);
  FILE* f = std::fopen(path, "r");
  if (!f) return true;  // no /proc: trust kill()
  char buf[512];
  const std::size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  buf[n] = 0;
  const char* close = std::strrchr(buf, ')');  // "pid (comm) state …": comm may hold ')'
  return !(close && close[1] == ' ' && (close[2] == 'Z' || close[2] == 'X'));
}
}  // namespace

std::size_t remove_dead_temporaries(const std::string& dir) {
  std::size_t removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    // ".NAME.tmp-PID-XXXXXX", a regular file (never a link or a folder).
    if (name.size() < 2 || name[0] != '.') continue;
    const auto at = name.rfind(".tmp-");
    if (at == std::string::npos || at == 0) continue;
    const std::string rest = name.substr(at + 5);
    const auto dash = rest.find('-');
    if (dash == std::string::npos || dash == 0 || dash > 10 || rest.size() - dash - 1 != 6) continue;
    const std::string pid_text = rest.substr(0, dash);
    if (pid_text.find_first_not_of("0123456789") != std::string::npos) continue;
    const long pid = std::stol(pid_text);
    if (pid <= 0 || pid == long(::getpid())) continue;
    if (process_alive(pid)) continue;  // alive, or not ours to ask: in use
    std::error_code st;
    if (!fs::is_regular_file(fs::symlink_status(it->path(), st))) continue;
    if (fs::remove(it->path(), st)) ++removed;
  }
  return removed;
}

void commit_all(const std::vector<Output*>& outputs) {
  for (Output* o : outputs) o->prepare();
  // The publishes are one commit for remove_live_temporaries: it never runs between two of them
  // (the first output's files new, the next one's removed).
  begin_publishing("");
  struct Done {
    ~Done() { --publishing; }
  } done;
  for (Output* o : outputs) o->publish();
}

// ---- encoders -----------------------------------------------------------------------------

std::string encode_png_gray16(const Layer& l, int nx, int nz) {
  check_layer(l, nx, nz, 1, "16-bit PNG");
  std::vector<std::uint16_t> px(l.data.size());
  for (std::size_t k = 0; k < px.size(); ++k) px[k] = to_u16(l.data[k]);
  return encode_png(px.data(), px.size() * 2, nx, nz, 16, SPNG_COLOR_TYPE_GRAYSCALE, kPngLayers);
}

std::string encode_png_rgb8(const Layer& l, int nx, int nz) {
  check_layer(l, nx, nz, 3, "RGB PNG");
  std::vector<std::uint8_t> px(l.data.size());
  for (std::size_t k = 0; k < px.size(); ++k) px[k] = to_u8(l.data[k]);
  return encode_png(px.data(), px.size(), nx, nz, 8, SPNG_COLOR_TYPE_TRUECOLOR, kPngLayers);
}

std::string encode_png_rgb8(const std::uint8_t* rgb, int width, int height) {
  if (width < 1 || height < 1)
    throw Error("layer", "RGB PNG: invalid size " + std::to_string(width) + "x" + std::to_string(height));
  // One SUB filter instead of the adaptive choice: measured on an 8192² tilemap render (libspng
  // 0.7.3, level 4, one core) 715 ms and 6.67 MB against 1970 ms and 6.85 MB adaptive.
  return encode_png(rgb, std::size_t(width) * std::size_t(height) * 3, width, height, 8, SPNG_COLOR_TYPE_TRUECOLOR,
                    PngSettings{4, -1, SPNG_FILTER_CHOICE_SUB});
}

std::string encode_png_gray8(const Layer& l, int nx, int nz) {
  check_layer(l, nx, nz, 1, "8-bit PNG");
  std::vector<std::uint8_t> px(l.data.size());
  for (std::size_t k = 0; k < px.size(); ++k) px[k] = to_u8(l.data[k]);
  return encode_png(px.data(), px.size(), nx, nz, 8, SPNG_COLOR_TYPE_GRAYSCALE);
}

std::string encode_png_pixels(const void* pixels, std::size_t bytes, int width, int height, int bit_depth, int channels) {
  if (width < 1 || height < 1 || (bit_depth != 8 && bit_depth != 16) || channels < 1 || channels > 4 ||
      bytes != std::size_t(width) * std::size_t(height) * std::size_t(channels) * std::size_t(bit_depth / 8))
    throw Error("output", "PNG: " + std::to_string(bytes) + " bytes do not make a " + std::to_string(width) + "x" +
                              std::to_string(height) + " image of " + std::to_string(channels) + " channel(s) at " +
                              std::to_string(bit_depth) + " bits");
  static const int types[] = {SPNG_COLOR_TYPE_GRAYSCALE, SPNG_COLOR_TYPE_GRAYSCALE_ALPHA, SPNG_COLOR_TYPE_TRUECOLOR,
                              SPNG_COLOR_TYPE_TRUECOLOR_ALPHA};
  return encode_png(pixels, bytes, width, height, bit_depth, types[channels - 1]);
}

std::string encode_r16(const Layer& l) {
  if (l.channels != 1)
    throw Error("layer", "r16: layer has " + std::to_string(l.channels) + " channel(s), expected 1");
  std::string out(l.data.size() * 2, '\0');
  for (std::size_t k = 0; k < l.data.size(); ++k) {
    const std::uint16_t v = to_u16(l.data[k]);
    out[2 * k] = char(v & 0xFF);  // little-endian whatever the host
    out[2 * k + 1] = char(v >> 8);
  }
  return out;
}

}  // namespace relief
