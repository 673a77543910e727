// The nodelet: a shell around RegistrationServer.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

#include "mac_registration/ros/registration_server.hpp"

namespace mac_registration {

class RegistrationNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      server_ = std::make_unique<RegistrationServer>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      // An exception here would take the whole manager down; refuse to start this nodelet only.
      NODELET_FATAL_STREAM("mac_registration not started: " << e.what());
    }
  }

  std::unique_ptr<RegistrationServer> server_;
};

}  // namespace mac_registration

PLUGINLIB_EXPORT_CLASS(mac_registration::RegistrationNodelet, nodelet::Nodelet)
