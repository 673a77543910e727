// The relocalization nodelet: a shell around RelocalizationServer.
#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include <memory>

#include "mac_registration/ros/relocalization_server.hpp"

namespace mac_registration {

class RelocalizationNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      server_ = std::make_unique<RelocalizationServer>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      // As the registration nodelet: the loader refuses it and the manager keeps running.
      NODELET_FATAL_STREAM("mac_relocalization not started: " << e.what());
      throw;
    }
  }

  std::unique_ptr<RelocalizationServer> server_;
};

}  // namespace mac_registration

PLUGINLIB_EXPORT_CLASS(mac_registration::RelocalizationNodelet, nodelet::Nodelet)
