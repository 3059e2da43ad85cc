#pragma once
// A minimal ZIP archive reader and writer over bytes in memory (what X3P containers need): the
// central directory, stored and deflated members (zlib), CRC-32 checked. No ZIP64, no encryption.
// Pure functions of their input; errors are ZipError exceptions with the reason.

#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace guideway::formats {

class ZipError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ZipEntry {
  std::string name;
  std::uint16_t method = 0;  // 0 stored, 8 deflated
  std::uint32_t crc32 = 0;
  std::uint64_t compressed_size = 0;
  std::uint64_t size = 0;
  std::uint64_t local_header_offset = 0;
};

// Reads the central directory. The archive must stay alive while its entries are extracted.
std::vector<ZipEntry> zip_entries(std::string_view archive);
// Extracts one member (inflating and checking its CRC-32); max_size guards against zip bombs.
std::string zip_extract(std::string_view archive, const ZipEntry& entry, std::uint64_t max_size = 1ull << 31);

struct ZipMember {
  std::string name;
  std::string data;
};
// Builds an archive; deflate = true compresses every member (zlib raw deflate).
std::string zip_build(const std::vector<ZipMember>& members, bool deflate);

}  // namespace guideway::formats
