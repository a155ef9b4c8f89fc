#include "skidimm/evaluation/log_groups.h"

#include <algorithm>
#include <exception>
#include <functional>
#include <map>

#include "check.h"
#include "estimates_reader.h"
#include "parallel.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/spliced_replay.h"

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
  std::vector<LogSpec> given;  // each group's argument, parsed
  for (const std::string& argument : arguments) {
    try {
      const std::string name = log_group_name(argument);
      const std::vector<LogSpec> logs = expand_log_argument(argument, expansion);
      given.push_back(parse_log_spec(argument));
      groups->push_back(LogGroup{name, {}});
      for (const LogSpec& log : logs) jobs.push_back(LogJob{groups->size() - 1, log, nullptr});
    } catch (...) {
      jobs.push_back(LogJob{0, LogSpec{}, std::current_exception()});
      break;
    }
  }
  // The tables and --json name groups: unlabelled arguments whose names
  // would be the same ('ICE/*.csv' and 'SNOW/*.csv' are both '*') are named
  // by the folders that tell them apart; arguments still of one name (one
  // label given twice, one argument twice) are one group.
  std::vector<std::string> names;
  for (const LogGroup& g : *groups) names.push_back(g.name);
  names = distinct_group_names(given, std::move(names));
  for (std::size_t g = 0; g < names.size(); ++g) (*groups)[g].name = names[g];
  std::vector<std::size_t> merged(groups->size());
  std::vector<LogGroup> kept;
  for (std::size_t g = 0; g < groups->size(); ++g) {
    const auto same =
        std::find_if(kept.begin(), kept.end(), [&](const LogGroup& k) { return k.name == (*groups)[g].name; });
    merged[g] = static_cast<std::size_t>(same - kept.begin());
    if (same == kept.end()) kept.push_back(std::move((*groups)[g]));
  }
  for (LogJob& job : jobs) {
    if (!job.error) job.group = merged[job.group];
  }
  *groups = std::move(kept);
  return jobs;
}

// A failing log's error, naming one of its files: as it is when it does,
// else after the log's paths.
std::string failure_message(const LogSpec& log, const std::string& error) {
  for (const LogFile& f : log.files) {
    if (error.find(f.path.string()) != std::string::npos) return error;
  }
  return joined_paths(log.files) + ": " + error;
}

// The logs of `arguments` in their groups, each log scored `scorings` ways
// by `evaluate` (a result per way, in order): the groups once per way.
std::vector<std::vector<LogGroup>> evaluate_groups(
    const std::vector<std::string>& arguments, const LogArgumentOptions& expansion, std::size_t scorings,
    const std::function<std::vector<LogResult>(const LogSpec&)>& evaluate, std::vector<LogFailure>* failures) {
  std::vector<LogGroup> groups;
  const std::vector<LogJob> jobs = log_jobs(arguments, expansion, &groups);
  if (failures != nullptr) {
    // A bad argument costs nothing to find: before any log is scored.
    for (const LogJob& job : jobs) {
      if (job.error) std::rethrow_exception(job.error);
    }
  }
  std::vector<std::vector<LogResult>> results(jobs.size());
  std::vector<std::string> errors(jobs.size());
  std::vector<char> failed(jobs.size(), 0);
  parallel_for(static_cast<int>(jobs.size()), worker_count(), [&](int i, int) {
    const LogJob& job = jobs[static_cast<std::size_t>(i)];
    if (job.error) std::rethrow_exception(job.error);
    if (failures == nullptr) {
      results[static_cast<std::size_t>(i)] = evaluate(job.log);
      return;
    }
    try {
      results[static_cast<std::size_t>(i)] = evaluate(job.log);
    } catch (const std::exception& e) {
      failed[static_cast<std::size_t>(i)] = 1;
      errors[static_cast<std::size_t>(i)] = failure_message(job.log, e.what());
    }
  });
  std::vector<const LogSpec*> specs;
  for (const LogJob& job : jobs) specs.push_back(&job.log);
  const std::vector<std::string> names = distinct_names(specs);
  std::vector<std::vector<LogGroup>> scored(scorings, groups);
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    if (failed[i]) {
      failures->push_back(LogFailure{groups[jobs[i].group].name, joined_paths(jobs[i].log.files), errors[i]});
      continue;
    }
    SKIDIMM_CHECK(results[i].size() == scorings, "a log was not scored every way asked");
    for (std::size_t k = 0; k < scorings; ++k) {
      results[i][k].name = names[i];
      scored[k][jobs[i].group].logs.push_back(std::move(results[i][k]));
    }
  }
  if (failures == nullptr) return scored;
  for (std::vector<LogGroup>& way : scored) {
    way.erase(std::remove_if(way.begin(), way.end(), [](const LogGroup& g) { return g.logs.empty(); }), way.end());
  }
  return scored;
}

}  // namespace

std::vector<LogGroup> evaluate_log_groups(const Bank& bank, const std::vector<std::string>& arguments,
                                          const SamplingConfig& sampling, const EstimatorOptions& estimator,
                                          const LogArgumentOptions& expansion, std::vector<LogFailure>* failures) {
  return evaluate_groups(
             arguments, expansion, 1,
             [&](const LogSpec& log) {
               std::vector<LogResult> one;
               one.push_back(evaluate_log(bank, log, sampling, {}, estimator));
               return one;
             },
             failures)
      .front();
}

