#include "skidimm/simulation/model_simulation.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "measured_outputs.h"
#include "random.h"
#include "skidimm/config/expression.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace simulation {

namespace {

// The column a value is written under: the bank's column when it reads a
// plain column, else the value's own name.
std::string column_for(const std::string& spec, const std::string& name) {
  return Expression::is_identifier(spec) ? spec : name;
}

// A square root of a covariance that tolerates semidefinite ones (a state
// without process noise): LDLT, with negative round-off pivots at zero.
Eigen::MatrixXd square_root(const Eigen::MatrixXd& covariance) {
  Eigen::LDLT<Eigen::MatrixXd> ldlt(covariance);
  const Eigen::VectorXd d = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
  Eigen::MatrixXd l = ldlt.matrixL();
  return ldlt.transpositionsP().transpose() * (l * d.asDiagonal());
}

std::string number(double v) { return std::isnan(v) ? "" : CsvWriter::format(v); }

}  // namespace

SimulatedColumns simulated_log_columns(const BankConfig& config) {
  SimulatedColumns columns;
  columns.time = config.columns.time;
  const auto add = [&](const std::string& spec, const std::string& name, std::vector<std::string>* written) {
    written->push_back(column_for(spec, name));
    if (written->back() != spec) columns.renamed.push_back(written->back());
  };
  for (std::size_t i = 0; i < config.input_names.size(); ++i) {
    add(config.columns.inputs[i], config.input_names[i], &columns.inputs);
  }
  for (std::size_t i = 0; i < config.measurement.names.size(); ++i) {
    add(config.columns.measurements[i], config.measurement.names[i], &columns.measurements);
  }
  columns.truth = config.columns.truth_mode.empty() ? "mode" : config.columns.truth_mode;
  return columns;
}

