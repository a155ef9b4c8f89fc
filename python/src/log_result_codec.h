// evaluation::LogResult as a plain Python dict and back, losslessly (every
// double as a Python float), so that results computed on a Dask worker can
// be pickled to the client and reduced there exactly as the CLI reduces them.
//
// The dict mirrors the struct (log_evaluation.h, mode_metrics.h,
// consistency.h) field by field; a field added there must be added here.
#ifndef SKIDIMM_PYTHON_LOG_RESULT_CODEC_H_
#define SKIDIMM_PYTHON_LOG_RESULT_CODEC_H_

#include <pybind11/pybind11.h>

#include "skidimm/evaluation/log_evaluation.h"

namespace skidimm {
namespace python {

pybind11::dict to_dict(const evaluation::LogResult& result);
// Throws pybind11 errors (KeyError, TypeError) on a malformed dict.
evaluation::LogResult log_result_from_dict(const pybind11::dict& d);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_LOG_RESULT_CODEC_H_
