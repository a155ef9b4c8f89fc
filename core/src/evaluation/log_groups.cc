#include "skidimm/evaluation/log_groups.h"

#include <exception>
#include <functional>

#include "estimates_reader.h"
#include "parallel.h"
#include "skidimm/io/log_arguments.h"

namespace skidimm {
namespace evaluation {

namespace {

// One log to evaluate, in the order one thread would: the group it belongs
// to, or the error expanding its argument gave (which one thread would have
// met after evaluating every log before it).
struct LogJob {
  std::size_t group = 0;
  LogSpec log;
  std::exception_ptr error;
};

std::vector<LogJob> log_jobs(const std::vector<std::string>& arguments, const LogArgumentOptions& expansion,
                             std::vector<LogGroup>* groups) {
  std::vector<LogJob> jobs;
  for (const std::string& argument : arguments) {
    try {
      LogGroup g{log_group_name(argument), {}};
      const std::vector<LogSpec> logs = expand_log_argument(argument, expansion);
      groups->push_back(std::move(g));
      for (const LogSpec& log : logs) jobs.push_back(LogJob{groups->size() - 1, log, nullptr});
    } catch (...) {
      jobs.push_back(LogJob{0, LogSpec{}, std::current_exception()});
      break;
    }
  }
  return jobs;
}

std::vector<LogGroup> evaluate_groups(const std::vector<std::string>& arguments, const LogArgumentOptions& expansion,
                                      const std::function<LogResult(const LogSpec&)>& evaluate) {
  std::vector<LogGroup> groups;
  const std::vector<LogJob> jobs = log_jobs(arguments, expansion, &groups);
  std::vector<LogResult> results(jobs.size());
  parallel_for(static_cast<int>(jobs.size()), worker_count(), [&](int i, int) {
    const LogJob& job = jobs[static_cast<std::size_t>(i)];
    if (job.error) std::rethrow_exception(job.error);
    results[static_cast<std::size_t>(i)] = evaluate(job.log);
  });
  for (std::size_t i = 0; i < jobs.size(); ++i) groups[jobs[i].group].logs.push_back(std::move(results[i]));
  return groups;
}

}  // namespace

std::vector<LogGroup> evaluate_log_groups(const Bank& bank, const std::vector<std::string>& arguments,
                                          const SamplingConfig& sampling, const EstimatorOptions& estimator,
                                          const LogArgumentOptions& expansion) {
  return evaluate_groups(arguments, expansion,
                         [&](const LogSpec& log) { return evaluate_log(bank, log, sampling, {}, estimator); });
}

std::vector<LogGroup> evaluate_estimate_groups(const std::vector<std::string>& arguments, const BankConfig* bank,
                                               const DecisionConfig* decide, const LogArgumentOptions& expansion) {
  return evaluate_groups(arguments, expansion, [&](const LogSpec& log) {
    return evaluate_estimates(log.files.front().path, bank, decide);
  });
}

}  // namespace evaluation
}  // namespace skidimm
