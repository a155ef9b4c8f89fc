// Rows a writer has computed and holds, not yet written to its file: the
// handlers of report_fatal_signals() (skidimm/engine/fatal_signal_report.h)
// write them to `fd` before the program ends, so that a plugin's crash
// loses no row computed before it. One writer at a time (CsvWriter::
// write_rows_on_a_crash()); set after each whole row, cleared when the
// writer is done with its file. The writer and the models it writes the
// steps of run on one thread, so when a model crashes, the writer is not in
// the middle of changing them. Private to core/src.
#ifndef SKIDIMM_CORE_SRC_UNWRITTEN_ROWS_H_
#define SKIDIMM_CORE_SRC_UNWRITTEN_ROWS_H_

#include <cstddef>

namespace skidimm {
namespace internal {

void set_unwritten_rows(int fd, const char* data, std::size_t size) noexcept;
void clear_unwritten_rows() noexcept;

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_UNWRITTEN_ROWS_H_
