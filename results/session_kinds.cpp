// Each test-session kind as data (session_kinds.hpp): its name, its start options with their ranges, its headline
// figures.
#include "results/session_kinds.hpp"

#include <cstdio>
#include <stdexcept>

namespace guideway::results {

namespace {

constexpr const SessionKindInfo* kinds[] = {&dbb_kind, &runout_kind, &straightness_kind, &profile_kind};

}  // namespace

std::span<const SessionKindInfo* const> session_kinds() { return kinds; }

const SessionKindInfo* find_session_kind(std::string_view name) {
  for (const SessionKindInfo* k : kinds)
    if (k->name == name) return k;
  return nullptr;
}

const SessionKindInfo& session_kind(std::string_view name) {
  if (const SessionKindInfo* k = find_session_kind(name)) return *k;
  throw std::out_of_range("unknown session kind \"" + std::string(name) + "\" (known: " + session_kind_names() + ")");
}

std::string session_kind_names() {
  std::string out;
  for (const SessionKindInfo* k : kinds) out += (out.empty() ? "" : ", ") + std::string(k->name);
  return out;
}

int session_kind_rank(std::string_view name) {
  for (std::size_t i = 0; i < std::size(kinds); ++i)
    if (kinds[i]->name == name) return static_cast<int>(i);
  return static_cast<int>(std::size(kinds));
}

std::string option_with_default(const SessionOption& o) {
  std::string out(o.name);
  switch (o.type) {
    case OptionType::number:
    case OptionType::integer: {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%g", o.fallback);
      return out + "=" + buf;
    }
    case OptionType::text:
      if (!o.choices.empty())
        return out + "=" + std::string(o.choices) + " (default " + std::string(o.fallback_text) + ")";
      return out + "=" + std::string(o.fallback_text);
    case OptionType::json:
      break;
  }
  return out;
}

std::string description(const SessionKindInfo& kind) {
  std::string options;
  for (const SessionOption* o : kind.options) options += (options.empty() ? "" : ", ") + option_with_default(*o);
  return std::string(kind.summary) + " (options: " + options + ")";
}

std::span<const Parameter* const> headlines(const SessionKindInfo& kind) { return headline_parameters(kind.name); }

}  // namespace guideway::results
