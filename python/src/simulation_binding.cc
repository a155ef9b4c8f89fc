// Simulation: a scenario's log (`skidimm simulate --scenario`) and a bank's
// own models driven by a log's inputs (`--bank --inputs-from`).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <optional>
#include <string>

#include "bindings.h"
#include "py_bank.h"
#include "python_model.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/io/log_reader.h"
#include "skidimm/simulation/model_simulation.h"
#include "skidimm/simulation/scenario.h"

namespace skidimm {
namespace python {

namespace py = pybind11;
namespace fs = std::filesystem;

void bind_simulation(py::module_& m) {
  m.def(
      "simulate_scenario",
      [](const fs::path& scenario, const fs::path& output, std::optional<unsigned long long> seed, double duration) {
        py::gil_scoped_release release;
        simulation::Scenario loaded = simulation::load_scenario(scenario);
        if (duration > 0.0) loaded.duration = duration;
        simulation::simulate(loaded, seed.value_or(loaded.seed), output);
      },
      py::arg("scenario"), py::arg("output"), py::arg("seed") = py::none(), py::arg("duration") = 0.0);
  m.def(
      "simulate_models",
      [](const PyBank& bank, const std::string& inputs_from, const fs::path& output, unsigned long long seed,
         double rate) {
        const LogSpec source = parse_log_spec(inputs_from);
        clear_python_model_error();
        simulation::ModelSimulationSummary summary;
        {
          py::gil_scoped_release release;
          summary = simulation::simulate_models(*bank.bank, source, sampling_of(bank.config(), rate), seed, output);
        }
        throw_if_python_model_raised();
        return py::make_tuple(summary.rows, summary.mode_switches);
      },
      py::arg("bank"), py::arg("inputs_from"), py::arg("output"), py::arg("seed") = 1, py::arg("rate") = 0.0);
}

}  // namespace python
}  // namespace skidimm
