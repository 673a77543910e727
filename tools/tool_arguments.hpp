#pragma once

// The command line the tools share: positional arguments, --config FILE, --set KEY=VALUE (repeatable),
// --out FILE and -h / --help; a tool's own options go through `own`.

#include <functional>
#include <string>
#include <vector>

namespace mac_registration {

struct ToolArguments {
  std::vector<std::string> positional;
  std::string config, out;
  std::vector<std::string> overrides;
  bool help = false;  // -h or --help was given (nothing after it is read)
};

// `own(option, value)` takes a tool's own option: it returns false for one it does not know, and calls
// `value()` for the option's value (which throws std::invalid_argument when none follows). Throws
// std::invalid_argument for an unknown option or a missing value.
ToolArguments parseToolArguments(
    int argc, char** argv,
    const std::function<bool(const std::string& option, const std::function<std::string()>& value)>& own =
        {});

}  // namespace mac_registration
