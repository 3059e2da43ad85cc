// Profile files from disk (profile_files.hpp): our CSV profiles and ISO 5436-2 X3P containers, read into one profile
// type.
#include "formats/profile_files.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/input_file.hpp"
#include "core/number_format.hpp"
#include "formats/zip_archive.hpp"

namespace guideway::formats {

namespace {

constexpr std::size_t profile_max_columns = 4096;

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r' || s.front() == '\n'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r' || s.back() == '\n'))
    s.remove_suffix(1);
  return s;
}

bool to_double(std::string_view s, double& out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && p == s.data() + s.size() && std::isfinite(out);
}

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i) {
    if (i == s.size() || s[i] == sep) {
      out.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  }
  return out;
}

std::string read_file(const std::string& path) {
  try {
    return read_text_file(path);  // a regular file within the input limits (core/input_file.hpp)
  } catch (const CsvError& e) {
    throw ProfileFileError(e.what());
  }
}

double unit_of(std::string_view column, char axis) {
  if (column.size() < 3 || column[0] != axis || column[1] != '_') return 0.0;
  const std::string_view u = column.substr(2);
  if (u == "m") return 1.0;
  if (u == "mm") return 1e-3;
  if (u == "um") return 1e-6;
  if (u == "nm" && axis == 'z') return 1e-9;
  return 0.0;
}

}  // namespace

std::optional<std::string> Profile::meta(std::string_view key) const {
  for (const auto& [k, v] : metadata) {
    if (k == key) return v;
  }
  return std::nullopt;
}

std::optional<double> Profile::spacing_m() const {
  if (x_m.size() < 2) return std::nullopt;
  const double d = (x_m.back() - x_m.front()) / static_cast<double>(x_m.size() - 1);
  if (!(d > 0)) return std::nullopt;
  for (std::size_t i = 1; i < x_m.size(); ++i) {
    if (std::abs((x_m[i] - x_m[i - 1]) - d) > 1e-6 * d + 1e-15) return std::nullopt;
  }
  return d;
}

Profile parse_profile_csv(std::string_view text, const std::string& name) {
  Profile p;
  std::size_t line_no = 0;
  int x_col = -1, z_col = -1;
  double x_scale = 0, z_scale = 0;
  std::size_t columns = 0;
  auto fail = [&](const std::string& why) -> ProfileFileError {
    return ProfileFileError(name + ":" + std::to_string(line_no) + ": " + why);
  };
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    const std::string_view raw = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    ++line_no;
    const std::string_view line = trim(raw);
    if (line.empty()) continue;
    if (line.front() == '#') {
      const std::string_view body = line.substr(1);
      const auto eq = body.find('=');
      if (eq != std::string_view::npos && !trim(body.substr(0, eq)).empty()) {
        p.metadata.emplace_back(std::string(trim(body.substr(0, eq))), std::string(trim(body.substr(eq + 1))));
      }
      continue;
    }
    if (const auto commas = static_cast<std::size_t>(std::count(line.begin(), line.end(), ','));
        x_col < 0 ? commas >= profile_max_columns : commas + 1 != columns)
      throw fail(x_col < 0 ? "more than " + std::to_string(profile_max_columns) + " columns"
                           : "expected " + std::to_string(columns) + " columns, got " + std::to_string(commas + 1));
    const auto cells = split(line, ',');
    if (x_col < 0) {  // the header row
      for (std::size_t i = 0; i < cells.size(); ++i) {
        const std::string_view c = trim(cells[i]);
        if (x_col < 0 && unit_of(c, 'x') > 0) {
          x_col = static_cast<int>(i);
          x_scale = unit_of(c, 'x');
        } else if (z_col < 0 && unit_of(c, 'z') > 0) {
          z_col = static_cast<int>(i);
          z_scale = unit_of(c, 'z');
        }
      }
      if (x_col < 0 || z_col < 0) throw fail("expected a header row naming x and z with units, e.g. x_mm,z_um");
      columns = cells.size();
      continue;
    }
    if (cells.size() != columns) {
      throw fail("expected " + std::to_string(columns) + " columns, got " + std::to_string(cells.size()));
    }
    double x = 0, z = 0;
    if (!to_double(cells[static_cast<std::size_t>(x_col)], x)) throw fail("x is not a number");
    const std::string_view zc = trim(cells[static_cast<std::size_t>(z_col)]);
    if (zc.empty() || zc == "nan" || zc == "NaN") {
      z = std::numeric_limits<double>::quiet_NaN();
    } else if (to_double(zc, z)) {
      z *= z_scale;
    } else {
      throw fail("z is not a number");
    }
    try {
      check_row_count(p.x_m.size() + 1, name, line_no);
    } catch (const CsvError& e) {
      throw ProfileFileError(e.what());
    }
    if (std::abs(x * x_scale) > profile_max_abs_x_m)
      throw fail("x = " + std::string(trim(cells[static_cast<std::size_t>(x_col)]).substr(0, 40)) +
                 " is outside +-10 m (a machine's travel)");
    if (std::abs(z) > profile_max_abs_z_m)
      throw fail("z = " + std::string(zc.substr(0, 40)) + " is outside +-10 mm (a profilometer's range)");
    p.x_m.push_back(x * x_scale);
    p.z_m.push_back(z);
  }
  if (x_col < 0) throw fail("no header row (x_mm,z_um)");
  if (p.x_m.empty()) throw fail("no data rows");
  return p;
}

