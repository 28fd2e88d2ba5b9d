#pragma once
// Internals of the world builder shared by src/world.cpp and src/world_store.cpp.
#include <cstdint>
#include <string>
#include <string_view>

#include "relief/world.hpp"

namespace relief::detail {
std::uint32_t crc32_of(std::string_view bytes);  // zlib's CRC-32
std::string hex32(std::uint32_t v);                // 8 lower-case hex digits
std::string hash_hex(std::string_view text);       // FNV-1a 64 as 16 hex digits
std::string read_file_bytes(const std::string& path, bool& ok);
std::string encode_tile(const WorldTile& t);       // the version-1 tile file (relief/world.hpp)
}  // namespace relief::detail
