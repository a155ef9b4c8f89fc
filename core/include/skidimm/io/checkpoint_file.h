// Checkpoint files: an ImmCheckpoint (imm_checkpoint.h) as a YAML document,
// every number written as the shortest text that reads back to the same
// double (NaN and infinities as YAML's .nan, .inf and -.inf), so that a
// checkpoint read back restores a filter bit for bit. Written through
// OutputFile (complete under its name, or not there), read with errors
// naming the file, the line and the field. docs/engine.md, "Checkpoints".
#ifndef SKIDIMM_IO_CHECKPOINT_FILE_H_
#define SKIDIMM_IO_CHECKPOINT_FILE_H_

#include <filesystem>
#include <string>

#include "skidimm/engine/imm_checkpoint.h"

namespace skidimm {

// The file's text.
std::string checkpoint_text(const ImmCheckpoint& checkpoint);
// Writes the text to `path`. Throws Error naming the file.
void save_checkpoint(const std::filesystem::path& path, const ImmCheckpoint& checkpoint);

// Reads what save_checkpoint() wrote. Throws ConfigError naming the file,
// the line and the field of the first thing that is not as written. Whether
// the checkpoint fits a bank is Imm::restore's to say.
ImmCheckpoint load_checkpoint(const std::filesystem::path& path);
// The same from the text itself; `name` names it in errors.
ImmCheckpoint parse_checkpoint(const std::string& text, const std::string& name);

}  // namespace skidimm

#endif  // SKIDIMM_IO_CHECKPOINT_FILE_H_
