// A minimal ZIP reader and writer over bytes in memory (zip_archive.hpp): stored and deflated members, CRC-32 checked.
#include "formats/zip_archive.hpp"

#include <zlib.h>

#include <algorithm>
#include <limits>

namespace guideway::formats {

namespace {

constexpr std::uint32_t local_signature = 0x04034b50;
constexpr std::uint32_t central_signature = 0x02014b50;
constexpr std::uint32_t end_signature = 0x06054b50;

std::uint32_t le(std::string_view s, std::size_t at, int bytes) {
  if (at > s.size() || s.size() - at < static_cast<std::size_t>(bytes)) throw ZipError("truncated archive");
  std::uint32_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | static_cast<std::uint8_t>(s[at + static_cast<std::size_t>(i)]);
  return v;
}

void put(std::string& s, std::uint32_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

std::uint32_t crc_of(std::string_view data) {
  uLong crc = crc32(0L, Z_NULL, 0);
  std::size_t off = 0;
  while (off < data.size()) {
    const auto n = static_cast<uInt>(std::min<std::size_t>(data.size() - off, 1u << 30));
    crc = crc32(crc, reinterpret_cast<const Bytef*>(data.data() + off), n);
    off += n;
  }
  return static_cast<std::uint32_t>(crc);
}

}  // namespace

std::vector<ZipEntry> zip_entries(std::string_view a) {
  if (a.size() < 22) throw ZipError("not a zip archive (too short)");
  // The end record is in the last 22 + 65535 bytes (it may carry a comment).
  std::size_t end = std::string_view::npos;
  const std::size_t lowest = a.size() > 22 + 65535 ? a.size() - 22 - 65535 : 0;
  for (std::size_t i = a.size() - 22 + 1; i-- > lowest;) {
    if (le(a, i, 4) == end_signature) {
      end = i;
      break;
    }
  }
  if (end == std::string_view::npos) throw ZipError("not a zip archive (no end of central directory)");
  const std::uint32_t count = le(a, end + 10, 2);
  const std::uint32_t cd_size = le(a, end + 12, 4);
  const std::uint32_t cd_offset = le(a, end + 16, 4);
  if (count == 0xffff || cd_offset == 0xffffffffu) throw ZipError("ZIP64 archives are not supported");
  if (std::uint64_t{cd_offset} + cd_size > end) throw ZipError("central directory outside the archive");
  std::vector<ZipEntry> entries;
  std::size_t p = cd_offset;
  for (std::uint32_t i = 0; i < count; ++i) {
    if (le(a, p, 4) != central_signature) throw ZipError("corrupt central directory");
    ZipEntry e;
    const std::uint32_t flags = le(a, p + 8, 2);
    e.method = static_cast<std::uint16_t>(le(a, p + 10, 2));
    e.crc32 = le(a, p + 16, 4);
    e.compressed_size = le(a, p + 20, 4);
    e.size = le(a, p + 24, 4);
    const std::uint32_t name_len = le(a, p + 28, 2), extra_len = le(a, p + 30, 2), comment_len = le(a, p + 32, 2);
    e.local_header_offset = le(a, p + 42, 4);
    if (p + 46 + name_len > a.size()) throw ZipError("truncated archive");
    e.name = std::string(a.substr(p + 46, name_len));
    if (flags & 1u) throw ZipError(e.name + ": encrypted members are not supported");
    entries.push_back(std::move(e));
    p += 46 + std::size_t{name_len} + extra_len + comment_len;
  }
  return entries;
}

std::string zip_extract(std::string_view a, const ZipEntry& e, std::uint64_t max_size) {
  const std::size_t h = e.local_header_offset;
  if (le(a, h, 4) != local_signature) throw ZipError(e.name + ": bad local header");
  const std::size_t data_at = h + 30 + le(a, h + 26, 2) + le(a, h + 28, 2);
  if (data_at > a.size() || a.size() - data_at < e.compressed_size)
    throw ZipError(e.name + ": data beyond the archive");
  if (e.size > max_size) throw ZipError(e.name + ": member too large");
  const std::string_view packed = a.substr(data_at, e.compressed_size);
  std::string out;
  if (e.method == 0) {
    if (e.compressed_size != e.size) throw ZipError(e.name + ": stored member with two sizes");
    out = std::string(packed);
  } else if (e.method == 8) {
    out.resize(e.size);
    z_stream z{};
    if (inflateInit2(&z, -MAX_WBITS) != Z_OK) throw ZipError("zlib: inflateInit2 failed");
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(packed.data()));
    z.avail_in = static_cast<uInt>(std::min<std::uint64_t>(packed.size(), std::numeric_limits<uInt>::max()));
    z.next_out = reinterpret_cast<Bytef*>(out.data());
    z.avail_out = static_cast<uInt>(std::min<std::uint64_t>(out.size(), std::numeric_limits<uInt>::max()));
    const int rc = inflate(&z, Z_FINISH);
    const std::uint64_t produced = z.total_out;
    inflateEnd(&z);
    if (rc != Z_STREAM_END || produced != e.size) throw ZipError(e.name + ": corrupt deflate data");
  } else {
    throw ZipError(e.name + ": compression method " + std::to_string(e.method) + " is not supported");
  }
  if (crc_of(out) != e.crc32) throw ZipError(e.name + ": CRC-32 mismatch");
  return out;
}

std::string zip_build(const std::vector<ZipMember>& members, bool deflate) {
  std::string archive, central;
  for (const ZipMember& m : members) {
    std::string packed = m.data;
    std::uint16_t method = 0;
    if (deflate) {
      z_stream z{};
      deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
      packed.resize(deflateBound(&z, static_cast<uLong>(m.data.size())));
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(m.data.data()));
      z.avail_in = static_cast<uInt>(m.data.size());
      z.next_out = reinterpret_cast<Bytef*>(packed.data());
      z.avail_out = static_cast<uInt>(packed.size());
      if (::deflate(&z, Z_FINISH) != Z_STREAM_END) {
        deflateEnd(&z);
        throw ZipError(m.name + ": deflate failed");
      }
      packed.resize(z.total_out);
      deflateEnd(&z);
      method = 8;
    }
    const std::uint32_t crc = crc_of(m.data);
    const auto offset = static_cast<std::uint32_t>(archive.size());
    auto header = [&](std::string& s, bool is_central) {
      put(s, is_central ? central_signature : local_signature, 4);
      if (is_central) put(s, 20, 2);  // version made by
      put(s, 20, 2);                  // version needed
      put(s, 0, 2);                   // flags
      put(s, method, 2);
      put(s, 0, 2);     // time
      put(s, 0x21, 2);  // date: 1980-01-01
      put(s, crc, 4);
      put(s, static_cast<std::uint32_t>(packed.size()), 4);
      put(s, static_cast<std::uint32_t>(m.data.size()), 4);
      put(s, static_cast<std::uint32_t>(m.name.size()), 2);
      put(s, 0, 2);  // extra length
      if (is_central) {
        put(s, 0, 2);  // comment length
        put(s, 0, 2);  // disk
        put(s, 0, 2);  // internal attributes
        put(s, 0, 4);  // external attributes
        put(s, offset, 4);
      }
      s += m.name;
    };
    header(archive, false);
    archive += packed;
    header(central, true);
  }
  const auto cd_offset = static_cast<std::uint32_t>(archive.size());
  archive += central;
  put(archive, end_signature, 4);
  put(archive, 0, 2);
  put(archive, 0, 2);
  put(archive, static_cast<std::uint32_t>(members.size()), 2);
  put(archive, static_cast<std::uint32_t>(members.size()), 2);
  put(archive, static_cast<std::uint32_t>(central.size()), 4);
  put(archive, cd_offset, 4);
  put(archive, 0, 2);
  return archive;
}

}  // namespace guideway::formats
