"""rosbag2 MCAP bags without ROS, reusable by any rosbag2 user: bulk CDR (messages), crash-safe writing
(writer), salvaging bulk reading (reader), repair. Imports nothing of the pendulum domain; bags made from
scenes live in ``pendulum_accel.recording``."""
