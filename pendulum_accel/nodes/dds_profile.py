"""The package's Fast DDS profile (a 10 ms writer heartbeat), applied to a node's own process.

No ROS import: it only sets an environment variable, which rmw_fastrtps reads when rclpy initialises.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping
from pathlib import Path

PROFILE = Path(__file__).resolve().with_name("fastdds_profile.xml")
PROFILE_VARIABLES = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")


def use_package_profile(environ: MutableMapping[str, str] = os.environ) -> bool:
    """Point Fast DDS at PROFILE unless the RMW is another one or a profile file is already chosen.

    True when it set FASTDDS_DEFAULT_PROFILES_FILE. Call before rclpy.init().
    """
    if environ.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp") != "rmw_fastrtps_cpp":
        return False
    if any(environ.get(name) for name in PROFILE_VARIABLES):
        return False
    environ["FASTDDS_DEFAULT_PROFILES_FILE"] = str(PROFILE)
    return True
