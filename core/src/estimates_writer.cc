#include "skidimm/estimates_writer.h"

namespace skidimm {

std::vector<std::string> EstimatesWriter::header(const BankConfig& config, bool with_truth) {
  std::vector<std::string> header{"t"};
  for (const ModeConfig& mode : config.modes) header.push_back("mu_" + mode.name);
  for (const std::string& s : config.state_names) header.push_back(s);
  for (const std::string& s : config.state_names) header.push_back("var_" + s);
  header.push_back("mode");
  header.push_back("decision");
  if (with_truth) header.push_back("truth_mode");
  header.push_back("status");
  return header;
}

EstimatesWriter::EstimatesWriter(const std::filesystem::path& path, const BankConfig& config, bool with_truth)
    : writer_(path, header(config, with_truth)), with_truth_(with_truth) {
  for (const ModeConfig& mode : config.modes) mode_names_.push_back(mode.name);
  cells_.resize(header(config, with_truth).size());
}

void EstimatesWriter::write(double t, const ImmEstimate& e, const std::string& decision, const std::string& truth) {
  std::size_t c = 0;
  cells_[c++] = CsvWriter::format(t);
  for (Eigen::Index j = 0; j < e.mode_probabilities.size(); ++j) cells_[c++] = CsvWriter::format(e.mode_probabilities[j]);
  for (Eigen::Index i = 0; i < e.state.size(); ++i) cells_[c++] = CsvWriter::format(e.state[i]);
  for (Eigen::Index i = 0; i < e.state.size(); ++i) cells_[c++] = CsvWriter::format(e.covariance(i, i));
  cells_[c++] = mode_names_[static_cast<std::size_t>(e.most_likely_mode)];
  cells_[c++] = decision;
  if (with_truth_) cells_[c++] = truth;
  cells_[c++] = to_string(e.status);
  writer_.write_row(cells_);
}

}  // namespace skidimm
