// The registry of session kinds (session.hpp): kinds added once, found by name.
#include "sessions/session.hpp"

#include <algorithm>

namespace guideway::sessions {

void SessionRegistry::add(SessionKind kind) {
  auto it = std::find_if(kinds_.begin(), kinds_.end(), [&](const SessionKind& k) { return k.kind == kind.kind; });
  if (it != kinds_.end()) {
    *it = std::move(kind);
  } else {
    kinds_.push_back(std::move(kind));
  }
}

const SessionKind* SessionRegistry::find(std::string_view kind) const {
  auto it = std::find_if(kinds_.begin(), kinds_.end(), [&](const SessionKind& k) { return k.kind == kind; });
  return it == kinds_.end() ? nullptr : &*it;
}

std::vector<std::string> SessionRegistry::kinds() const {
  std::vector<std::string> out;
  for (const auto& k : kinds_) out.push_back(k.kind);
  return out;
}

}  // namespace guideway::sessions
