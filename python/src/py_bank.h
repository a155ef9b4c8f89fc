// Bank as Python holds it: the loaded bank shared with every Imm made from
// it, and what it was loaded from (so that Dask workers can load it again).
#ifndef SKIDIMM_PYTHON_PY_BANK_H_
#define SKIDIMM_PYTHON_PY_BANK_H_

#include <pybind11/pybind11.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "python_model_provider.h"
#include "skidimm/config/bank.h"

namespace skidimm {
namespace python {

// Not in an anonymous namespace: every binding file converts the same
// registered type.
struct PyBank {
  std::shared_ptr<Bank> bank;
  std::filesystem::path file;
  std::vector<std::filesystem::path> plugin_paths;
  PythonModels models;

  const BankConfig& config() const { return bank->config; }
};

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_PY_BANK_H_
