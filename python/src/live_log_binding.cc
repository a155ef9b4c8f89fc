// LiveLog: a log pushed row by row while it is read (live_log.h), the steps
// it completes as numpy arrays for Imm.step or Imm.run.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bindings.h"
#include "numpy_values.h"
#include "py_bank.h"
#include "skidimm/errors.h"
#include "skidimm/io/live_log.h"

namespace py = pybind11;

namespace skidimm {
namespace python {

namespace {

struct PyLiveLog {
  std::unique_ptr<LiveLog> live;
  std::size_t inputs = 0;
  std::size_t measurements = 0;

  int table_of(const py::object& table) const {
    if (py::isinstance<py::str>(table)) return live->table(table.cast<std::string>());
    if (py::isinstance<py::int_>(table)) return table.cast<int>();
    throw py::type_error("table: expected a table's name (str) or index (int)");
  }
};

// `tables`: [(name, [column, ...], offset), ...], as the Python class hands them.
std::vector<LiveTable> live_tables_of(
    const std::vector<std::tuple<std::string, std::vector<std::string>, double>>& given) {
  std::vector<LiveTable> out;
  for (const auto& [name, columns, offset] : given) out.push_back({name, columns, offset});
  return out;
}

}  // namespace

void bind_live_log(py::module_& m) {
  py::class_<PyLiveLog>(m, "LiveLog", "A log pushed row by row while it is read (live_log.h).")
      .def(py::init([](const PyBank& bank,
                       const std::vector<std::tuple<std::string, std::vector<std::string>, double>>& tables,
                       double rate) {
             SamplingConfig sampling = bank.config().sampling;
             if (rate != 0.0) sampling.rate = rate;
             PyLiveLog self;
             self.live = std::make_unique<LiveLog>(bank.config(), live_tables_of(tables), sampling);
             self.inputs = bank.config().input_names.size();
             self.measurements = bank.config().measurement.names.size();
             return self;
           }),
           py::arg("bank"), py::arg("tables"), py::arg("rate") = 0.0)
      .def(
          "push",
          [](PyLiveLog& self, const py::object& table, const py::object& row) {
            const int k = self.table_of(table);
            const DoubleArray values = DoubleArray::ensure(row);
            if (!values || values.ndim() < 1 || values.ndim() > 2) {
              throw py::value_error("row: expected a sequence of numbers (a row), or a 2-D array of rows");
            }
            const std::size_t width = values.ndim() == 1 ? static_cast<std::size_t>(values.shape(0))
                                                         : static_cast<std::size_t>(values.shape(1));
            const std::size_t rows = values.ndim() == 1 ? 1 : static_cast<std::size_t>(values.shape(0));
            const double* data = values.data();
            py::gil_scoped_release release;
            for (std::size_t r = 0; r < rows; ++r) {
              try {
                self.live->push(k, data + r * width, width);
              } catch (const Error& e) {
                if (rows == 1) throw;
                throw Error("row " + std::to_string(r) + " of the " + std::to_string(rows) +
                            " given (those before it were pushed): " + e.what());
              }
            }
          },
          py::arg("table"), py::arg("row"))
      .def(
          "close",
          [](PyLiveLog& self, const py::object& table) {
            if (table.is_none()) {
              self.live->close();
            } else {
              self.live->close(self.table_of(table));
            }
          },
          py::arg("table") = py::none())
      .def("steps",
           [](PyLiveLog& self) {
             std::vector<double> t, u, z;
             {
               py::gil_scoped_release release;
               try {
                 for (LogSample s; self.live->next(&s);) {
                   t.push_back(s.t);
                   u.insert(u.end(), s.u.data(), s.u.data() + s.u.size());
                   z.insert(z.end(), s.z.data(), s.z.data() + s.z.size());
                 }
               } catch (const Error&) {
                 // The steps before a refused row first; the next call raises (next() does, each time).
                 if (t.empty()) throw;
               }
             }
             const py::ssize_t n = static_cast<py::ssize_t>(t.size());
             py::array_t<double> uu = adopt(std::move(u));
             py::array_t<double> zz = adopt(std::move(z));
             return py::make_tuple(adopt(std::move(t)), uu.reshape({n, static_cast<py::ssize_t>(self.inputs)}),
                                   zz.reshape({n, static_cast<py::ssize_t>(self.measurements)}));
           })
      .def_property_readonly("ended",
                             [](PyLiveLog& self) {
                               py::gil_scoped_release release;
                               return self.live->ended();
                             })
      .def_property_readonly("waiting_for",
                             [](PyLiveLog& self) -> py::object {
                               LiveLog::Waiting waiting;
                               {
                                 py::gil_scoped_release release;
                                 waiting = self.live->waiting_for();
                               }
                               if (waiting.table < 0) return py::none();
                               return py::make_tuple(
                                   self.live->table_columns(waiting.table).name,
                                   waiting.rows > 0 ? py::object(py::float_(waiting.last_time)) : py::none());
                             })
      .def_property_readonly("tables",
                             [](const PyLiveLog& self) {
                               py::dict out;
                               for (int k = 0; k < self.live->num_tables(); ++k) {
                                 const LiveTable& t = self.live->table_columns(k);
                                 out[py::str(t.name)] = t.columns;
                               }
                               return out;
                             })
      .def("describe_stats",
           [](PyLiveLog& self) {
             py::gil_scoped_release release;
             return self.live->describe_stats();
           })
      .def("unmeasured",
           [](PyLiveLog& self) {
             py::gil_scoped_release release;
             return self.live->unmeasured();
           })
      .def_property(
          "max_queued_rows", [](const PyLiveLog& self) { return self.live->max_queued_rows(); },
          [](PyLiveLog& self, std::size_t rows) { self.live->set_max_queued_rows(rows); });
}

}  // namespace python
}  // namespace skidimm
