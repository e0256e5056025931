"""The lab's teacher material (docs/lab/ is the students'): the class's secret draw, the measurements the
worked solution makes, and the key. Not part of the installed package (setup.py packages only
pendulum_accel), so a student's install holds none of it; ``pendulum-accel lab make-class`` finds it in a
clone of the repository."""