Profile read_profile_csv(const std::string& path) { return parse_profile_csv(read_file(path), path); }

std::string format_profile_csv(const Profile& profile) {
  std::string out = "# format = guideway/profile/1\n";
  for (const auto& [k, v] : profile.metadata) {
    if (k != "format") out += "# " + k + " = " + v + "\n";
  }
  out += "x_mm,z_um\n";
  const std::size_t n = std::min(profile.x_m.size(), profile.z_m.size());
  for (std::size_t i = 0; i < n; ++i) {
    out += shortest(profile.x_m[i] * 1e3) + "," + (std::isnan(profile.z_m[i]) ? "" : shortest(profile.z_m[i] * 1e6)) +
           "\n";
  }
  return out;
}

void write_profile_csv(const std::string& path, const Profile& profile) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw ProfileFileError(path + ": cannot write: " + std::strerror(errno));
  out << format_profile_csv(profile);
  if (!out.flush()) throw ProfileFileError(path + ": write failed");
}

std::optional<std::string_view> xml_text(std::string_view doc, std::initializer_list<std::string_view> path) {
  std::string_view range = doc;
  std::size_t depth = 0;
  for (std::string_view name : path) {
    ++depth;
    std::size_t at = 0;
    std::size_t open_end = std::string_view::npos;
    while (true) {
      at = range.find(name, at);
      if (at == std::string_view::npos) return std::nullopt;
      const std::size_t after = at + name.size();
      if (at > 0 && range[at - 1] == '<' && after < range.size() &&
          (range[after] == '>' || range[after] == ' ' || range[after] == '/' || range[after] == '\t' ||
           range[after] == '\n' || range[after] == '\r')) {
        open_end = range.find('>', after);
        if (open_end == std::string_view::npos) return std::nullopt;
        break;
      }
      at = after;
    }
    if (range[open_end - 1] == '/') {  // <Name/> or <Name attr="..."/>
      return depth == path.size() ? std::optional<std::string_view>("") : std::nullopt;
    }
    const std::string close = "</" + std::string(name) + ">";
    const std::size_t content = open_end + 1;
    const std::size_t end = range.find(close, content);
    if (end == std::string_view::npos) return std::nullopt;
    range = range.substr(content, end - content);
  }
  return trim(range);
}

