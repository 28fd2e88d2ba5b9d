#pragma once
// Internals of the world builder shared by src/world.cpp and src/world_store.cpp.
#include <cstdint>
#include <string>
#include <string_view>

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
}  // namespace relief::detail
