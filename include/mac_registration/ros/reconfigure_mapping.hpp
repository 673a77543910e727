#pragma once

#include <mac_registration/MacRegistrationConfig.h>

#include <string>
#include <vector>

#include "mac_registration/config/parameter_table.hpp"

namespace mac_registration {

// dynamic_reconfigure through the parameter table: each field of cfg/MacRegistration.cfg is the table key
// with its dots written as underscores (graph_t_cmp for graph.t_cmp), so no field is mapped by hand and a
// new reconfigurable parameter is one line of the .cfg.

// The table key of a .cfg field, or "" when it has none.
std::string reconfigureKey(const std::string& field);

// The table keys of every .cfg field, in the .cfg's order.
std::vector<std::string> reconfigurableKeys();

// Writes the reconfigurable values of `config` into `fields`.
void toReconfigure(const RegistrationConfig& config, MacRegistrationConfig& fields);

// Sets the reconfigurable values of `fields` in `config` (ranges are left to validateConfig()).
void fromReconfigure(const MacRegistrationConfig& fields, RegistrationConfig& config);

}  // namespace mac_registration