X3pSurface parse_x3p(std::string_view archive, const std::string& name) {
  auto fail = [&](const std::string& why) { return ProfileFileError(name + ": " + why); };
  try {
    const std::vector<ZipEntry> entries = zip_entries(archive);
    const ZipEntry* main = nullptr;
    for (const ZipEntry& e : entries) {
      if (e.name.rfind("__MACOSX/", 0) == 0) continue;
      if (e.name == "main.xml" || (e.name.size() > 9 && e.name.compare(e.name.size() - 9, 9, "/main.xml") == 0)) {
        if (!main || e.name.size() < main->name.size()) main = &e;
      }
    }
    if (!main) throw fail("no main.xml in the container (not an X3P file)");
    const std::string dir = main->name.substr(0, main->name.size() - 8);
    const std::string xml = zip_extract(archive, *main, 16u << 20);
    auto text = [&](std::initializer_list<std::string_view> path) { return xml_text(xml, path); };
    auto number = [&](std::initializer_list<std::string_view> path, double fallback, const char* what) {
      const auto t = text(path);
      if (!t || t->empty()) return fallback;
      double v = 0;
      if (!to_double(*t, v)) throw fail(std::string(what) + ": not a number: \"" + std::string(*t) + "\"");
      return v;
    };
    auto size = [&](std::string_view key) {
      const auto t = text({"Record3", "MatrixDimension", key});
      std::uint64_t v = 0;
      if (!t || std::from_chars(t->data(), t->data() + t->size(), v).ptr != t->data() + t->size() || v == 0 ||
          v > (1u << 28)) {
        throw fail("Record3.MatrixDimension." + std::string(key) + " missing or out of range");
      }
      return static_cast<std::size_t>(v);
    };
    X3pSurface s;
    s.feature_type = std::string(text({"Record1", "FeatureType"}).value_or(""));
    if (s.feature_type != "SUR" && s.feature_type != "PRF")
      throw fail("FeatureType \"" + s.feature_type + "\": expected SUR or PRF");
    for (const char* axis : {"CX", "CY"}) {
      if (text({"Record1", "Axes", axis, "AxisType"}).value_or("") != "I") {
        throw fail(std::string(axis) + ": only incremental (AxisType I) X and Y axes are supported");
      }
    }
    s.increment_x_m = number({"Record1", "Axes", "CX", "Increment"}, 0.0, "CX.Increment");
    s.increment_y_m = number({"Record1", "Axes", "CY", "Increment"}, 0.0, "CY.Increment");
    if (!(s.increment_x_m > 0) || !(s.increment_y_m > 0) || s.increment_x_m > profile_max_increment_m ||
        s.increment_y_m > profile_max_increment_m)
      throw fail("CX/CY increments must be in (0, 1] m");
    s.offset_x_m = number({"Record1", "Axes", "CX", "Offset"}, 0.0, "CX.Offset");
    s.offset_y_m = number({"Record1", "Axes", "CY", "Offset"}, 0.0, "CY.Offset");
    if (std::abs(s.offset_x_m) > profile_max_abs_x_m || std::abs(s.offset_y_m) > profile_max_abs_x_m)
      throw fail("CX/CY offsets must be within +-10 m (a machine's travel)");
    const std::string z_type(text({"Record1", "Axes", "CZ", "DataType"}).value_or(""));
    if (z_type.size() != 1 || std::string_view("DFLI").find(z_type[0]) == std::string_view::npos) {
      throw fail("CZ.DataType \"" + z_type + "\": expected D, F, L or I");
    }
    s.data_type = z_type[0];
    const double z_increment = number({"Record1", "Axes", "CZ", "Increment"}, 1.0, "CZ.Increment");
    const double z_offset = number({"Record1", "Axes", "CZ", "Offset"}, 0.0, "CZ.Offset");
    s.size_x = size("SizeX");
    s.size_y = size("SizeY");
    s.size_z = size("SizeZ");
    const std::uint64_t points = std::uint64_t{s.size_x} * s.size_y * s.size_z;
    if (points > (1u << 28)) throw fail("matrix too large");
    const auto link = text({"Record3", "DataLink", "PointDataLink"});
    if (!link || link->empty()) throw fail("no Record3.DataLink.PointDataLink (inline DataList is not supported)");
    const std::string bin_name = dir + std::string(*link);
    const ZipEntry* bin = nullptr;
    for (const ZipEntry& e : entries) {
      if (e.name == bin_name) bin = &e;
    }
    if (!bin) throw fail("point data \"" + bin_name + "\" not in the container");
    const std::size_t width = s.data_type == 'D' ? 8 : s.data_type == 'I' ? 2 : 4;
    if (bin->size != points * width) {
      throw fail(bin_name + ": " + std::to_string(bin->size) + " bytes, expected " + std::to_string(points * width) +
                 " for " + std::to_string(s.size_x) + " x " + std::to_string(s.size_y) + " x " +
                 std::to_string(s.size_z) + " of type " + z_type);
    }
    const std::string data = zip_extract(archive, *bin, points * width);
    const std::size_t n = s.size_x * s.size_y;  // first layer
    s.z_m.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      std::uint64_t u = 0;
      for (std::size_t b = width; b-- > 0;) u = (u << 8) | static_cast<std::uint8_t>(data[i * width + b]);
      double v = 0;
      switch (s.data_type) {
        case 'D':
          v = std::bit_cast<double>(u);
          break;
        case 'F':
          v = std::bit_cast<float>(static_cast<std::uint32_t>(u));
          break;
        case 'L':
          v = static_cast<std::int32_t>(static_cast<std::uint32_t>(u)) * z_increment;
          break;
        default:
          v = static_cast<std::int16_t>(static_cast<std::uint16_t>(u)) * z_increment;
          break;
      }
      s.z_m[i] = std::isfinite(v) ? v + z_offset : std::numeric_limits<double>::quiet_NaN();
    }
    auto add_meta = [&](const char* key, std::initializer_list<std::string_view> path) {
      if (const auto t = text(path); t && !t->empty()) s.metadata.emplace_back(key, std::string(*t));
    };
    add_meta("x3p_revision", {"Record1", "Revision"});
    add_meta("date", {"Record2", "Date"});
    add_meta("creator", {"Record2", "Creator"});
    add_meta("instrument_manufacturer", {"Record2", "Instrument", "Manufacturer"});
    add_meta("instrument_model", {"Record2", "Instrument", "Model"});
    add_meta("instrument_serial", {"Record2", "Instrument", "Serial"});
    add_meta("probing_system", {"Record2", "ProbingSystem", "Type"});
    add_meta("probe", {"Record2", "ProbingSystem", "Identification"});
    add_meta("comment", {"Record2", "Comment"});
    return s;
  } catch (const ZipError& e) {
    throw fail(e.what());
  }
}

