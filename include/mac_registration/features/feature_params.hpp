#pragma once

// FeatureParams moved to the config module, which reads, checks and documents every parameter; this path
// stays for code that includes it from here.
#include "mac_registration/config/feature_params.hpp"
