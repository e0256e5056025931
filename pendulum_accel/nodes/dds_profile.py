"""The package's Fast DDS profiles, applied to a node's own process: loopback only unless asked otherwise.

No ROS import: it only sets environment variables, which rmw_fastrtps reads when rclpy initialises.

* Default (discovery range unset or LOCALHOST): LOOPBACK_PROFILE, whose transports are the loopback
  interface and shared memory only, so nothing listens on another address. The range the rmw sees is
  then SUBNET: with LOCALHOST, rmw_fastrtps adds its own peers and bound a sender on the machine's
  address; with SUBNET, discovery is multicast on the loopback interface, and still reaches nodes
  started with LOCALHOST on this machine (they announce to the loopback unicast ports).
* Network (PENDULUM_ACCEL_NETWORK=1, ``pendulum-accel run --network``, or a discovery range of SUBNET
  or OFF chosen by the user): PROFILE, all interfaces, for multi-host use.

Both carry the 10 ms heartbeat for reliable writers. A profile file already chosen by the user, or
another RMW, is left alone.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping
from pathlib import Path

PROFILE = Path(__file__).resolve().with_name("fastdds_profile.xml")
LOOPBACK_PROFILE = Path(__file__).resolve().with_name("fastdds_profile_loopback.xml")
PROFILE_VARIABLES = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
NETWORK_ENV = "PENDULUM_ACCEL_NETWORK"
RANGE_ENV = "ROS_AUTOMATIC_DISCOVERY_RANGE"


def network_requested(environ: MutableMapping[str, str] = os.environ) -> bool:
    """True when PENDULUM_ACCEL_NETWORK is set to anything but '', '0', 'false' or 'no'."""
    return environ.get(NETWORK_ENV, "").strip().lower() not in ("", "0", "false", "no")


def use_package_profile(environ: MutableMapping[str, str] = os.environ) -> bool:
    """Point Fast DDS at LOOPBACK_PROFILE (default) or PROFILE (network), see the module docstring.

    True when it set FASTDDS_DEFAULT_PROFILES_FILE. Call before rclpy.init().
    """
    if environ.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp") != "rmw_fastrtps_cpp":
        return False
    if any(environ.get(name) for name in PROFILE_VARIABLES):
        return False
    requested = environ.get(RANGE_ENV, "").strip().upper()
    if network_requested(environ) or requested not in ("", "LOCALHOST"):
        environ["FASTDDS_DEFAULT_PROFILES_FILE"] = str(PROFILE)
        return True
    environ["FASTDDS_DEFAULT_PROFILES_FILE"] = str(LOOPBACK_PROFILE)
    environ[RANGE_ENV] = "SUBNET"
    return True
