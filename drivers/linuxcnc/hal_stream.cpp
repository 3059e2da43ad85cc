// The LinuxCNC bridge's stream (hal_stream.hpp): one text line per servo period, written and parsed.
#include "drivers/linuxcnc/hal_stream.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>

namespace guideway::drivers::linuxcnc {

namespace {

constexpr std::size_t max_line = 64 * 1024;

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// The next whitespace-separated word of `s` (removed from it); empty at the end.
std::string_view next_word(std::string_view& s) {
  s = trim(s);
  const auto end = s.find_first_of(" \t");
  const std::string_view word = s.substr(0, end);
  s.remove_prefix(end == std::string_view::npos ? s.size() : end);
  return word;
}

bool to_int(std::string_view word, std::int64_t& out) {
  const auto [p, ec] = std::from_chars(word.data(), word.data() + word.size(), out);
  return ec == std::errc() && p == word.data() + word.size();
}

bool to_double(std::string_view word, double& out) {
  const auto [p, ec] = std::from_chars(word.data(), word.data() + word.size(), out);
  return ec == std::errc() && p == word.data() + word.size() && std::isfinite(out);
}

}  // namespace

int HalStreamHeader::column(std::string_view name) const {
  const auto it = std::find(columns.begin(), columns.end(), name);
  return it == columns.end() ? -1 : static_cast<int>(it - columns.begin());
}

std::string format_hal_stream_header(const HalStreamHeader& header) {
  std::string out(hal_stream_magic);
  out += "\n# period_ns = " + std::to_string(header.period_ns) + "\n# columns = ";
  for (std::size_t i = 0; i < header.columns.size(); ++i) out += (i ? "," : "") + header.columns[i];
  out += "\n# end\n";
  return out;
}

std::vector<std::string> parse_column_list(std::string_view text) {
  std::vector<std::string> out;
  while (true) {
    const auto comma = text.find(',');
    const std::string name(trim(text.substr(0, comma)));
    if (name.empty() || name.find_first_of(" \t#!") != std::string::npos)
      throw std::invalid_argument("column list \"" + std::string(text) + "\": a name is empty or has a blank, # or !");
    if (std::find(out.begin(), out.end(), name) != out.end())
      throw std::invalid_argument("column \"" + name + "\" is named twice");
    out.push_back(name);
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  return out;
}

bool parse_period_line(std::string_view line, std::size_t count, std::int64_t& seq, std::span<double> values,
                       std::string& error) {
  std::string_view rest = line;
  if (!to_int(next_word(rest), seq)) {
    error = "no sample number";
    return false;
  }
  for (std::size_t i = 0; i < count; ++i) {
    const std::string_view word = next_word(rest);
    if (word.empty()) {
      error = std::to_string(i) + " values, " + std::to_string(count) + " expected";
      return false;
    }
    double v = 0.0;
    if (!to_double(word, v) || i >= values.size()) {
      error = "value " + std::to_string(i + 1) + " \"" + std::string(word) + "\" is not a number";
      return false;
    }
    values[i] = v;
  }
  if (!trim(rest).empty()) {
    error = "more than " + std::to_string(count) + " values";
    return false;
  }
  return true;
}

std::int64_t seq_step(std::int64_t from, std::int64_t to) {
  // sampler.N.sample-num is an s32: the difference modulo 2^32.
  return static_cast<std::int64_t>(static_cast<std::uint32_t>(static_cast<std::uint64_t>(to - from)));
}

HalStreamReader::HalStreamReader(PeriodFn on_period, LostFn on_lost)
    : on_period_(std::move(on_period)), on_lost_(std::move(on_lost)) {}

void HalStreamReader::feed(std::string_view bytes) {
  while (!bytes.empty() && error_.empty()) {
    const auto nl = bytes.find('\n');
    if (nl == std::string_view::npos) {
      partial_.append(bytes);
      if (partial_.size() > max_line) error_ = "a line longer than 64 KiB";
      return;
    }
    if (partial_.empty()) {
      line(bytes.substr(0, nl));
    } else {
      partial_.append(bytes.substr(0, nl));
      std::string whole;
      whole.swap(partial_);
      if (whole.size() > max_line) {
        error_ = "a line longer than 64 KiB";
        return;
      }
      line(whole);
    }
    bytes.remove_prefix(nl + 1);
  }
}

void HalStreamReader::header_line(std::string_view text) {
  if (!magic_seen_) {
    if (trim(text) != hal_stream_magic) {
      error_ = "not a guideway-linuxcnc-bridge stream (first line \"" + std::string(text.substr(0, 80)) + "\")";
      return;
    }
    magic_seen_ = true;
    return;
  }
  std::string_view body = trim(text.substr(1));
  if (body == "end") {
    if (header_.columns.empty() || header_.period_ns <= 0) {
      error_ = "the stream's header names no columns or no period_ns";
      return;
    }
    values_.assign(header_.columns.size(), 0.0);
    header_done_ = true;
    return;
  }
  const auto eq = body.find('=');
  if (eq == std::string_view::npos) return;  // a comment
  const std::string_view key = trim(body.substr(0, eq)), value = trim(body.substr(eq + 1));
  try {
    if (key == "period_ns") {
      std::int64_t ns = 0;
      if (!to_int(value, ns) || ns <= 0) throw std::invalid_argument("period_ns \"" + std::string(value) + "\"");
      header_.period_ns = ns;
    } else if (key == "columns") {
      header_.columns = parse_column_list(value);
    }
  } catch (const std::invalid_argument& e) {
    error_ = std::string("the stream's header: ") + e.what();
  }
}

void HalStreamReader::lost(std::uint64_t periods, std::string_view reason, bool announced) {
  counters_.lost += periods;
  if (!announced) counters_.lost_unannounced += periods;
  if (on_lost_) on_lost_(periods, reason);
}

void HalStreamReader::line(std::string_view text) {
  if (!header_done_) {
    if (!text.empty() && text.front() == '#') {
      header_line(text);
    } else {
      error_ = magic_seen_ ? "a line before the header's end: \"" + std::string(text.substr(0, 80)) + "\""
                           : "not a guideway-linuxcnc-bridge stream (first line \"" +
                                 std::string(text.substr(0, 80)) + "\")";
    }
    return;
  }
  if (text.empty() || text.front() == '#') return;
  if (text.front() == '!') {
    std::string_view rest = text.substr(1);
    std::int64_t n = 0;
    if (next_word(rest) == "lost" && to_int(next_word(rest), n) && n >= 0) {
      announced_ += static_cast<std::uint64_t>(n);
      lost(static_cast<std::uint64_t>(n), trim(rest), true);
      return;
    }
    ++counters_.bad_lines;
    last_bad_ = std::string(text.substr(0, 200));
    return;
  }
  std::int64_t seq = 0;
  std::string why;
  if (!parse_period_line(text, values_.size(), seq, values_, why)) {
    ++counters_.bad_lines;
    last_bad_ = std::string(text.substr(0, 200)) + " (" + why + ")";
    return;
  }
  if (have_seq_) {
    const std::int64_t step = seq_step(last_seq_, seq);
    if (step == 0) {  // the same period twice
      ++counters_.bad_lines;
      last_bad_ = std::string(text.substr(0, 200)) + " (sample number repeated)";
      return;
    }
    // A number half the counter's range ahead is one behind: the sampler was renumbered (setp
    // sampler.N.sample-num), nothing lost: the stream goes on from it.
    const auto gap = step >= (std::int64_t{1} << 31) ? 0 : static_cast<std::uint64_t>(step - 1);
    if (gap > 0) {
      const std::uint64_t covered = std::min(gap, announced_);
      announced_ -= covered;
      if (gap > covered) lost(gap - covered, "sample numbers skipped", false);
    }
  }
  have_seq_ = true;
  last_seq_ = seq;
  ++counters_.periods;
  on_period_(seq, values_);
}

}  // namespace guideway::drivers::linuxcnc
