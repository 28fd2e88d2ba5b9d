// The world tile store (relief/world.hpp): the tile grid, the tile file format (float32,
// byte-shuffled, zlib, CRC-32 trailer), the manifest reader, verification and window reads.
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "relief/error.hpp"
#include "relief/world.hpp"
#include "world_internal.hpp"

namespace relief {

static_assert(std::endian::native == std::endian::little, "the tile store writes the host's floats as little-endian");

namespace {
constexpr char kMagic[8] = {'R', 'L', 'F', 'T', 'I', 'L', 'E', '1'};
constexpr std::uint64_t kZlibMaxRatio = 1032;

std::uint32_t get_u32(const unsigned char* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}
void put_u32(std::string& s, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) s.push_back(char((v >> (8 * k)) & 0xFF));
}
// zlib (RFC 1950) of `n` bytes with the RLE strategy at level 1, fed in pieces of at most 1 GiB
// (zlib counts in 32 bits).
std::string zlib_rle(const char* src, std::size_t n) {
  z_stream zs{};
  if (deflateInit2(&zs, 1, Z_DEFLATED, 15, 8, Z_RLE) != Z_OK) throw Error("output", "zlib could not start compressing a tile");
  std::string z(deflateBound(&zs, uLong(n)), '\0');
  std::size_t in_at = 0, out_at = 0;
  int zr = Z_OK;
  while (zr == Z_OK) {
    const std::size_t in_n = std::min<std::size_t>(n - in_at, std::size_t(1) << 30);
    const std::size_t out_n = std::min<std::size_t>(z.size() - out_at, std::size_t(1) << 30);
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(src) + in_at);
    zs.avail_in = uInt(in_n);
    zs.next_out = reinterpret_cast<Bytef*>(z.data() + out_at);
    zs.avail_out = uInt(out_n);
    zr = deflate(&zs, in_at + in_n == n ? Z_FINISH : Z_NO_FLUSH);
    in_at += in_n - zs.avail_in;
    out_at += out_n - zs.avail_out;
  }
  deflateEnd(&zs);
  if (zr != Z_STREAM_END) throw Error("output", "zlib could not compress a tile");
  z.resize(out_at);
  return z;
}

}  // namespace

