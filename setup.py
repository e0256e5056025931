"""ament_python package setup; also a plain ``pip install .``."""

import os
import re
import subprocess
import sys
from glob import glob
from pathlib import Path

from setuptools import find_packages, setup
from setuptools.command.install import install

PACKAGE = "pendulum_accel"
HERE = Path(__file__).resolve().parent
# One version, kept in package.xml, so colcon and pip agree.
VERSION = re.search(r"<version>([^<]+)</version>", (HERE / "package.xml").read_text()).group(1)


class InstallAndWarm(install):
    """install, then compile the numba kernels into the cache beside the installed modules
    (pendulum_accel.kernel_cache), so that the first run after `colcon build` does not wait a minute or
    two for numba. Skipped when installing into a staging root (a wheel build: its cache would be stale
    where the wheel is unpacked); a failed warm-up only says so (the first run then compiles)."""

    def run(self) -> None:
        super().run()
        if self.root is not None:
            return
        env = {
            **os.environ,
            "PYTHONPATH": os.pathsep.join(filter(None, [self.install_lib, os.environ.get("PYTHONPATH")])),
        }
        # From install_lib: `python -m` imports from its working directory first, and colcon runs setup.py
        # in the source tree, whose modules (and __pycache__) would otherwise be the ones compiled.
        done = subprocess.run(
            [sys.executable, "-m", f"{PACKAGE}.kernel_cache"], env=env, cwd=self.install_lib, check=False
        )
        if done.returncode != 0:
            print(
                f"{PACKAGE}: numba's cache was not warmed (exit {done.returncode}); the first run compiles it"
            )


setup(
    cmdclass={"install": InstallAndWarm},
    name=PACKAGE,
    version=VERSION,
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"]),
    package_data={
        PACKAGE: [
            "scenes/*.yaml",
            "scenes/*.csv",
            # Recorded motion (drive cycles, a robot's odometry) with its provenance and licences.
            "scenes/real_motion/*.csv",
            "scenes/real_motion/*.md",
            "nodes/*.xml",
            "py.typed",
        ]
    },
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/launch_scripts", sorted(glob("launch_scripts/*.py"))),
        # ros2 launch looks in share/<package>/launch (the repo keeps launch files in launch_scripts).
        (f"share/{PACKAGE}/launch", sorted(glob("launch_scripts/*.launch.py"))),
        (f"share/{PACKAGE}/config", sorted(glob("config/*.yaml"))),
        # The default scene's URDF (`pendulum-accel urdf`), for robot_state_publisher and file-based viewers.
        (f"share/{PACKAGE}/urdf", sorted(glob("urdf/*.urdf"))),
        # Foxglove and PlotJuggler layouts for recorded bags.
        (f"share/{PACKAGE}/layouts", sorted(glob("layouts/*.json") + glob("layouts/*.xml"))),
        (
            f"share/{PACKAGE}/scenes",
            sorted(glob(f"{PACKAGE}/scenes/*.yaml") + glob(f"{PACKAGE}/scenes/*.csv")),
        ),
        # The scenes' relative paths (real_motion/udds.csv) resolve in share/ as in the package.
        (
            f"share/{PACKAGE}/scenes/real_motion",
            sorted(glob(f"{PACKAGE}/scenes/real_motion/*.csv") + glob(f"{PACKAGE}/scenes/real_motion/*.md")),
        ),
    ],
    # ROS 2 (rclpy and message packages) is deliberately absent: it comes from
    # a system install or from requirements-ros.txt.
    # Floors are the versions the tests run with (requirements-dev.txt; zstandard and lz4 as installed
    # with them): rosbags for its typestore (message definitions, RIHS01 hashes, CDR), mcap for its
    # record reader; bags are written by pendulum_accel.bag.mcap_file, not by either library.
    install_requires=[
        "numpy>=2.4.6",
        "scipy>=1.17.1",
        "numba>=0.68.1",
        "PyYAML>=6.0.3",
        "rosbags>=0.11.9",
        "mcap>=1.6.0",
        "matplotlib>=3.11.2",
        "tqdm>=4.70.1",
        "zstandard>=0.25.0",
        "lz4>=4.4.5",
    ],
    # The work-precision benchmark's 30-digit reference, and the test tools.
    extras_require={
        "bench": ["mpmath>=1.4.1"],
        # `analyze` over many bags and `design` on Dask distributed; the table as Parquet.
        "fleet": ["dask>=2026.8.0", "distributed>=2026.8.0", "pyarrow>=26.0.1"],
        # The student lab (docs/lab/): Jupyter on top of the ROS-free core; matplotlib is already core.
        "lab": ["jupyterlab>=4.0", "ipykernel>=7.4.0"],
        # `pendulum-accel export`: pandas for the tables, pyarrow for Parquet.
        "export": ["pandas>=3.1.1", "pyarrow>=26.0.1"],
        # The docs site (mkdocs.yml: the material theme, pymdownx extensions); `make docs` installs only
        # these (pinned in requirements-docs.txt) into .venv-docs.
        "docs": ["mkdocs>=1.6.1", "mkdocs-material>=9.8.2", "pymdown-extensions>=13.1.2"],
        "test": [
            "pytest>=9.2.0",
            "pytest-timeout>=2.4.0",
            "hypothesis>=6.170.15",
            "mpmath>=1.4.1",
            # The reference test_allan checks pendulum_accel.allan's ADEV against; not core: it pulls
            # pytest, numpydoc and sphinx (26 distributions, 78 MB).
            "allantools>=2024.6",
            "mcap-ros2-support>=0.6.0",
            "pandas>=3.1.1",
            "pyarrow>=26.0.1",
            "distributed>=2026.8.0",
        ],
    },
    python_requires=">=3.11",
    zip_safe=True,
    maintainer="pendulum_accel developers",
    maintainer_email="dev@pendulum-accel.invalid",
    description="A pendulum accelerometer for ROS 2: simulator, estimator, MCAP recording and replay.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "pendulum-accel = pendulum_accel.cli.main:main",
            "pendulum_sim = pendulum_accel.nodes.node_help:pendulum_sim",
            "accel_estimator = pendulum_accel.nodes.node_help:accel_estimator",
            "bag_recorder = pendulum_accel.nodes.node_help:bag_recorder",
            "bag_player = pendulum_accel.nodes.node_help:bag_player",
        ],
    },
)
