"""Recordings of the chain, above ``scene_run``: bags generated from scenes (generate), offline analysis
(analyze), the golden bags (golden) and the Scene → estimator settings mapping (settings). Writes and
reads through ``pendulum_accel.bag``, which knows nothing of scenes."""