namespace detail {

std::uint32_t crc32_of(std::string_view bytes) {
  return std::uint32_t(::crc32_z(0L, reinterpret_cast<const Bytef*>(bytes.data()), bytes.size()));
}

std::uint32_t tile_checksum(std::string_view file_bytes) {
  return file_bytes.size() < 4 ? crc32_of(file_bytes) : crc32_of(file_bytes.substr(0, file_bytes.size() - 4));
}

std::string hex32(std::uint32_t v) {
  char b[9];
  std::snprintf(b, sizeof b, "%08x", v);
  return b;
}

std::string hash_hex(std::string_view text) {
  std::uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a, 64-bit
  for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ull;
  char b[17];
  std::snprintf(b, sizeof b, "%016llx", (unsigned long long)h);
  return b;
}

std::string read_file_bytes(const std::string& path, bool& ok) {
  std::ifstream f(path, std::ios::binary);
  ok = bool(f);
  if (!ok) return {};
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::vector<std::string> encode_tile_parts(const std::vector<const Layer*>& layers, int nx) {
  // Row-delta, byte-shuffled floats, layer after layer (see relief/world.hpp).
  std::size_t raw = 0;
  for (const Layer* l : layers) raw += l->data.size() * 4;
  std::string shuffled(raw, '\0');
  std::size_t at = 0;
  std::vector<std::uint32_t> d;
  for (const Layer* l : layers) {
    const std::size_t m = l->data.size(), c = std::size_t(l->channels), row = std::size_t(nx) * c;
    d.resize(m);
    if (m) std::memcpy(d.data(), l->data.data(), m * 4);
    for (std::size_t r0 = 0; r0 < m; r0 += row)
      for (std::size_t k = r0 + row - 1; k >= r0 + c; --k) d[k] -= d[k - c];
    for (std::size_t b = 0; b < 4; ++b) {
      char* dst = shuffled.data() + at + b * m;
      for (std::size_t k = 0; k < m; ++k) dst[k] = char((d[k] >> (8 * b)) & 0xFF);
    }
    at += 4 * m;
  }
  d = {};
  // Each byte plane on its own (see relief/world.hpp), concurrently: stored when a zlib pass over
  // its first 64 KiB saves less than 10 % (the noisy low bytes), else zlib RLE.
  std::vector<std::pair<std::size_t, std::size_t>> planes;  // (offset, size) in `shuffled`
  for (const Layer* l : layers)
    for (std::size_t b = 0; b < 4; ++b) planes.push_back({0, l->data.size()});
  for (std::size_t k = 0, off = 0; k < planes.size(); ++k) {
    planes[k].first = off;
    off += planes[k].second;
  }
  std::vector<std::string> packed(planes.size());
  std::vector<std::uint8_t> method(planes.size(), 0);
  // Isolated: a thread waiting here must not pick up another tile of build_world's tile loop
  // (that would hold two tiles' buffers on one thread and let memory grow past the estimate).
  tbb::this_task_arena::isolate([&] { tbb::parallel_for(std::size_t(0), planes.size(), [&](std::size_t k) {
    const char* src = shuffled.data() + planes[k].first;
    const std::size_t m = planes[k].second;
    const std::size_t probe = std::min<std::size_t>(m, 65536);
    if (probe == 0 || zlib_rle(src, probe).size() * 10 > probe * 9) return;  // stored
    std::string z = zlib_rle(src, m);
    if (z.size() >= m) return;
    packed[k] = std::move(z);
    method[k] = 1;
  }); });
  // Each layer's four planes, framed: u8 method, u64 length, bytes.
  std::vector<std::string> out(layers.size());
  for (std::size_t li = 0; li < layers.size(); ++li) {
    std::string& o = out[li];
    std::size_t size = 0;
    for (std::size_t k = 4 * li; k < 4 * li + 4; ++k) size += 9 + (method[k] ? packed[k].size() : planes[k].second);
    o.reserve(size);
    for (std::size_t k = 4 * li; k < 4 * li + 4; ++k) {
      o.push_back(char(method[k]));
      const std::uint64_t len = method[k] ? packed[k].size() : planes[k].second;
      for (int q = 0; q < 8; ++q) o.push_back(char((len >> (8 * q)) & 0xFF));
      if (method[k]) o += packed[k];
      else o.append(shuffled.data() + planes[k].first, planes[k].second);
      packed[k] = std::string();
    }
  }
  return out;
}

std::string assemble_tile(const WorldTile& t, const std::vector<RawPart>& parts) {
  json layers = json::array();
  std::size_t raw = 0, payload = 0;
  const std::size_t n = std::size_t(t.window.nx) * std::size_t(t.window.nz);
  for (const RawPart& p : parts) {
    layers.push_back({{"name", p.name}, {"channels", p.channels}});
    raw += n * std::size_t(p.channels) * 4;
    payload += p.planes.size();
  }
  const json header = {{"format", 1},
                       {"world_id", t.world_id},
                       {"tile", {t.X, t.Z}},
                       {"window", {t.window.ix0, t.window.iz0, t.window.nx, t.window.nz}},
                       {"layers", layers},
                       {"encoding", "float32le-rowdelta-shuffle-planes"},
                       {"raw_bytes", raw},
                       {"payload_bytes", payload}};
  const std::string h = header.dump();
  std::string out;
  out.reserve(8 + 4 + h.size() + payload + 4);
  out.append(kMagic, 8);
  put_u32(out, std::uint32_t(h.size()));
  out += h;
  for (const RawPart& p : parts) out.append(p.planes.data(), p.planes.size());
  put_u32(out, crc32_of(out));
  return out;
}

std::string encode_tile(const WorldTile& t) {
  const std::size_t n = std::size_t(t.window.nx) * std::size_t(t.window.nz);
  std::vector<const Layer*> layers;
  for (auto& [name, l] : t.layers) {
    if (l.data.size() != n * std::size_t(l.channels))
      throw Error("tile", "layer '" + name + "' has " + std::to_string(l.data.size()) + " values, expected " +
                              std::to_string(n * std::size_t(l.channels)));
    layers.push_back(&l);
  }
  const std::vector<std::string> coded = encode_tile_parts(layers, t.window.nx);
  std::vector<RawPart> parts;
  std::size_t k = 0;
  for (auto& [name, l] : t.layers) parts.push_back({name, l.channels, coded[k++]});
  return assemble_tile(t, parts);
}

TileParts parse_tile(std::string_view bytes, const std::string& origin) {
  auto bad = [&](const std::string& why) { return Error("tile", origin + ": " + why); };
  if (bytes.size() < 16 || std::memcmp(bytes.data(), kMagic, 8) != 0) throw bad("not a Relief tile file (bad magic)");
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::uint32_t stored = get_u32(u + bytes.size() - 4);
  if (crc32_of(bytes.substr(0, bytes.size() - 4)) != stored) throw bad("CRC-32 mismatch (the file is damaged or incomplete)");
  const std::uint32_t hlen = get_u32(u + 8);
  if (std::uint64_t(hlen) + 16 > bytes.size()) throw bad("header length beyond the file");
  const json h = json::parse(bytes.substr(12, hlen), nullptr, false);
  if (!h.is_object() || h.value("format", 0) != 1 || !h.contains("window") || !h.contains("layers") || !h.contains("tile"))
    throw bad("header is not a version-1 tile header");
  TileParts p;
  WorldTile& t = p.tile;
  try {
    t.world_id = h.at("world_id").get<std::string>();
    t.X = h.at("tile").at(0).get<std::int64_t>();
    t.Z = h.at("tile").at(1).get<std::int64_t>();
    const json& w = h.at("window");
    t.window.ix0 = w.at(0).get<std::int64_t>();
    t.window.iz0 = w.at(1).get<std::int64_t>();
    t.window.nx = w.at(2).get<int>();
    t.window.nz = w.at(3).get<int>();
    if (t.window.nx < 1 || t.window.nz < 1 || t.window.nx > kMaxWorldTile || t.window.nz > kMaxWorldTile)
      throw bad("window size out of range");
    const std::size_t n = std::size_t(t.window.nx) * std::size_t(t.window.nz);
    std::size_t raw = 0;
    if (!h.at("layers").is_array() || h.at("layers").size() > 256) throw bad("expected at most 256 layers");
    for (const json& l : h.at("layers")) {
      const int c = l.at("channels").get<int>();
      if (c < 1 || c > 16) throw bad("layer channel count out of range");
      if (!l.at("name").is_string()) throw bad("a layer name is not a string");
      raw += n * std::size_t(c) * 4;
    }
    if (h.at("raw_bytes").get<std::uint64_t>() != raw) throw bad("raw_bytes does not match the layers");
    if (h.value("encoding", "") != "float32le-rowdelta-shuffle-planes") throw bad("unknown encoding");
    const std::uint64_t plen = h.at("payload_bytes").get<std::uint64_t>();
    if (12 + std::uint64_t(hlen) + plen + 4 != bytes.size()) throw bad("payload_bytes does not match the file size");
    // The byte planes: method (0 stored, 1 zlib), u64 length, bytes. Their framing is checked here,
    // so that no header makes a decoder allocate more than the planes can hold: a stored plane
    // holds its length, a zlib stream at most kZlibMaxRatio bytes per byte (deflate's limit is 1032:1).
    const std::size_t end = 12 + hlen + plen;
    std::size_t pos = 12 + hlen;
    for (const json& l : h.at("layers")) {
      const int c = l.at("channels").get<int>();
      const std::uint64_t m = std::uint64_t(n) * std::uint64_t(c);
      TileParts::Part part;
      part.name = l.at("name").get<std::string>();
      part.channels = c;
      part.offset = pos;
      for (int b = 0; b < 4; ++b) {
        if (pos + 9 > end) throw bad("byte planes end early");
        std::uint64_t len = 0;
        for (int q = 0; q < 8; ++q) len |= std::uint64_t(u[pos + 1 + q]) << (8 * q);
        pos += 9;
        if (len > end - pos) throw bad("a byte plane runs past the payload");
        if (u[pos - 9] == 0 ? len != m : (u[pos - 9] != 1 || m > len * kZlibMaxRatio + 64))
          throw bad("a byte plane's length does not fit its layer (" + std::to_string(m) + " bytes from " + std::to_string(len) + ")");
        pos += len;
      }
      part.size = pos - part.offset;
      p.parts.push_back(std::move(part));
    }
    if (pos != end) throw bad("bytes left after the byte planes");
  } catch (const json::exception& e) {
    throw bad(std::string("malformed header: ") + e.what());
  }
  return p;
}

Layer decode_tile_part(std::string_view bytes, const TileParts& p, std::size_t k, const std::string& origin) {
  auto bad = [&](const std::string& why) { return Error("tile", origin + ": " + why); };
  const TileParts::Part& part = p.parts.at(k);
  const auto* u = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t n = std::size_t(p.tile.window.nx) * std::size_t(p.tile.window.nz);
  const std::size_t m = n * std::size_t(part.channels);
  // parse_tile checked the framing: four planes, each a stored plane of m bytes or a zlib stream.
  std::string shuffled(4 * m, '\0');
  std::size_t pos = part.offset;
  for (int b = 0; b < 4; ++b) {
    const unsigned char method = u[pos];
    std::uint64_t len = 0;
    for (int q = 0; q < 8; ++q) len |= std::uint64_t(u[pos + 1 + q]) << (8 * q);
    pos += 9;
    char* dst = shuffled.data() + std::size_t(b) * m;
    if (method == 0) {
      if (len != m) throw bad("a stored byte plane has the wrong size");
      if (m) std::memcpy(dst, u + pos, m);
    } else if (method == 1) {
      uLongf got = uLongf(m);
      if (uncompress(reinterpret_cast<Bytef*>(dst), &got, u + pos, uLong(len)) != Z_OK || got != m)
        throw bad("a zlib byte plane does not decode to its size");
    } else {
      throw bad("unknown byte-plane method");
    }
    pos += len;
  }
  Layer layer;
  layer.channels = part.channels;
  layer.data.resize(m);
  std::vector<std::uint32_t> d(m, 0);
  for (std::size_t b = 0; b < 4; ++b) {
    const unsigned char* src = reinterpret_cast<const unsigned char*>(shuffled.data()) + b * m;
    for (std::size_t q = 0; q < m; ++q) d[q] |= std::uint32_t(src[q]) << (8 * b);
  }
  const std::size_t c = std::size_t(layer.channels), row = std::size_t(p.tile.window.nx) * c;
  for (std::size_t r0 = 0; r0 < m; r0 += row)
    for (std::size_t q = r0 + c; q < r0 + row; ++q) d[q] += d[q - c];
  if (m) std::memcpy(layer.data.data(), d.data(), m * 4);
  return layer;
}

}  // namespace detail

WorldGrid::Window WorldGrid::window(std::int64_t X, std::int64_t Z) const {
  Window w;
  w.ix0 = X * (tile - 1);
  w.iz0 = Z * (tile - 1);
  w.nx = int(std::min<std::int64_t>(tile, nx - w.ix0));
  w.nz = int(std::min<std::int64_t>(tile, nz - w.iz0));
  return w;
}

WorldGrid world_grid(std::int64_t nx, std::int64_t nz, std::int64_t tile, const std::string& size_path,
                     const std::string& tile_path) {
  if (nx < kMinSize || nz < kMinSize || nx > kMaxWorldSize || nz > kMaxWorldSize)
    throw Error(size_path, "expected " + std::to_string(kMinSize) + ".." + std::to_string(kMaxWorldSize) +
                               " samples per axis, got " + std::to_string(nx) + "x" + std::to_string(nz));
  const bool pow2_plus_1 = tile >= 3 && ((tile - 1) & (tile - 2)) == 0;
  if (!pow2_plus_1 || tile > kMaxWorldTile)
    throw Error(tile_path, "expected a tile size of 2^n+1 samples in 3.." + std::to_string(kMaxWorldTile) +
                               " (e.g. 257, 513, 1025), got " + std::to_string(tile));
  if (tile > std::max(nx, nz))
    throw Error(tile_path, "the tile (" + std::to_string(tile) + " samples) is larger than the world (" + std::to_string(nx) +
                               "x" + std::to_string(nz) + "); choose a tile of at most " + std::to_string(std::max(nx, nz)) +
                               " samples, or `relief generate` for one map");
  WorldGrid g;
  g.nx = nx;
  g.nz = nz;
  g.tile = int(tile);
  g.tiles_x = (nx - 1 + tile - 2) / (tile - 1);
  g.tiles_z = (nz - 1 + tile - 2) / (tile - 1);
  if (g.tiles_x * g.tiles_z > kMaxWorldTiles)
    throw Error(tile_path, "a tile of " + std::to_string(tile) + " samples makes " + std::to_string(g.tiles_x) + "x" +
                               std::to_string(g.tiles_z) + " tiles, more than the " + std::to_string(kMaxWorldTiles) +
                               " a world may have; choose a larger tile");
  return g;
}

std::string world_tile_path(std::int64_t X, std::int64_t Z) {
  char b[64];
  std::snprintf(b, sizeof b, "tiles/x%04lld_z%04lld.rtile", (long long)X, (long long)Z);
  return b;
}

WorldTile decode_world_tile(std::string_view bytes, const std::string& origin) {
  const detail::TileParts p = detail::parse_tile(bytes, origin);
  WorldTile t = p.tile;
  for (std::size_t k = 0; k < p.parts.size(); ++k) t.layers[p.parts[k].name] = detail::decode_tile_part(bytes, p, k, origin);
  return t;
}

WorldTile read_world_tile(const std::string& dir, std::int64_t X, std::int64_t Z) {
  const std::string path = (std::filesystem::path(dir) / world_tile_path(X, Z)).string();
  bool ok = false;
  const std::string bytes = detail::read_file_bytes(path, ok);
  if (!ok) throw Error("tile", "cannot read '" + path + "'");
  return decode_world_tile(bytes, path);
}

json read_world_manifest(const std::string& dir) {
  const std::string path = (std::filesystem::path(dir) / "world.json").string();
  bool ok = false;
  const std::string text = detail::read_file_bytes(path, ok);
  if (!ok) throw Error("output", "no world manifest '" + path + "'");
  json m = json::parse(text, nullptr, false);
  const auto is = [&](const char* key, json::value_t t) { return m.is_object() && m.contains(key) && m[key].type() == t; };
  if (!is("format", json::value_t::string) || m["format"] != "relief-world" || !is("world_id", json::value_t::string))
    throw Error("output", "'" + path + "' is not a Relief world manifest");
  // The fields the readers below use, with their types and ranges (a damaged or hand-edited file is
  // refused here, naming the field, rather than half-read).
  auto bad = [&](const std::string& field, const std::string& want) {
    return Error("output", "'" + path + "': " + field + ": expected " + want);
  };
  if (!is("frame", json::value_t::object)) throw bad("frame", "an object");
  const json& fr = m["frame"];
  if (!fr.contains("size") || !fr["size"].is_array() || fr["size"].size() != 2 || !fr["size"][0].is_number_integer() ||
      !fr["size"][1].is_number_integer())
    throw bad("frame.size", "[nx, nz], two integers");
  for (const char* k : {"width_m", "depth_m", "spacing_m", "height_m", "sea_level"})
    if (!fr.contains(k) || !fr[k].is_number() || !std::isfinite(fr[k].get<double>()))
      throw bad(std::string("frame.") + k, "a finite number");
  if (!is("grid", json::value_t::object) || !m["grid"].contains("tile") || !m["grid"]["tile"].is_number_integer())
    throw bad("grid.tile", "an integer");
  if (!is("layers", json::value_t::array) || m["layers"].size() > 256) throw bad("layers", "an array of at most 256 layers");
  for (const json& l : m["layers"])
    if (!l.is_object() || !l.contains("name") || !l["name"].is_string() || !l.contains("channels") ||
        !l["channels"].is_number_integer() || l["channels"].get<std::int64_t>() < 1 || l["channels"].get<std::int64_t>() > 16)
      throw bad("layers[]", "{\"name\": string, \"channels\": 1..16}");
  if (m.contains("tiles")) {
    if (!m["tiles"].is_array()) throw bad("tiles", "an array");
    for (const json& t : m["tiles"])
      if (!t.is_object() || !t.contains("tile") || !t["tile"].is_array() || t["tile"].size() != 2 || !t["tile"][0].is_number_integer() ||
          !t["tile"][1].is_number_integer() || !t.contains("bytes") || !t["bytes"].is_number_unsigned() || !t.contains("crc32") ||
          !t["crc32"].is_string())
        throw bad("tiles[]", "{\"tile\": [X, Z], \"bytes\": size, \"crc32\": hex}");
  }
  // The grid itself (sizes, tile) checked as a build checks it.
  try {
    world_grid(fr["size"][0].get<std::int64_t>(), fr["size"][1].get<std::int64_t>(), m["grid"]["tile"].get<std::int64_t>(),
               "frame.size", "grid.tile");
  } catch (const Error& e) {
    throw Error("output", "'" + path + "': " + e.what());
  }
  return m;
}

std::vector<std::string> verify_world(const std::string& dir) {
  const json m = read_world_manifest(dir);
  std::vector<std::string> bad;
  if (m.value("status", "") != "complete" || !m.contains("tiles")) {
    bad.push_back("world.json (the build is not complete)");
    return bad;
  }
  for (const json& t : m.at("tiles")) {
    const std::string rel = world_tile_path(t.at("tile").at(0).get<std::int64_t>(), t.at("tile").at(1).get<std::int64_t>());
    bool ok = false;
    const std::string bytes = detail::read_file_bytes((std::filesystem::path(dir) / rel).string(), ok);
    if (!ok || bytes.size() != t.at("bytes").get<std::uint64_t>() || detail::hex32(detail::tile_checksum(bytes)) != t.at("crc32"))
      bad.push_back(rel);
  }
  return bad;
}

Terrain read_world_window(const std::string& dir, std::int64_t ix0, std::int64_t iz0, int nx, int nz) {
  const json m = read_world_manifest(dir);
  const json& fr = m.at("frame");
  const WorldGrid g = world_grid(fr.at("size").at(0).get<std::int64_t>(), fr.at("size").at(1).get<std::int64_t>(),
                                 m.at("grid").at("tile").get<int>());
  if (nx < 1 || nz < 1 || ix0 < 0 || iz0 < 0 || ix0 + nx > g.nx || iz0 + nz > g.nz)
    throw Error("window", "expected a window inside the " + std::to_string(g.nx) + "x" + std::to_string(g.nz) + " world, got [" +
                              std::to_string(ix0) + ", " + std::to_string(iz0) + "] + " + std::to_string(nx) + "x" + std::to_string(nz));
  Terrain t;
  Frame f;
  f.world_width_m = fr.at("width_m").get<double>();
  f.world_depth_m = fr.at("depth_m").get<double>();
  f.spacing_m = fr.at("spacing_m").get<double>();
  f.height_m = fr.at("height_m").get<double>();
  f.sea_level = fr.at("sea_level").get<double>();
  t.frame = f.window(ix0, iz0, nx, nz);
  for (const json& l : m.at("layers")) t.layer(l.at("name").get<std::string>(), l.at("channels").get<int>());
  const std::int64_t step = g.tile - 1;
  const std::int64_t X0 = std::min(ix0 / step, g.tiles_x - 1), X1 = std::min((ix0 + nx - 1) / step, g.tiles_x - 1);
  const std::int64_t Z0 = std::min(iz0 / step, g.tiles_z - 1), Z1 = std::min((iz0 + nz - 1) / step, g.tiles_z - 1);
  for (std::int64_t Z = Z0; Z <= Z1; ++Z)
    for (std::int64_t X = X0; X <= X1; ++X) {
      const WorldTile tile = read_world_tile(dir, X, Z);
      const WorldGrid::Window w = g.window(X, Z);
      if (tile.world_id != m.at("world_id") || tile.window.ix0 != w.ix0 || tile.window.iz0 != w.iz0 || tile.window.nx != w.nx ||
          tile.window.nz != w.nz)
        throw Error("tile", world_tile_path(X, Z) + " is not the manifest's tile");
      // The overlap of this tile with the window.
      const std::int64_t a0 = std::max(ix0, w.ix0), a1 = std::min(ix0 + nx, w.ix0 + w.nx);
      const std::int64_t b0 = std::max(iz0, w.iz0), b1 = std::min(iz0 + nz, w.iz0 + w.nz);
      for (auto& [name, dst] : t.layers) {
        auto it = tile.layers.find(name);
        if (it == tile.layers.end() || it->second.channels != dst.channels)
          throw Error("tile", world_tile_path(X, Z) + " lacks layer '" + name + "'");
        const std::size_t c = std::size_t(dst.channels);
        for (std::int64_t z = b0; z < b1; ++z) {
          const float* src = it->second.data.data() + (std::size_t(z - w.iz0) * std::size_t(w.nx) + std::size_t(a0 - w.ix0)) * c;
          float* out = dst.data.data() + (std::size_t(z - iz0) * std::size_t(nx) + std::size_t(a0 - ix0)) * c;
          std::copy(src, src + std::size_t(a1 - a0) * c, out);
        }
      }
    }
  return t;
}

Frame world_frame(const Recipe& r, std::int64_t nx, std::int64_t nz) {
  World w = r.world;
  w.nx = int(nx);
  w.nz = int(nz);
  return w.frame();
}

}  // namespace relief
