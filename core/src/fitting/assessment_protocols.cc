// Assessment protocols: how the logs are split into held-out sets, for the
// selection's cross-validation and for each protocol's assessment.
#include "assessment_protocols.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "skidimm/errors.h"
#include "skidimm/fitting/tuning.h"

namespace skidimm {
namespace fitting {

std::vector<std::vector<int>> grouped_folds(const std::vector<int>& members, const std::vector<std::string>& classes,
                                         int folds) {
  std::vector<std::vector<int>> out;
  if (folds <= 0 || folds >= static_cast<int>(members.size())) {
    for (int i : members) out.push_back({i});
    return out;
  }
  std::vector<int> order = members;
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return classes[static_cast<std::size_t>(a)] < classes[static_cast<std::size_t>(b)];
  });
  out.resize(static_cast<std::size_t>(folds));
  for (std::size_t k = 0; k < order.size(); ++k) out[k % static_cast<std::size_t>(folds)].push_back(order[k]);
  return out;
}

std::string Protocol::name() const {
  switch (kind) {
    case Kind::kLogs:
      return "logs";
    case Kind::kSessions:
      return "sessions";
    case Kind::kExtrapolation:
      return "extrapolation in " + input;
  }
  return "?";
}

std::string Protocol::slug() const { return kind == Kind::kExtrapolation ? "extrapolation-" + input : name(); }

Protocol protocol_from_string(const std::string& text) {
  Protocol p;
  if (text == "logs") return p;
  if (text == "sessions") {
    p.kind = Protocol::Kind::kSessions;
    return p;
  }
  const std::string prefix = "extrapolation:";
  if (text.compare(0, prefix.size(), prefix) == 0 && text.size() > prefix.size()) {
    p.kind = Protocol::Kind::kExtrapolation;
    std::string rest = text.substr(prefix.size());
    // A fraction after the last ':' (an expression has no ':').
    const std::size_t colon = rest.rfind(':');
    if (colon != std::string::npos) {
      const std::string fraction = rest.substr(colon + 1);
      char* end = nullptr;
      p.fraction = std::strtod(fraction.c_str(), &end);
      if (fraction.empty() || end != fraction.c_str() + fraction.size() || !(p.fraction > 0.0 && p.fraction < 1.0)) {
        throw Error("protocol '" + text + "': expected a fraction in (0, 1) after the last ':', got '" + fraction + "'");
      }
      rest.resize(colon);
    }
    const std::size_t equals = rest.find('=');
    p.input = rest.substr(0, equals);
    if (equals != std::string::npos) p.expression = rest.substr(equals + 1);
    const bool name_ok = !p.input.empty() && std::all_of(p.input.begin(), p.input.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
    });
    if (name_ok && (equals == std::string::npos || !p.expression.empty())) return p;
  }
  throw Error("unknown protocol '" + text + "' (expected logs, sessions, extrapolation:INPUT[:FRACTION] or "
              "extrapolation:NAME=EXPRESSION[:FRACTION], NAME of letters, digits and _)");
}

// The share of a class's largest ranking above which a log counts as driven
// in an extrapolation protocol's input.
constexpr double kDrivenShare = 0.1;

std::vector<std::vector<int>> protocol_folds(const Protocol& protocol, const std::vector<int>& members,
                                             const std::vector<std::string>& classes,
                                             const std::vector<std::string>& sessions,
                                             const std::vector<double>& ranking, int folds) {
  switch (protocol.kind) {
    case Protocol::Kind::kLogs:
      return grouped_folds(members, classes, folds);
    case Protocol::Kind::kSessions: {
      std::map<std::string, std::vector<int>> by_session;
      for (int i : members) {
        const std::string& session = sessions[static_cast<std::size_t>(i)];
        // A log of no session is a session of its own (the \x01 keeps it apart from every name).
        by_session[session.empty() ? "\x01" + std::to_string(i) : session].push_back(i);
      }
      if (by_session.size() < 2) throw Error("protocol 'sessions' needs logs from at least two sessions");
      std::vector<std::vector<int>> out;
      for (auto& [session, held] : by_session) out.push_back(std::move(held));
      return out;
    }
    case Protocol::Kind::kExtrapolation: {
      std::map<std::string, std::vector<int>> by_class;
      for (int i : members) by_class[classes[static_cast<std::size_t>(i)]].push_back(i);
      std::vector<int> held;
      for (auto& [name, logs] : by_class) {
        // Only the logs driven in this way at all compete: a class's runs on
        // the spot are not "slower" runs of its straight driving, and holding
        // them out with it would leave the class no straight run to learn
        // from, a test of another question.
        double largest = 0.0;
        for (int i : logs) largest = std::max(largest, ranking[static_cast<std::size_t>(i)]);
        std::vector<int> driven;
        for (int i : logs) {
          if (largest > 0.0 && ranking[static_cast<std::size_t>(i)] >= kDrivenShare * largest) driven.push_back(i);
        }
        if (driven.size() < 2) continue;  // one such log stays in training
        std::stable_sort(driven.begin(), driven.end(), [&](int a, int b) {
          return ranking[static_cast<std::size_t>(a)] > ranking[static_cast<std::size_t>(b)];
        });
        const std::size_t count =
            std::min(driven.size() - 1,
                     std::max<std::size_t>(1, static_cast<std::size_t>(std::lround(protocol.fraction * driven.size()))));
        held.insert(held.end(), driven.begin(), driven.begin() + static_cast<std::ptrdiff_t>(count));
      }
      if (held.empty()) {
        throw Error("protocol '" + protocol.name() + "' needs a class with at least two logs driven in " + protocol.input);
      }
      std::sort(held.begin(), held.end());
      return {held};
    }
  }
  return {};
}

namespace internal {

std::vector<int> complement(const std::vector<int>& excluded, const std::vector<int>& within) {
  std::vector<int> out;
  for (int i : within) {
    if (std::find(excluded.begin(), excluded.end(), i) == excluded.end()) out.push_back(i);
  }
  return out;
}

}  // namespace internal

}  // namespace fitting
}  // namespace skidimm
