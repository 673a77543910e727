#include "tool_arguments.hpp"

#include <stdexcept>

namespace mac_registration {

ToolArguments parseToolArguments(
    int argc, char** argv,
    const std::function<bool(const std::string& option, const std::function<std::string()>& value)>& own) {
  ToolArguments arguments;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const std::function<std::string()> value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--config")
      arguments.config = value();
    else if (arg == "--out")
      arguments.out = value();
    else if (arg == "--set")
      arguments.overrides.push_back(value());
    else if (arg == "-h" || arg == "--help") {
      arguments.help = true;
      return arguments;
    } else if (!arg.empty() && arg[0] == '-') {
      if (!own || !own(arg, value)) throw std::invalid_argument("unknown option '" + arg + "'");
    } else {
      arguments.positional.push_back(arg);
    }
  }
  return arguments;
}

}  // namespace mac_registration
