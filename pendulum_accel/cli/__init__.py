"""The ``pendulum-accel`` command line: one module per subcommand."""
