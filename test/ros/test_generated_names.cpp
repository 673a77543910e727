// The library's names beside those generated from its ROS interface. The message, service and
// dynamic_reconfigure types (RegistrationResult, Register, MacRegistrationConfig, ...) are generated into
// namespace mac_registration, the library's own, so a library name that is also a generated one would be a
// redefinition wherever the two headers meet, in a user's code first. This translation unit includes every
// installed header with every generated one (every_header.hpp, written by test/CMakeLists.txt from include/,
// msg/, srv/ and cfg/): such a name fails the build here. The rule it checks is in README.md, "Layout".
#include "every_header.hpp"

#include <gtest/gtest.h>
#include <ros/message_traits.h>
#include <ros/service_traits.h>

#include <type_traits>

namespace {

TEST(GeneratedNames, AreTheInterfaceTypes) {
  EXPECT_TRUE(ros::message_traits::IsMessage<mac_registration::RegistrationResult>::value);
  EXPECT_TRUE(ros::message_traits::IsMessage<mac_registration::CompetingPose>::value);
  EXPECT_TRUE(ros::message_traits::IsMessage<mac_registration::Correspondences>::value);
  EXPECT_TRUE((std::is_same<mac_registration::Register::Request, mac_registration::RegisterRequest>::value));
  EXPECT_TRUE((std::is_same<mac_registration::RegisterCorrespondences::Response,
                            mac_registration::RegisterCorrespondencesResponse>::value));
  EXPECT_STREQ(ros::service_traits::datatype<mac_registration::Register>(), "mac_registration/Register");
}

}  // namespace
