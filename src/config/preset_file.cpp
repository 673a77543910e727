#include "mac_registration/config/preset_file.hpp"

#include <fstream>
#include <set>
#include <stdexcept>

namespace mac_registration {
namespace {

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\"'");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\"'");
  return text.substr(first, last - first + 1);
}

// "graph" for "graph.t_cmp", "" for a top-level key.
std::string sectionOf(const std::string& key) {
  const auto dot = key.find('.');
  return dot == std::string::npos ? "" : key.substr(0, dot);
}

bool isTableSection(const std::string& section) {
  static const std::set<std::string> sections = [] {
    std::set<std::string> names;
    for (const auto& p : parameterTable()) names.insert(sectionOf(p.key));
    return names;
  }();
  return sections.count(section) > 0;
}

}  // namespace

void readPresetFile(const std::string& path,
                    const std::function<void(const std::string& key, const std::string& value)>& visit) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open config '" + path + "'");
  std::string line, section;
  for (int number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    if (trim(line).empty()) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos)
      throw std::runtime_error(path + ":" + std::to_string(number) + ": expected 'key: value'");
    const bool indented = line[0] == ' ' || line[0] == '\t';
    const std::string key = trim(line.substr(0, colon)), value = trim(line.substr(colon + 1));
    if (!indented) {
      if (value.empty()) {
        section = key;
        continue;
      }
      section.clear();
    }
    try {
      visit(section.empty() ? key : section + "." + key, value);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(path + ":" + std::to_string(number) + ": " + e.what());
    }
  }
}

void loadPresetFile(RegistrationConfig& config, const std::string& path,
                    const std::function<void(const std::string& key, const std::string& value)>& other) {
  readPresetFile(path, [&](const std::string& key, const std::string& value) {
    if (isTableSection(sectionOf(key)))
      setParameter(config, key, value);
    else if (other)
      other(key, value);
  });
}

}  // namespace mac_registration
