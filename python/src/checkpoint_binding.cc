// skidimm.Checkpoint: a filter's state after a step (imm_checkpoint.h), as
// Imm.checkpoint() returns it and Imm.restore() takes it; saved and loaded as
// the checkpoint files of `skidimm run --save-checkpoint` / `--resume`
// (checkpoint_file.h), pickled as that text.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <string>

#include "bindings.h"
#include "skidimm/engine/imm_checkpoint.h"
#include "skidimm/io/checkpoint_file.h"
#include "skidimm/io/csv.h"

namespace py = pybind11;

namespace skidimm {
namespace python {

void bind_checkpoint(py::module_& m) {
  py::class_<ImmCheckpoint>(m, "Checkpoint",
                            "A filter's state after its last step (Imm.checkpoint(), Imm.restore()): restored into "
                            "an Imm of a bank with the same modes, states, inputs and measurement, every later step "
                            "is the uninterrupted filter's, bit for bit. save() and load() read and write the files "
                            "of `skidimm run --save-checkpoint` and `--resume`.")
      .def_readonly("t", &ImmCheckpoint::t, "The last step's time (s).")
      .def_readonly("started", &ImmCheckpoint::started, "False before the first step.")
      .def_readonly("mode_names", &ImmCheckpoint::mode_names)
      .def_property_readonly(
          "mode_probabilities", [](const ImmCheckpoint& c) { return c.estimate.mode_probabilities; },
          "Each mode's probability after the last step.")
      .def_property_readonly(
          "state", [](const ImmCheckpoint& c) { return c.estimate.state; }, "The combined state after the last step.")
      .def_property_readonly(
          "decision",
          [](const ImmCheckpoint& c) -> py::object {
            return c.decision ? py::object(py::str(c.decision->decision)) : py::none();
          },
          "The decision after the last step ('unknown' when none), or None if the checkpoint has no decision.")
      .def(
          "save", [](const ImmCheckpoint& c, const std::filesystem::path& path) { save_checkpoint(path, c); },
          py::arg("path"),
          "Writes the checkpoint file (YAML, every number read back exactly), complete under its name or not at all.")
      .def_static(
          "load", [](const std::filesystem::path& path) { return load_checkpoint(path); }, py::arg("path"),
          "Reads a checkpoint file; ConfigError names the line and field of anything not as written.")
      .def_property_readonly("text", &checkpoint_text, "The checkpoint file's text.")
      .def_static(
          "from_text", [](const std::string& text) { return parse_checkpoint(text, "<checkpoint text>"); },
          py::arg("text"))
      .def(py::pickle([](const ImmCheckpoint& c) { return checkpoint_text(c); },
                      [](const std::string& text) { return parse_checkpoint(text, "<pickled checkpoint>"); }))
      .def("__repr__", [](const ImmCheckpoint& c) {
        return "<skidimm.Checkpoint t=" + CsvWriter::format(c.t) + " modes=" + std::to_string(c.mode_names.size()) +
               (c.started ? "" : " not started") + ">";
      });
}

}  // namespace python
}  // namespace skidimm
