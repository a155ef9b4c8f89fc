// What the parameters an error message names mean, from their models'
// descriptions (sdk::ParameterInfo::description): a fit that refuses
// "[B[8,2], B[8,1]]" says that B[8,2] is the effect of input dv on the ninth
// state, which the flat name alone leaves the user to work out from the
// model's layout. Private to the fitters.
#ifndef SKIDIMM_CORE_SRC_FITTING_PARAMETER_GLOSSARY_H_
#define SKIDIMM_CORE_SRC_FITTING_PARAMETER_GLOSSARY_H_

#include <algorithm>
#include <cctype>
#include <string>
#include <utility>
#include <vector>

namespace skidimm {
namespace fitting {
namespace internal {

// "B[0,2]: d(omega)/dt per unit of input dv; B[0,1]: ...; and 4 more": each
// of `described` (name, description) whose name `text` holds as a whole
// name, in the order `text` first names them, at most `most` of them, those
// with one description named together ("B[1,0], B[1,1]: input matrix..."); ""
// when `text` names none that has a description.
inline std::string parameter_glossary(const std::string& text,
                                      const std::vector<std::pair<std::string, std::string>>& described,
                                      std::size_t most = 6) {
  const auto is_name_char = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_' || c == '.';
  };
  std::vector<std::pair<std::size_t, std::size_t>> found;  // (where text first names it, index in described)
  for (std::size_t i = 0; i < described.size(); ++i) {
    const std::string& name = described[i].first;
    if (name.empty() || described[i].second.empty()) continue;
    for (std::size_t at = text.find(name); at != std::string::npos; at = text.find(name, at + 1)) {
      const bool starts = at == 0 || !is_name_char(text[at - 1]);
      const std::size_t end = at + name.size();
      const bool ends = end == text.size() || !is_name_char(text[end]) || name.back() == ']';
      if (starts && ends) {
        found.emplace_back(at, i);
        break;
      }
    }
  }
  const std::size_t named = found.size();
  std::sort(found.begin(), found.end());
  if (found.size() > most) found.resize(most);
  // Entries of one matrix often share its description: named together.
  std::vector<std::pair<std::string, std::string>> groups;  // (names, description)
  for (const auto& entry : found) {
    const std::pair<std::string, std::string>& parameter = described[entry.second];
    auto group = std::find_if(groups.begin(), groups.end(),
                              [&parameter](const auto& g) { return g.second == parameter.second; });
    if (group == groups.end()) {
      groups.push_back(parameter);
    } else {
      group->first += ", " + parameter.first;
    }
  }
  std::string out;
  for (const auto& [names, description] : groups) out += (out.empty() ? "" : "; ") + names + ": " + description;
  if (named > most) out += "; and " + std::to_string(named - most) + " more";
  return out;
}

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_PARAMETER_GLOSSARY_H_
