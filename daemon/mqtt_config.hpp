#pragma once
// The optional [mqtt] table of guidewayd's configuration (docs/configuration.md): the broker, the
// credentials (a password only from a file) and the machine's place in the topic tree.

#include <optional>
#include <string>

#include "core/toml_access.hpp"
#include "plant/publisher.hpp"

namespace guideway::daemon {

// Throws ConfigError naming the file, line and key: a bad broker URL, a file that cannot be read, a
// password file other users can read, a machine name that cannot be a topic level, ...
// `relative_to` is the configuration file (relative paths are relative to it); the journal directory
// is set by the caller once the state directory is known.
plant::PublisherSettings parse_mqtt_table(const TableReader& table, const std::string& relative_to);

}  // namespace guideway::daemon
