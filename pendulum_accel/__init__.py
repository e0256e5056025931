"""pendulum_accel: a pendulum accelerometer in a car, simulated, estimated, recorded and replayed.

Conventions (REP-103 car frame, SI): x forward, y left, z up. θ is the bob's rotation
about +y, zero hanging straight down; positive θ swings the bob to the rear.
θ'' = -(g/l) sin θ + (a/l) cos θ, so steady forward acceleration a > 0 gives a = g tan θ.
"""

__version__ = "0.1.0"