ModelSimulationSummary simulate_models(const Bank& bank, const LogSpec& source, const SamplingConfig& sampling,
                                       std::uint64_t seed, const std::filesystem::path& output) {
  const BankConfig& config = bank.config;
  LogReader reader(config, source.files, sampling);
  if (source.label.empty() && !reader.has_truth()) {
    throw Error(source.text + ": the source log needs " +
                (config.columns.truth_mode.empty()
                     ? std::string("a label (MODE=...), the bank naming no truth column (columns.truth_mode),")
                     : "a truth column '" + config.columns.truth_mode + "' or a label (MODE=...)") +
                " to say which mode drives each step");
  }
  const int n = config.state_dim();
  const SimulatedColumns columns = simulated_log_columns(config);
  std::vector<std::string> header{columns.time};
  header.insert(header.end(), columns.inputs.begin(), columns.inputs.end());
  header.insert(header.end(), columns.measurements.begin(), columns.measurements.end());
  header.push_back(columns.truth);
  for (const std::string& s : config.state_names) header.push_back("true_" + s);
  CsvWriter writer(output, header);

  MeasuredOutputs outputs(bank);
  Random random(seed);
  std::vector<Eigen::MatrixXd> r_roots;  // per mode: the noise its measurements get (its own R, else the bank's)
  for (int j = 0; j < config.num_modes(); ++j) r_roots.push_back(square_root(config.measurement_noise(j)));
  const Eigen::MatrixXd p0_root = square_root(config.initial_covariance);
  Eigen::VectorXd x = config.initial_state, next(n), noise(n);
  Eigen::VectorXd draw(std::max<Eigen::Index>(n, config.measurement.r.rows()));
  auto gaussian_vector = [&](Eigen::Index size) {
    for (Eigen::Index i = 0; i < size; ++i) draw[i] = random.gaussian();
    return draw.head(size);
  };
  Eigen::MatrixXd qd(n, n);
  ModelSimulationSummary summary;
  LogSample sample, previous;
  int previous_mode = -1;
  std::vector<std::string> cells(header.size());
  while (reader.next(&sample)) {
    const std::string& label = source.label.empty() ? sample.truth_mode : source.label;
    const int mode = config.mode_index(label);
    if (mode < 0) {
      // A class has several modes, and a step is simulated by one of them.
      const int class_index = config.class_index(label);
      std::string why = config.unknown_label(label);
      if (class_index >= 0) {
        std::string modes;
        for (const int j : config.classes[static_cast<std::size_t>(class_index)].modes) {
          modes += (modes.empty() ? "" : ", ") + config.modes[static_cast<std::size_t>(j)].name;
        }
        why = "'" + label + "' is a class of bank '" + config.name + "' (its modes: " + modes +
              "), and each step is simulated by one mode: label the log with one of them (" +
              modes.substr(0, modes.find(',')) + "=...)";
      }
      throw Error(source.text + ": step at t = " + CsvWriter::format(sample.t) + ": " + why);
    }
    const sdk::MotionModel& model = *bank.models[static_cast<std::size_t>(mode)];
    if (summary.rows == 0) {
      x = config.initial_state + p0_root * gaussian_vector(n);
    } else {
      const double dt = sample.t - previous.t;
      // The mode that fails is named with its plugin and its own words, and a
      // prediction that is not finite fails where it is made: written on, it
      // filled the log's rows with NaN, or failed at the next mode's step.
      const auto fail = [&](const std::string& what) {
        const std::size_t j = static_cast<std::size_t>(mode);
        const char* reason = model.failure_reason();
        throw Error(source.text + ": mode '" + label + "'" +
                    (j < bank.model_sources.size() ? " (" + bank.model_sources[j].describe() + ")" : std::string()) +
                    " could not propagate the state at t = " + CsvWriter::format(sample.t) + ": " + what +
                    (reason != nullptr && reason[0] != '\0' ? ": " + std::string(reason) : std::string()));
      };
      if (!model.predict(x, previous.u, dt, next)) fail("predict() failed");
      if (!model.process_noise(config.modes[static_cast<std::size_t>(mode)].q_intensity, x, previous.u, dt, qd)) {
        fail("process_noise() failed");
      }
      if (!next.allFinite()) fail("predict() returned a state that is not finite");
      if (!qd.allFinite()) fail("process_noise() returned a covariance that is not finite");
      x = next + square_root(0.5 * (qd + qd.transpose())) * gaussian_vector(n);
      summary.mode_switches += mode != previous_mode;
    }
    for (int i = 0; i < n; ++i) {
      if (config.angle_mask[static_cast<std::size_t>(i)]) x[i] = sdk::wrap_angle(x[i]);
    }
    Eigen::VectorXd z = config.measurement.h * x +
                        r_roots[static_cast<std::size_t>(mode)] * gaussian_vector(config.measurement.r.rows());
    // The outputs measured are the mode's outputs() at this step's input.
    if (outputs.any()) {
      std::string reason;
      if (!outputs.predict(mode, sample.u, &reason)) {
        throw Error(source.text + ": mode '" + label +
                    "' could not give its outputs at t = " + CsvWriter::format(sample.t) + ": " + reason);
      }
      z += outputs.expected(mode);
    }
    std::size_t c = 0;
    // In the unit the bank reads its time column in (columns.time_unit), so
    // that the bank runs on what it simulated.
    cells[c++] = CsvWriter::format(sample.t * config.columns.time_units_per_second);
    for (Eigen::Index i = 0; i < sample.u.size(); ++i) cells[c++] = CsvWriter::format(sample.u[i]);
    for (Eigen::Index i = 0; i < z.size(); ++i) {
      double value = z[i];
      if (config.measurement.is_angle[static_cast<std::size_t>(i)]) value = sdk::wrap_angle(value);
      cells[c++] = std::isfinite(sample.z[i]) ? number(value) : "";  // measured where the source was
    }
    cells[c++] = label;
    for (int i = 0; i < n; ++i) cells[c++] = CsvWriter::format(x[i]);
    writer.write_row(cells);
    previous = sample;
    previous_mode = mode;
    ++summary.rows;
  }
  if (summary.rows == 0) throw Error(source.text + ": the source log gives no step");
  writer.commit();
  return summary;
}

}  // namespace simulation
}  // namespace skidimm