X3pSurface read_x3p(const std::string& path) { return parse_x3p(read_file(path), path); }

Profile x3p_row(const X3pSurface& s, std::size_t iy, const std::string& source) {
  if (iy >= s.size_y)
    throw ProfileFileError("row " + std::to_string(iy) + " beyond the surface's " + std::to_string(s.size_y));
  Profile p;
  if (!source.empty()) p.metadata.emplace_back("source", source);
  p.metadata.emplace_back("row", std::to_string(iy));
  p.metadata.emplace_back("y_mm", shortest((s.offset_y_m + static_cast<double>(iy) * s.increment_y_m) * 1e3));
  p.metadata.emplace_back("spacing_um", shortest(s.increment_x_m * 1e6));
  p.metadata.insert(p.metadata.end(), s.metadata.begin(), s.metadata.end());
  p.x_m.resize(s.size_x);
  p.z_m.resize(s.size_x);
  for (std::size_t ix = 0; ix < s.size_x; ++ix) {
    p.x_m[ix] = s.offset_x_m + static_cast<double>(ix) * s.increment_x_m;
    p.z_m[ix] = s.at(ix, iy);
  }
  return p;
}

std::vector<Profile> x3p_profiles(const X3pSurface& s, const std::string& source) {
  std::vector<Profile> out;
  out.reserve(s.size_y);
  for (std::size_t iy = 0; iy < s.size_y; ++iy) out.push_back(x3p_row(s, iy, source));
  return out;
}

std::string build_x3p(const X3pSurface& s, bool deflate) {
  auto num = [](double v) { return shortest(v); };
  std::string xml =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<p:ISO5436_2 xmlns:p=\"http://www.opengps.eu/2008/ISO5436_2\">\n"
      "<Record1>\n<Revision>ISO5436 - 2000</Revision>\n<FeatureType>" +
      (s.size_y == 1 ? std::string("PRF") : std::string("SUR")) +
      "</FeatureType>\n<Axes>\n"
      "<CX><AxisType>I</AxisType><DataType>D</DataType><Increment>" +
      num(s.increment_x_m) + "</Increment><Offset>" + num(s.offset_x_m) +
      "</Offset></CX>\n"
      "<CY><AxisType>I</AxisType><DataType>D</DataType><Increment>" +
      num(s.increment_y_m) + "</Increment><Offset>" + num(s.offset_y_m) +
      "</Offset></CY>\n"
      "<CZ><AxisType>A</AxisType><DataType>D</DataType><Increment>1</Increment><Offset/></CZ>\n</Axes>\n</Record1>\n"
      "<Record2>\n<Creator>guideway</Creator>\n</Record2>\n"
      "<Record3>\n<MatrixDimension><SizeX>" +
      std::to_string(s.size_x) + "</SizeX><SizeY>" + std::to_string(s.size_y) +
      "</SizeY><SizeZ>1</SizeZ></MatrixDimension>\n<DataLink><PointDataLink>bindata/data.bin</PointDataLink></"
      "DataLink>\n"
      "</Record3>\n</p:ISO5436_2>\n";
  std::string bin;
  bin.reserve(s.z_m.size() * 8);
  for (double v : s.z_m) {
    const auto u = std::bit_cast<std::uint64_t>(v);
    for (int b = 0; b < 8; ++b) bin.push_back(static_cast<char>((u >> (8 * b)) & 0xff));
  }
  return zip_build({{"main.xml", xml}, {"bindata/data.bin", bin}}, deflate);
}

std::vector<Profile> read_profiles(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".x3p") return x3p_profiles(read_x3p(path), path);
  if (ext == ".csv") {
    Profile p = read_profile_csv(path);
    p.metadata.insert(p.metadata.begin(), {"source", path});
    return {std::move(p)};
  }
  throw ProfileFileError(path + ": unknown profile file type (expected .csv or .x3p)");
}

}  // namespace guideway::formats
