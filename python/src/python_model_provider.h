// Python model classes as a source of a bank's models (bank.h,
// ModelProvider): a mode whose `model:` names a registered class gets an
// instance of it (python_model.h), built and checked by the library's bank
// builder like any plugin's model.
#ifndef SKIDIMM_PYTHON_PYTHON_MODEL_PROVIDER_H_
#define SKIDIMM_PYTHON_PYTHON_MODEL_PROVIDER_H_

#include <pybind11/pybind11.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"

namespace skidimm {
namespace python {

// Python model classes by the name a bank's `model:` gives.
using PythonModels = std::map<std::string, pybind11::object>;

// Provides the classes of `models`, which must outlive it. Its methods take
// the GIL themselves, so a bank is built with the GIL released (plugins load
// without Python). A class takes the `shared:` keys listed in its
// `shared_parameters`; an exception its constructor raises is a refusal of
// the mode's parameters.
class PythonModelProvider final : public ModelProvider {
 public:
  explicit PythonModelProvider(const PythonModels& models) : models_(models) {}

  bool provides(const std::string& model) const override;
  std::vector<std::string> shared_parameter_keys(const std::string& model) const override;
  ModelHandle create(const std::string& model, const sdk::ParameterSet& params) const override;
  ModelSource source(const std::string& model) const override;
  std::string describe() const override;

 private:
  const PythonModels& models_;
};

// Loads `file` with its plugins (found as plugin_location.h says) and the
// Python models of `models`. Call with the GIL held; it is released while
// the bank is built. Throws ConfigError with file, line and field.
Bank load_bank(const std::filesystem::path& file, const std::vector<std::filesystem::path>& plugin_paths,
               const PythonModels& models);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_PYTHON_MODEL_PROVIDER_H_
