#pragma once
// Every node of a JSON document, for the property tests that replace any node of a real result by a value of
// any type (tests/results: explanation_test, params_test).

#include <cstddef>
#include <vector>

#include <nlohmann/json.hpp>

namespace guideway::test {

// Every node's pointer in `j`, the root's ("") included, appended to `out`.
inline void node_pointers(const nlohmann::json& j, const nlohmann::json::json_pointer& at,
                          std::vector<nlohmann::json::json_pointer>& out) {
  out.push_back(at);
  if (j.is_object())
    for (const auto& [k, v] : j.items()) node_pointers(v, at / k, out);
  if (j.is_array())
    for (std::size_t i = 0; i < j.size(); ++i) node_pointers(j[i], at / i, out);
}

inline std::vector<nlohmann::json::json_pointer> node_pointers(const nlohmann::json& j) {
  std::vector<nlohmann::json::json_pointer> out;
  node_pointers(j, nlohmann::json::json_pointer(), out);
  return out;
}

}  // namespace guideway::test
