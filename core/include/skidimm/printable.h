// Text from files is echoed in messages and tables: a control character or an
// escape sequence in a CSV cell must not retitle or clear the user's
// terminal, and a NUL must not cut a message short.
#ifndef SKIDIMM_PRINTABLE_H_
#define SKIDIMM_PRINTABLE_H_

#include <string>
#include <string_view>

namespace skidimm {

// `text` with control characters (below 0x20 except tab, and 0x7f) and bytes
// that are not valid UTF-8 written as \xNN; valid UTF-8 is kept as it is.
std::string printable(std::string_view text);

}  // namespace skidimm

#endif  // SKIDIMM_PRINTABLE_H_
