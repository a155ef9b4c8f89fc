// A robot-loop style use of skidimm: load a bank once, then call step() with
// each new sample and act on the most likely mode. Here the samples come from
// a log; on a robot they come from its drivers, at whatever rate they arrive.
//
//   online_imm <bank.yaml> <log.csv>
#include <cstdio>
#include <exception>

#include "skidimm/engine/imm.h"
#include "skidimm/io/csv.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <bank.yaml> <log.csv>\n", argv[0]);
    return 2;
  }
  try {
    // The bundled plugins' directory comes from find_package(skidimm); banks
    // may add their own with plugin_paths, users with SKIDIMM_PLUGIN_PATH.
    skidimm::Imm imm = skidimm::Imm::from_yaml(argv[1], {SKIDIMM_PLUGIN_DIR});
    skidimm::LogReader log(imm.config(), {argv[2]});
    skidimm::LogSample sample;
    int last_mode = -1;
    long steps = 0;
    while (log.next(&sample)) {
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
    std::printf("%ld steps\n", steps);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "online_imm: %s\n", e.what());
    return 1;
  }
}
