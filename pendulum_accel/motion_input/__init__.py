"""Motion input: a(t) from what users bring, a scene's profile mapping, a speed trace, an acceleration
log or a bag topic, as the ``physics.profiles`` types the simulator integrates.

Modules, each importing only those listed before it (test/test_architecture.py checks there is no
circle):

- ``columns``: the time and value columns of a user's CSV file (seconds or date-times);
- ``fields``: a profile mapping's fields, each checked (one ParameterError naming the field);
- ``trace``: a sampled trace's checks, its window (cut before the gap check), and the stated
  smoothing-spline differentiation;
- ``speed_trace``: ``speed_table`` and ``speed_csv`` (speeds in m/s, km/h, mph → a = s'(t));
- ``accel_log``: ``accel_csv`` and ``csv`` (a logged acceleration, used as recorded);
- ``bag_topic``: ``bag_topic`` (odometry, twist, Imu or accel messages of a recorded bag);
- ``registry``: every profile type, its fields, and ``profile_from_dict``.

No ROS imports: bags are read with rosbags (pure Python).
"""

from pendulum_accel.motion_input.registry import (
    PROFILE_CLASSES,
    PROFILE_FIELDS,
    PROFILE_TYPES,
    profile_from_dict,
)

__all__ = ["PROFILE_CLASSES", "PROFILE_FIELDS", "PROFILE_TYPES", "profile_from_dict"]
