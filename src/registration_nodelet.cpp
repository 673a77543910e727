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
      // nodelet::Loader catches what onInit throws and refuses the nodelet: the manager keeps running,
      // its load_nodelet service answers false and `nodelet load` exits non-zero, so roslaunch sees the
      // failure. The loader's own message leaves out the reason, hence this one.
      NODELET_FATAL_STREAM("mac_registration not started: " << e.what());
      throw;
    }
  }

  std::unique_ptr<RegistrationServer> server_;
};

}  // namespace mac_registration

PLUGINLIB_EXPORT_CLASS(mac_registration::RegistrationNodelet, nodelet::Nodelet)
