"""MAC (maximal cliques) point cloud registration from Python: numpy in, numpy out.

    import mac_registration as mr
    result = mr.register_clouds(source_points, target_points)          # (N, 3) and (M, 3) arrays [m]
    result = mr.register_correspondences(src, tgt, mr.Config("config/outdoor_lidar.yaml", graph_t_cmp=0.95))
    if result.success:
        T = result.T_target_source                                      # 4 x 4, maps source into target

The calls run the package's C++ (the core, the parameter table and the PCL front end; the extension
module ``mac_registration._mac``) with the GIL released, and give what ``mac_register`` gives for the
same input and configuration. README.md, "Python", has the whole contract.

In a catkin workspace this is also the package of the ROS messages: ``from mac_registration.msg import
RegistrationResult`` works beside it, and keeps working in a build without the extension module.
"""
from ._api import *  # noqa: F401,F403
from ._api import _EXTENSION_NAMES, __all__, _mac, _require_module  # noqa: F401


def __getattr__(name):
    # A build without the extension module: its names say why they are missing.
    if name in _EXTENSION_NAMES:
        _require_module()
    raise AttributeError(f"module 'mac_registration' has no attribute '{name}'")


__version__ = "0.1.0"
