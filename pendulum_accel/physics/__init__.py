"""Car-frame pendulum physics: parameters, acceleration profiles, models, integrators.

No ROS imports: everything here runs with numpy and scipy alone.
"""
