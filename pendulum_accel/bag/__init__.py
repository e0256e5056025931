"""rosbag2 MCAP bags of the chain, without ROS: bulk CDR (messages), crash-safe writing (writer),
salvaging bulk reading (reader), repair, offline analysis, generation from scenes, golden bags."""
