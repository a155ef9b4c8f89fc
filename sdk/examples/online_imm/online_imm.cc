// A robot-loop style use of skidimm: load a bank once, push each sensor
// message into a LiveLog as it arrives, step the IMM with each step the
// messages complete, and act on the most likely mode. Here the messages are
// the rows of a log, split into two sensors (wheel encoders and odometry) as a
// robot's drivers would publish them; on a robot each push is in its
// driver's callback, at whatever rate it arrives.
//
// With a checkpoint file, the program is a node that may be restarted: if
// the file exists it goes on from the filter saved there (the messages up to
// its time are ones the node before already had), and it saves the filter
// there when the drive ends.
//
//   online_imm <bank.yaml> <log.csv> [checkpoint.yaml]
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "skidimm/engine/imm.h"
#include "skidimm/errors.h"
#include "skidimm/io/checkpoint_file.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/live_log.h"

int main(int argc, char** argv) {
  if (argc != 3 && argc != 4) {
    std::fprintf(stderr, "usage: %s <bank.yaml> <log.csv> [checkpoint.yaml]\n", argv[0]);
    return 2;
  }
  try {
    // The bundled plugins' directory comes from find_package(skidimm); banks
    // may add their own with plugin_paths, users with SKIDIMM_PLUGIN_PATH.
    skidimm::Imm imm = skidimm::Imm::from_yaml(argv[1], {SKIDIMM_PLUGIN_DIR});
    const std::filesystem::path checkpoint = argc == 4 ? argv[3] : "";
    double resumed_at = -1.0;  // the restored filter's last time; messages up to it were the last node's
    if (!checkpoint.empty() && std::filesystem::exists(checkpoint)) {
      imm.restore(skidimm::load_checkpoint(checkpoint));
      resumed_at = imm.estimate().t;
      std::printf("resumed at t = %.4f s\n", resumed_at);
    }
    // One table per sensor stream, with the columns the bank's expressions
    // name (the bank ltc_terrains.yaml: inputs from the wheels, V and omega
    // measured by odometry).
    const std::vector<std::string> wheel_columns = {"t", "phi_dot_L", "phi_dot_R"};
    const std::vector<std::string> odometry_columns = {"t", "V", "omega"};
    skidimm::LiveLog live(imm.config(), {{"wheels", wheel_columns}, {"odometry", odometry_columns}});
    const int wheels = live.table("wheels");
    const int odometry = live.table("odometry");

    int last_mode = -1;
    long steps = 0;
    const auto step_what_has_arrived = [&] {
      for (skidimm::LogSample sample; live.next(&sample);) {
        // step() allocates nothing: safe in a real-time loop.
        const skidimm::ImmEstimate& estimate = imm.step(sample.t, sample.u, sample.z);
        ++steps;
        const int mode = estimate.most_likely_mode;
        if (mode != last_mode && estimate.mode_probabilities[mode] > 0.9) {
          std::printf("t = %7.2f s: now on %s (p = %.3f)\n", sample.t, imm.config().modes[mode].name.c_str(),
                      estimate.mode_probabilities[mode]);
          last_mode = mode;
        }
      }
    };

    // The "drivers": each row of the log is a message of each sensor.
    skidimm::CsvReader log(argv[2]);
    const auto values = [&](const std::vector<std::string>& columns) {
      std::vector<double> row;
      for (const std::string& name : columns) {
        const int c = log.column(name);
        if (c < 0) throw skidimm::Error(log.path().string() + ": no column '" + name + "'");
        row.push_back(std::strtod(std::string(log.field(c)).c_str(), nullptr));
      }
      return row;
    };
    while (log.next_row()) {
      if (values({"t"})[0] <= resumed_at) continue;
      live.push(wheels, values(wheel_columns));       // the encoders' callback
      live.push(odometry, values(odometry_columns));  // the odometry's callback
      step_what_has_arrived();
    }
    live.close();  // the drive has ended: its last steps
    step_what_has_arrived();
    std::printf("%ld steps\n", steps);
    const skidimm::ImmEstimate& last = imm.estimate();
    std::printf("last step: t = %.17g, probabilities", last.t);
    for (Eigen::Index j = 0; j < last.mode_probabilities.size(); ++j) {
      std::printf(" %.17g", last.mode_probabilities[j]);
    }
    std::printf("\n");
    if (!checkpoint.empty()) skidimm::save_checkpoint(checkpoint, imm.checkpoint());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "online_imm: %s\n", e.what());
    return 1;
  }
}