std::vector<LogGroup> evaluate_spliced_logs(const Bank& bank, const std::vector<std::string>& arguments,
                                            const SamplingConfig& sampling, const LogArgumentOptions& expansion,
                                            std::vector<LogFailure>* failures, std::size_t* spliced) {
  std::vector<LogGroup> names;
  const std::vector<LogJob> jobs = log_jobs(arguments, expansion, &names);
  std::vector<SplicedGroup> groups;
  for (const LogGroup& g : names) groups.push_back(SplicedGroup{g.name, {}});
  for (const LogJob& job : jobs) {
    if (job.error) std::rethrow_exception(job.error);
    groups[job.group].logs.push_back(job.log);
  }
  return evaluate_spliced_groups(bank, groups, sampling, failures, spliced);
}

std::vector<LogGroup> evaluate_spliced_groups(const Bank& bank, const std::vector<SplicedGroup>& groups,
                                              const SamplingConfig& sampling, std::vector<LogFailure>* failures,
                                              std::size_t* spliced) {
  // The groups take turns, in the order given.
  std::vector<std::vector<std::pair<std::size_t, const LogSpec*>>> by_group(groups.size());  // group, log
  for (std::size_t g = 0; g < groups.size(); ++g) {
    for (const LogSpec& log : groups[g].logs) by_group[g].emplace_back(g, &log);
  }
  const std::vector<std::pair<std::size_t, const LogSpec*>> order = taking_turns(by_group);
  // Each log read into memory once, on every core; one that fails is left
  // out of the splice (or, without `failures`, ends the evaluation).
  std::vector<RecordedLog> recorded(order.size());
  std::vector<LogResult> said(order.size());  // what the reader said of each log
  std::vector<std::string> errors(order.size());
  parallel_for(static_cast<int>(order.size()), worker_count(), [&](int i, int) {
    const LogSpec& log = *order[static_cast<std::size_t>(i)].second;
    try {
      recorded[static_cast<std::size_t>(i)] =
          record_labelled_log(bank.config, log, sampling, &said[static_cast<std::size_t>(i)]);
    } catch (const std::exception& e) {
      if (failures == nullptr) throw;
      errors[static_cast<std::size_t>(i)] = failure_message(log, e.what());
    }
  });
  std::vector<const RecordedLog*> logs;
  std::vector<std::string> labels, sources, unmeasured_in_logs, skipped_in_logs;
  std::vector<const LogSpec*> specs;
  std::vector<long> steps;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const LogSpec& log = *order[k].second;
    if (!errors[k].empty()) {
      failures->push_back(LogFailure{groups[order[k].first].name, joined_paths(log.files), errors[k]});
      continue;
    }
    logs.push_back(&recorded[k]);
    labels.push_back(log.label);
    specs.push_back(&log);
    sources.push_back(joined_paths(log.files));
    for (const std::string& line : said[k].unmeasured) unmeasured_in_logs.push_back(sources.back() + ": " + line);
    for (const std::string& line : said[k].skipped) skipped_in_logs.push_back(sources.back() + ": " + line);
    steps.push_back(static_cast<long>(recorded[k].samples().size()));
  }
  if (spliced != nullptr) *spliced = logs.size();
  if (logs.empty()) return {};
  SplicedReplay source(logs, labels, sampling.rate > 0.0 ? 1.0 / sampling.rate : 0.0);
  LogResult whole;
  evaluate_spliced(bank, &source, distinct_names(specs), steps, &whole);
  whole.name = "spliced";
  // Each line names its log: the whole run's source is every log's.
  whole.unmeasured = std::move(unmeasured_in_logs);
  whole.skipped = std::move(skipped_in_logs);
  for (std::size_t k = 0; k < sources.size(); ++k) whole.source += (k ? ", " : "") + sources[k];
  return {LogGroup{"spliced (" + std::to_string(logs.size()) + " logs end to end, the groups taking turns)", {whole}}};
}

std::vector<LogGroup> evaluate_estimate_groups(const std::vector<std::string>& arguments, const BankConfig* bank,
                                               const DecisionConfig* decide, const LogArgumentOptions& expansion,
                                               std::vector<LogFailure>* failures) {
  return evaluate_estimate_groups(
             arguments, bank, decide != nullptr ? std::vector<DecisionConfig>{*decide} : std::vector<DecisionConfig>{},
             expansion, failures)
      .front();
}

std::vector<std::vector<LogGroup>> evaluate_estimate_groups(const std::vector<std::string>& arguments,
                                                            const BankConfig* bank,
                                                            const std::vector<DecisionConfig>& decisions,
                                                            const LogArgumentOptions& expansion,
                                                            std::vector<LogFailure>* failures) {
  return evaluate_groups(
      arguments, expansion, std::max<std::size_t>(decisions.size(), 1),
      [&](const LogSpec& log) { return evaluate_estimates(log.files.front().path, bank, decisions, log.label); },
      failures);
}

}  // namespace evaluation
}  // namespace skidimm
