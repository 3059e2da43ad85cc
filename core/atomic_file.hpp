#pragma once
// Whole files written so that a reader never sees half of one.

#include <optional>
#include <string>
#include <string_view>

#include <sys/types.h>

namespace guideway {

// Writes `content` to PATH.part, then renames it to PATH; a failed write removes PATH.part (no empty
// or truncated leftovers). With `exact_mode` (e.g. 0640) the file gets that mode whatever the umask;
// without, 0666 less the umask. Throws std::runtime_error naming the file and the cause.
void write_file_atomically(const std::string& path, std::string_view content,
                           std::optional<mode_t> exact_mode = std::nullopt);

}  // namespace guideway
