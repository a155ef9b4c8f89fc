// skidimm: identify the traction mode of a skid-steer robot from its logs.
//
//   skidimm run --bank B.yaml --input log.csv --output out.csv
//   skidimm validate B.yaml
//   skidimm simulate --scenario S.yaml --output log.csv
//   skidimm plugins
#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.h"

namespace fs = std::filesystem;
using namespace skidimm::cli;

int main(int argc, char** argv) {
  CLI::App app{"skidimm " SKIDIMM_VERSION ": Interacting Multiple Model identification of skid-steer traction modes"};
  app.require_subcommand(1);
  app.set_version_flag("--version", SKIDIMM_VERSION);

  std::vector<std::string> plugin_paths;
  auto add_plugin_path = [&plugin_paths](CLI::App* command) {
    command
        ->add_option("--plugin-path", plugin_paths,
                     "Directory (or plugin file) searched first for motion-model plugins; repeatable")
        ->check(CLI::ExistingPath);
  };

  RunOptions run_options;
  std::string bank, output;
  std::vector<std::string> inputs;
  CLI::App* run = app.add_subcommand("run", "Run a bank of modes over a log and write per-row estimates");
  run->add_option("--bank,-b", bank, "Bank file (YAML), see docs/bank-format.md")->required()->check(CLI::ExistingFile);
  run->add_option("--input,-i", inputs,
                  "Log CSV; repeat to read several files side by side (row i of each is one sample)")
      ->required()
      ->check(CLI::ExistingFile);
  run->add_option("--output,-o", output, "Output CSV (written as <output>.partial, renamed when complete)")->required();
  run->add_flag("--quiet,-q", run_options.quiet, "No summary or progress on stderr");
  add_plugin_path(run);

  std::string validate_bank;
  CLI::App* validate = app.add_subcommand("validate", "Check a bank file and its plugins without running it");
  validate->add_option("bank", validate_bank, "Bank file (YAML)")->required();
  add_plugin_path(validate);

  SimulateOptions simulate_options;
  std::string scenario, simulate_output;
  CLI::App* simulate =
      app.add_subcommand("simulate", "Simulate a skid-steer robot driving a scenario and write its sensor log");
  simulate->add_option("--scenario,-s", scenario, "Scenario file (YAML), see docs/simulation.md")
      ->required()
      ->check(CLI::ExistingFile);
  simulate->add_option("--output,-o", simulate_output, "Log CSV to write")->required();
  simulate->add_option("--seed", simulate_options.seed, "Random seed (default: the scenario's)");
  simulate->add_option("--duration", simulate_options.duration, "Seconds to simulate (default: the scenario's)")
      ->check(CLI::PositiveNumber);
  simulate->add_flag("--quiet,-q", simulate_options.quiet, "No summary on stderr");

  CLI::App* plugins = app.add_subcommand("plugins", "List the motion-model plugins found on the search path");
  add_plugin_path(plugins);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitUsage;
  }

  std::vector<fs::path> paths(plugin_paths.begin(), plugin_paths.end());
  if (*run) {
    run_options.bank = bank;
    run_options.inputs.assign(inputs.begin(), inputs.end());
    run_options.output = output;
    run_options.plugin_paths = paths;
    return skidimm::cli::run(run_options);
  }
  if (*validate) return skidimm::cli::validate(validate_bank, paths);
  if (*simulate) {
    simulate_options.scenario = scenario;
    simulate_options.output = simulate_output;
    simulate_options.has_seed = simulate->count("--seed") > 0;
    return skidimm::cli::simulate(simulate_options);
  }
  return skidimm::cli::plugins(paths);
}
