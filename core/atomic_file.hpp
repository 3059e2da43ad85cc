#pragma once
// Whole files written so that a reader never sees half of one.

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <sys/types.h>

namespace guideway {

// Writes `content` to PATH.part, then renames it to PATH; a failed write removes PATH.part (no empty
// or truncated leftovers). With `exact_mode` (e.g. 0640) the file gets that mode whatever the umask;
// without, 0666 less the umask. Throws std::runtime_error naming the file and the cause.
void write_file_atomically(const std::string& path, std::string_view content,
                           std::optional<mode_t> exact_mode = std::nullopt);

// Files that are only right together (a controller's compensation tables and the INI lines that load
// them): every one is written to NAME.part first, and only when all are written are they renamed into
// `dir`; the `retired` names that are not in the set (a previous set's file that would be loaded with the
// new ones) are removed. The earlier set is kept aside (NAME.previous) until the new one is whole, so a
// failed write (a full disk) or a rename that fails half way (a directory in the way) leaves `dir` as it
// was: the old set whole, never a mix. Throws std::runtime_error naming the file and the cause.
struct NamedContent {
  std::string name;  // a file name in `dir`
  std::string content;
};
void write_file_set_atomically(const std::string& dir, const std::vector<NamedContent>& files,
                               const std::vector<std::string>& retired);

}  // namespace guideway
