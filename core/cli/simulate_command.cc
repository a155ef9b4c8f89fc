#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "commands.h"
#include "skidimm/config/bank.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/bank_writer.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/printable.h"
#include "skidimm/simulation/model_simulation.h"
#include "skidimm/simulation/scenario.h"

namespace skidimm {
namespace cli {

namespace {

// The bank of `bank_file` (`config`) with the columns of the log
// simulate_models() wrote from it (`columns`), everything else as it was.
void write_bank_reading(const std::filesystem::path& bank_file, BankConfig config,
                        const simulation::SimulatedColumns& columns, const std::filesystem::path& log,
                        const std::filesystem::path& output) {
  config.columns.time = columns.time;
  config.columns.inputs = columns.inputs;
  config.columns.measurements = columns.measurements;
  config.columns.truth_mode = columns.truth;
  fitting::write_bank_from_template(
      bank_file, output,
      {"The bank of " + bank_file.string() + " with the columns of the log that `skidimm simulate --bank` wrote",
       "from it (" + log.string() + "): each input and measurement under its own name where that bank reads",
       "an expression. Everything else is that bank's."},
      {{"columns", fitting::format_columns_block(config)}});
}

}  // namespace

int simulate(const SimulateOptions& options) {
  // Whether a .partial of this output was there before: only one this run left is reported.
  const std::filesystem::path partial = options.output.string() + ".partial";
  std::error_code ec;
  const bool partial_before = std::filesystem::exists(partial, ec);
  const int code = report_errors("skidimm simulate", [&] {
    if (!options.bank.empty() && !options.scenario.empty()) {
      throw UsageError("give either --scenario or --bank, not both");
    }
    if (!options.bank.empty()) {
      if (options.inputs_from.empty()) {
        throw UsageError("--bank needs --inputs-from LOG (its inputs and modes drive the models)");
      }
      if (options.duration > 0.0) {
        throw UsageError("--duration is the scenario's length; with --bank the log of --inputs-from sets it");
      }
      const Bank bank = Bank::load(options.bank, options.plugin_paths);
      {
        FatalSignalWording wording;
        wording.lost = "the log is not written";
        wording.every_model_call_marked = false;  // the simulation calls the models itself
        name_plugins_in_fatal_signals("skidimm simulate", bank, wording);
      }
      const LogSpec source = join_log_arguments({options.inputs_from});
      refuse_output_over_logs(options.output, "--output", {source});
      std::vector<NamedFile> outputs{{"--output", options.output}};
      if (!options.output_bank.empty()) {
        refuse_output_over_logs(options.output_bank, "--output-bank", {source});
        outputs.push_back({"--output-bank", options.output_bank});
      }
      refuse_clashing_files(outputs, {{"--bank", options.bank}});
      // Written after the simulation: a path it cannot take is said first.
      if (!options.output_bank.empty()) check_output_path(options.output_bank, "--output-bank");
      const std::uint64_t seed = options.has_seed ? options.seed : 1;
      const simulation::ModelSimulationSummary summary = simulation::simulate_models(
          bank, source, sampling_of(bank.config, options.rate), seed, options.output);
      if (!options.quiet) {
        std::fprintf(stderr, "skidimm simulate: bank '%s' driven by %s (seed %llu): %ld rows, %ld mode switches -> %s\n",
                     bank.config.name.c_str(), source.name().c_str(), static_cast<unsigned long long>(seed),
                     summary.rows, summary.mode_switches, options.output.string().c_str());
      }
      const simulation::SimulatedColumns columns = simulation::simulated_log_columns(bank.config);
      if (!options.output_bank.empty()) {
        write_bank_reading(options.bank, bank.config, columns, options.output, options.output_bank);
        if (!options.quiet) std::cerr << "skidimm simulate: wrote " << options.output_bank.string() << "\n";
      } else if (!columns.renamed.empty() && !options.quiet) {
        std::string renamed;
        for (const std::string& name : columns.renamed) renamed += (renamed.empty() ? "" : ", ") + name;
        std::cerr << "skidimm simulate: the log has " << renamed
                  << " under their own names, where the bank reads expressions (or column texts that are not "
                     "plain names), so the bank cannot read it back; --output-bank writes a copy of the bank that "
                     "reads the log\n";
      }
      return kExitOk;
    }
    if (options.scenario.empty()) {
      throw UsageError("give --scenario (the physical simulator) or --bank with --inputs-from");
    }
    if (!options.inputs_from.empty()) {
      throw UsageError("--inputs-from drives a bank's models (--bank); a scenario drives its own");
    }
    if (!options.output_bank.empty()) throw UsageError("--output-bank writes a bank given with --bank, not a scenario");
    if (options.rate > 0.0) throw UsageError("--rate steps a bank's models (--bank); a scenario states its own rates");
    simulation::Scenario scenario = simulation::load_scenario(options.scenario);
    refuse_clashing_files({{"--output", options.output}}, {{"--scenario", options.scenario}});
    const double own_duration = scenario.duration;
    if (options.duration > 0.0) scenario.duration = options.duration;
    const std::uint64_t seed = options.has_seed ? options.seed : scenario.seed;
    const simulation::SimulationSummary summary = simulation::simulate(scenario, seed, options.output);
    if (!options.quiet) {
      std::string modes;
      for (const std::string& m : summary.modes_driven) modes += (modes.empty() ? "" : " -> ") + m;
      std::fprintf(stderr,
                   "skidimm simulate: scenario '%s' (%s, %.1f s, seed %llu): %ld rows -> %s\n"
                   "  modes: %s\n  peak horizontal acceleration %.2f m/s^2 (friction limit %.2f m/s^2)\n",
                   scenario.name.c_str(), simulation::to_string(scenario.maneuver.type), scenario.duration,
                   static_cast<unsigned long long>(seed), summary.rows, options.output.string().c_str(), modes.c_str(),
                   summary.max_horizontal_accel, summary.max_friction_accel);
    }
    // A switch at or after the end of the run and of the scenario's own
    // duration is never driven (a typo in `at` or `duration`); one a shorter
    // --duration cuts off was asked for.
    const double end = std::max(own_duration, scenario.duration);
    for (std::size_t i = 1; i < scenario.schedule.size(); ++i) {
      const simulation::ScheduleEntry& entry = scenario.schedule[i];
      if (entry.start < end) continue;
      std::fprintf(stderr,
                   "skidimm simulate: warning: %s: schedule[%zu] (at %g s, mode '%s') starts when the run of %g s "
                   "has ended: it is not driven\n",
                   options.scenario.string().c_str(), i, entry.start, printable(entry.mode).c_str(), scenario.duration);
    }
    // Past the start from rest (scenario.h), every bundled scenario keeps
    // up on every row; a tenth of the rows behind is a maneuver the robot
    // cannot drive on that terrain, and its log is of wheels slipping.
    if (summary.share_behind_command > 0.1) {
      const std::string shortfall =
          summary.reached_half_command
              ? "the body went less than half the maneuver's commanded speed on " +
                    std::to_string(static_cast<int>(std::lround(100.0 * summary.share_behind_command))) +
                    "% of the rows after it first reached half of it (at worst "
              : std::string("the body never went half the maneuver's commanded speed (at most ");
      std::fprintf(stderr,
                   "skidimm simulate: warning: %s: %s%.3g m/s where it commanded %.3g m/s): the robot cannot follow "
                   "this maneuver on this terrain, and the log is of wheels slipping; lower maneuver.speed (or the "
                   "turn it asks: maneuver.radius, maneuver.yaw_rate_amplitude), or lengthen maneuver.ramp\n",
                   options.scenario.string().c_str(), shortfall.c_str(), summary.body_speed, summary.commanded_speed);
    }
    return kExitOk;
  });
  if (code != kExitOk && !partial_before && std::filesystem::exists(partial, ec)) {
    std::cerr << "skidimm simulate: the rows simulated before the error are in " << partial.string() << "\n";
  }
  return code;
}

}  // namespace cli
}  // namespace skidimm
