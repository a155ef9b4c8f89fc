#include "skidimm/fitting/solver_messages.h"

#include <glog/logging.h>

#include <algorithm>
#include <mutex>
#include <vector>

#include "skidimm/printable.h"

namespace skidimm {
namespace fitting {

namespace {

constexpr std::size_t kKept = 200;   // messages kept between two takes
constexpr std::size_t kShown = 3;    // distinct messages a summary shows

class CapturingSink : public google::LogSink {
 public:
  void send(google::LogSeverity severity, const char* /*full_filename*/, const char* base_filename, int line,
            const google::LogMessageTime& /*time*/, const char* message, std::size_t message_len) override {
    if (severity < google::GLOG_WARNING) return;
    std::lock_guard<std::mutex> lock(mutex_);
    ++count_;
    if (messages_.size() < kKept) {
      messages_.push_back(std::string(base_filename) + ":" + std::to_string(line) + ": " +
                          std::string(message, message_len));
    }
  }

  std::string take(const std::string& indent) {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string out;
    if (count_ == 0) return out;
    std::vector<std::string> distinct;
    for (const std::string& m : messages_) {
      if (std::find(distinct.begin(), distinct.end(), m) == distinct.end()) distinct.push_back(m);
    }
    out = indent + "Ceres reported " + std::to_string(count_) + " warning(s) or error(s)" +
          (distinct.size() > kShown ? ", the first " + std::to_string(kShown) + " distinct:" : ":") + "\n";
    for (std::size_t i = 0; i < distinct.size() && i < kShown; ++i) {
      std::string line = distinct[i].substr(0, 400);
      std::replace(line.begin(), line.end(), '\n', ' ');
      out += indent + "  " + printable(line) + "\n";
    }
    messages_.clear();
    count_ = 0;
    return out;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> messages_;
  long count_ = 0;
};

CapturingSink& sink() {
  static CapturingSink* const instance = new CapturingSink;  // lives as long as glog may call it
  return *instance;
}

}  // namespace

void capture_solver_messages() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (!google::IsGoogleLoggingInitialized()) google::InitGoogleLogging("skidimm");
    // An empty destination turns glog's log files off, severity by severity.
    for (int s = google::GLOG_INFO; s < google::NUM_SEVERITIES; ++s) google::SetLogDestination(s, "");
    FLAGS_logtostderr = false;
    FLAGS_alsologtostderr = false;
    FLAGS_stderrthreshold = google::GLOG_FATAL;
    FLAGS_minloglevel = google::GLOG_WARNING;
    google::AddLogSink(&sink());
  });
}

std::string take_solver_messages(const std::string& indent) { return sink().take(indent); }

}  // namespace fitting
}  // namespace skidimm
