// Fuzzes the merge of a log's files (log_reader.h): up to three CSV files
// read together, by time (each with an offset) or row for row, at every time
// stamp or on a fixed-rate grid, with held inputs and aggregated
// measurements, as `skidimm run --input a.csv+b.csv@OFFSET` reads them.
//
// Input: one byte of settings, one byte per extra file choosing its offset,
// then the files' texts separated by a form feed ('\f'):
//   settings bits 0-1  rate: none, 7.5 Hz, 100 Hz, 1e6 Hz
//                 bit 2    sampling.skip_gaps
//                 bit 3    sampling.join: rows (else time)
//                 bits 4-5 max_gap: 10 s, 0.05 s, 1e9 s, 1 s
//                 bit 6    aggregated measurements (mean, std, rms, diff_std; with a rate)
//                 bit 7    sampling.skip_out_of_order
//
// The bank reads columns t, velL, velR (inputs), wz and cur (measurements);
// a file may have any of them. Bad input must end in a skidimm::Error. What
// the reader gives must hold: steps in strictly increasing finite time,
// finite inputs, at most LogReader::kMaxStepsPerRow grid steps per row read,
// finite or missing (NaN) measurements. Any other exception, a crash, a hang
// or a sanitizer report is a finding.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fuzz_input_file.h"
#include "skidimm/config/bank.h"
#include "skidimm/errors.h"
#include "skidimm/io/log_reader.h"

namespace {

[[noreturn]] void finding(const char* what, double value) {
  std::fprintf(stderr, "multirate_merge_fuzzer: %s (%g)\n", what, value);
  std::abort();
}

skidimm::BankConfig bank(bool aggregated) {
  skidimm::BankConfig c;
  c.file = "fuzz_bank.yaml";
  c.state_names = {"omega", "current"};
  c.input_names = {"dv", "speed"};
  c.measurement.names = {"omega", "current", "vibration"};
  c.columns.time = "t";
  c.columns.inputs = {"velR - velL", "abs(velL + velR) / 2"};
  c.columns.measurements = aggregated ? std::vector<std::string>{"mean(wz)", "rms(cur)", "log(std(wz)) - diff_std(wz)"}
                                      : std::vector<std::string>{"wz", "cur", "log(abs(wz))"};
  return c;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::vector<std::filesystem::path> paths = {
      skidimm_fuzz::input_file(".a.csv"), skidimm_fuzz::input_file(".b.csv"), skidimm_fuzz::input_file(".c.csv")};
  static const double kRates[] = {0.0, 7.5, 100.0, 1e6};
  static const double kGaps[] = {10.0, 0.05, 1e9, 1.0};
  static const double kOffsets[] = {0.0, 0.005, -0.5, 1e6, -1e6, 1e300, 0.1, 3.0};
  if (size < 3) return 0;
  const std::uint8_t settings = data[0];
  skidimm::SamplingConfig sampling;
  sampling.rate = kRates[settings & 3];
  sampling.skip_gaps = (settings & 4) != 0;
  sampling.skip_out_of_order = (settings & 128) != 0;
  sampling.join = (settings & 8) != 0 ? skidimm::SamplingConfig::Join::kRows : skidimm::SamplingConfig::Join::kTime;
  sampling.max_gap = kGaps[(settings >> 4) & 3];
  const bool aggregated = (settings & 64) != 0 && sampling.rate > 0.0;

  const std::string text(reinterpret_cast<const char*>(data + 3), size - 3);
  std::vector<skidimm::LogFile> files;
  std::size_t begin = 0;
  while (files.size() < paths.size()) {
    std::size_t end = text.find('\f', begin);
    if (end == std::string::npos) end = text.size();
    const std::string file = text.substr(begin, end - begin);
    skidimm_fuzz::write_input(paths[files.size()], reinterpret_cast<const std::uint8_t*>(file.data()), file.size());
    const double offset = files.empty() ? 0.0 : kOffsets[data[files.size()] & 7];
    files.emplace_back(paths[files.size()], offset);
    if (end == text.size()) break;
    begin = end + 1;
  }

  const skidimm::BankConfig config = bank(aggregated);
  long steps = 0;
  try {
    skidimm::LogReader reader(config, files, sampling);
    skidimm::LogSample sample;
    double last_t = -INFINITY;
    while (reader.next(&sample)) {
      ++steps;
      if (!std::isfinite(sample.t) || !(sample.t > last_t)) finding("step time not finite or not increasing", sample.t);
      last_t = sample.t;
      for (Eigen::Index i = 0; i < sample.u.size(); ++i) {
        if (!std::isfinite(sample.u[i])) finding("input not finite", sample.u[i]);
      }
      for (Eigen::Index i = 0; i < sample.z.size(); ++i) {
        if (std::isinf(sample.z[i])) finding("measurement infinite", sample.z[i]);
      }
      long rows = 0;
      for (long r : reader.stats().rows) rows += r;
      // The rows applied, and the one the reader may have read ahead.
      if (sampling.rate > 0.0 && steps > skidimm::LogReader::kMaxStepsPerRow * (rows + 1) + 1) {
        finding("grid steps beyond the bound per row", static_cast<double>(steps));
      }
    }
    (void)reader.describe_stats(config);
  } catch (const skidimm::Error&) {
  }
  return 0;
}
