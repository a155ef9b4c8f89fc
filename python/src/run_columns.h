// A run's columns as Python gets them: numpy arrays made once for all rows
// (or taken over from a log run's vectors), written in place by the run
// (array_run.h), then handed over as the dict `skidimm run`'s columns make.
#ifndef SKIDIMM_PYTHON_RUN_COLUMNS_H_
#define SKIDIMM_PYTHON_RUN_COLUMNS_H_

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <vector>

#include "array_run.h"
#include "skidimm/config/bank.h"

namespace skidimm {
namespace python {

// A run's columns as numpy arrays, and where the run writes them
// (`columns`: into these arrays). Made for a known number of rows before the
// run (Imm.run), or from a log run's grown vectors without a copy.
struct RunArrays {
  pybind11::array_t<double> t;
  std::vector<pybind11::array_t<double>> mu, state, var;
  std::vector<pybind11::array_t<double>> unknown;  // one column with an unknown hypothesis, none without
  pybind11::array_t<std::int32_t> mode, decision;
  pybind11::array_t<std::int8_t> status;
  RunColumns columns;

  RunArrays(const BankConfig& config, long rows);
  explicit RunArrays(GrowingRunColumns&& grown);

  pybind11::ssize_t rows() const { return t.shape(0); }
};

// The columns `skidimm run` writes, in its order; `truth` (an object array
// of str, or None) is the truth_mode column.
pybind11::dict columns_to_dict(RunArrays&& c, const BankConfig& config, const pybind11::object& truth);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_RUN_COLUMNS_H_
