#include "mac_registration/ros/reconfigure_mapping.hpp"

#include <dynamic_reconfigure/Config.h>

#include <stdexcept>

namespace mac_registration {

std::string reconfigureKey(const std::string& field) {
  for (const auto& p : parameterTable()) {
    std::string name = p.key;
    for (char& c : name) c = c == '.' ? '_' : c;
    if (name == field) return p.key;
  }
  return "";
}

std::vector<std::string> reconfigurableKeys() {
  std::vector<std::string> keys;
  for (const auto& description : MacRegistrationConfig::__getParamDescriptions__())
    keys.push_back(reconfigureKey(description->name));
  return keys;
}

namespace {

// The generated config converts to and from a message of named values: the one generic view of its fields.
dynamic_reconfigure::Config toMessage(const MacRegistrationConfig& fields) {
  dynamic_reconfigure::Config message;
  fields.__toMessage__(message);
  return message;
}

std::string keyOf(const std::string& field) {
  std::string key = reconfigureKey(field);
  if (key.empty()) throw std::logic_error("cfg/MacRegistration.cfg field '" + field + "' names no parameter");
  return key;
}

}  // namespace

void toReconfigure(const RegistrationConfig& config, MacRegistrationConfig& fields) {
  dynamic_reconfigure::Config message = toMessage(fields);
  for (auto& d : message.doubles) d.value = std::get<double>(findParameter(keyOf(d.name))->get(config));
  for (auto& i : message.ints) {
    i.value = static_cast<int>(std::get<long long>(findParameter(keyOf(i.name))->get(config)));
  }
  for (auto& b : message.bools) b.value = std::get<bool>(findParameter(keyOf(b.name))->get(config));
  for (auto& s : message.strs) s.value = std::get<std::string>(findParameter(keyOf(s.name))->get(config));
  fields.__fromMessage__(message);
}

void fromReconfigure(const MacRegistrationConfig& fields, RegistrationConfig& config) {
  const dynamic_reconfigure::Config message = toMessage(fields);
  for (const auto& d : message.doubles) setParameter(config, keyOf(d.name), ParameterValue(d.value));
  for (const auto& i : message.ints)
    setParameter(config, keyOf(i.name), ParameterValue(static_cast<long long>(i.value)));
  for (const auto& b : message.bools)
    setParameter(config, keyOf(b.name), ParameterValue(static_cast<bool>(b.value)));
  for (const auto& s : message.strs) setParameter(config, keyOf(s.name), ParameterValue(s.value));
}

}  // namespace mac_registration
