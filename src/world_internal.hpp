#pragma once
// Internals of the world builder shared by src/world.cpp, src/world_store.cpp and the world
// algorithms (src/world_fill.cpp, src/world_flow.cpp).
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "relief/world.hpp"

namespace relief::detail {
std::uint32_t crc32_of(std::string_view bytes);  // zlib's CRC-32
// A tile file's checksum as world.json lists it: the CRC-32 of every byte before the trailer (the
// value the trailer holds). Not the CRC-32 of the whole file: appending a CRC-32 to its data gives
// the same CRC-32 (0x2144df1c, the residue) for every file, which would identify nothing.
std::uint32_t tile_checksum(std::string_view file_bytes);
std::string hex32(std::uint32_t v);                // 8 lower-case hex digits
std::string hash_hex(std::string_view text);       // FNV-1a 64 as 16 hex digits
std::string read_file_bytes(const std::string& path, bool& ok);
std::string encode_tile(const WorldTile& t);       // the version-1 tile file (relief/world.hpp)

// A tile file parsed without inflating or decoding its byte planes: the magic, CRC-32, header and
// every plane's framing checked as decode_world_tile checks them (same errors). `tile` holds the
// header's world_id, (X, Z) and window, and no layers.
struct TileParts {
  struct Part {
    std::string name;
    int channels = 1;
    std::size_t offset = 0, size = 0;  // the layer's four framed planes in the file's bytes
  };
  WorldTile tile;
  std::vector<Part> parts;  // in the file's order (ascending names)
};
TileParts parse_tile(std::string_view bytes, const std::string& origin);
// Decodes part k of a parsed file (its zlib streams checked as decode_world_tile checks them).
Layer decode_tile_part(std::string_view bytes, const TileParts& p, std::size_t k, const std::string& origin);
// Each layer's four framed planes, as encode_tile writes them (planes coded concurrently); `nx` is
// the tile's window width (the row length of the row delta).
std::vector<std::string> encode_tile_parts(const std::vector<const Layer*>& layers, int nx);
// A tile file from already framed parts: `parts` (name, channels, the layer's framed planes), in
// ascending name order; world_id, X, Z and window from `t` (its layers are ignored). The bytes
// encode_tile writes for the same layers.
struct RawPart {
  std::string name;
  int channels = 1;
  std::string_view planes;
};
std::string assemble_tile(const WorldTile& t, const std::vector<RawPart>& parts);

// The pending tiles of class `cls` (X mod 2 + 2·(Z mod 2): tiles of one class are never
// neighbours, so they can be solved at once), in tile order; their flags are cleared.
inline std::vector<std::int64_t> take_tile_class(std::vector<std::uint8_t>& pending, std::int64_t tiles_x, int cls) {
  std::vector<std::int64_t> batch;
  for (std::int64_t t = 0; t < std::int64_t(pending.size()); ++t)
    if (pending[std::size_t(t)] && int((t % tiles_x) % 2 + 2 * ((t / tiles_x) % 2)) == cls) {
      pending[std::size_t(t)] = 0;
      batch.push_back(t);
    }
  return batch;
}

// Tile work of the global world algorithms: compute(k) for every k of `items`, concurrently on the
// calling task arena's threads (at most 2 per thread in flight, which bounds memory), and
// merge(k, result) for each in the order of `items`, one at a time (it may overlap later computes).
// An exception of compute(k) is rethrown at k's turn to merge, so the first failure in order is the
// one thrown, whatever the thread count. No exception crosses the pipeline: a failure is kept, the
// pipeline drains (no new item starts, computes not yet begun are skipped) and the failure is
// rethrown after it. (oneTBB leaks the heap-held tokens of items in flight when an exception or a
// cancellation ends a pipeline; these tokens are indices, held in place.)
template <class R, class Compute, class Merge>
void ordered_tiles(const std::vector<std::int64_t>& items, Compute&& compute, Merge&& merge) {
  struct Item {
    std::optional<R> result;
    std::exception_ptr error;
  };
  // The pipeline passes plain indices (stored in its tokens without allocation); results live in
  // `slots`, which owns them even if the pipeline is cancelled from outside, and each is freed at
  // its merge.
  std::vector<Item> slots(items.size());
  std::size_t next = 0;
  std::exception_ptr failure;       // the first in order; written by the last (serial) stage only
  std::atomic<bool> failed{false};  // read by the other stages
  const std::size_t tokens = std::size_t(2 * std::max(1, tbb::this_task_arena::max_concurrency()));
  tbb::parallel_pipeline(
      tokens,
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& fc) -> std::size_t {
                                            if (next >= items.size() || failed.load()) {
                                              fc.stop();
                                              return 0;
                                            }
                                            return next++;
                                          }) &
          tbb::make_filter<std::size_t, std::size_t>(tbb::filter_mode::parallel,
                                                     [&](std::size_t i) {
                                                       if (failed.load()) return i;
                                                       try {
                                                         slots[i].result.emplace(compute(items[i]));
                                                       } catch (...) {
                                                         slots[i].error = std::current_exception();
                                                       }
                                                       return i;
                                                     }) &
          tbb::make_filter<std::size_t, void>(tbb::filter_mode::serial_in_order, [&](std::size_t i) {
            Item it = std::move(slots[i]);
            slots[i].result.reset();
            if (failure) return;
            try {
              if (it.error) std::rethrow_exception(it.error);
              merge(items[i], std::move(*it.result));
            } catch (...) {
              failure = std::current_exception();
              failed.store(true);
            }
          }));
  if (failure) std::rethrow_exception(failure);
}

// Progress over rounds that run until a fixpoint (their count unknown in advance), within the span
// [lo, lo + span) of a phase: round r takes [1 − 2^(1−r), 1 − 2^(−r)) of it, split evenly among the
// tiles pending when the round starts (a tile woken within the round adds a solve but no share: the
// share never decreases).
struct RoundProgress {
  double lo = 0, span = 0.5;  // the current round's part; the first round takes half the phase's span
  std::int64_t tiles = 1, done = 0;
  RoundProgress(double phase_lo, double phase_span) : lo(phase_lo), span(0.5 * phase_span) {}
  // Before round `round` (1-based), with `pending` its tiles' flags.
  void start(int round, const std::vector<std::uint8_t>& pending) {
    if (round > 1) lo += span, span *= 0.5;
    tiles = std::max<std::int64_t>(1, std::count(pending.begin(), pending.end(), std::uint8_t(1)));
    done = 0;
  }
  // The share after one more tile merged.
  double step() { return lo + span * double(std::min(++done, tiles)) / double(tiles); }
};
}  // namespace relief::detail
