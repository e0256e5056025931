"""What RViz and Foxglove's 3D panel draw: the pendulum's URDF and its MarkerArray rows (no ROS).

Frames follow REP-103 in ``base_link`` (x forward, y left, z up). The pivot sits above the car body;
``pendulum_joint`` turns about +y, so θ > 0 swings the bob toward the rear: bob = pivot +
(−l sin θ, 0, −l cos θ). The URDF lets ``robot_state_publisher`` animate the swing from the recorded
JointState; the markers show it without TF (fixed frame ``base_link``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.cdr_layout import Layout

if TYPE_CHECKING:  # rosbags' protocol of its typestore's message classes (defined for type checkers only)
    from rosbags.typesys.store import Msg

BODY = (1.0, 0.6, 0.2)
"""Car body box (length x, width y, height z), m: only a reference for the eye."""
PIVOT_CLEARANCE = 0.3
"""m between the bob's lowest point and the top of the car body."""
ARROW_M_PER_MS2 = 0.1
"""Arrow length per unit acceleration: 0.1 m per m/s² (a 3 m/s² step draws a 0.3 m arrow)."""
MARKER_RATE_HZ = 30.0
"""Marker messages per simulated second: enough for the eye, 1/33 of a 1 kHz chain's traffic."""
TRUTH_COLOR = (0.1, 0.7, 0.2)
ESTIMATE_COLOR = (0.9, 0.2, 0.1)

# Marker type and action codes (visualization_msgs/Marker constants).
_ARROW, _SPHERE, _LINE_STRIP = 0, 2, 4


def pivot_height(length: float) -> float:
    """z of the pivot in base_link: body height + string length + bob radius + clearance (m)."""
    return BODY[2] + length + bob_radius(length) + PIVOT_CLEARANCE


def bob_radius(length: float) -> float:
    """Bob radius drawn: 5 % of the string, at least 2 cm (m)."""
    return max(0.02, 0.05 * length)


def urdf(length: float, name: str = "pendulum_accel", *, mass: float = 1.0) -> str:
    """URDF of the car body, the pivot, ``pendulum_joint`` (continuous about y: a large swing goes over
    the top) and the string and bob sized from ``length`` (m): ``base_link`` → pivot_link (fixed) →
    pendulum_link (pendulum_joint) → bob_link (fixed, l below the pivot).

    Inertials are what the model has: the bob's ``mass`` (kg) on bob_link, as a solid sphere of the drawn
    radius r (I = 2/5 m r² about each axis: the model's point mass, drawn with a size); the string is
    massless, so pendulum_link and pivot_link carry none, nor does base_link (the car's mass is no
    part of the model, and KDL refuses an inertia on the root link).
    """
    lx, ly, lz = BODY
    h = pivot_height(length)
    r = bob_radius(length)
    inertia = 0.4 * mass * r * r
    return f"""<?xml version="1.0"?>
<robot name="{name}">
  <material name="body"><color rgba="0.6 0.6 0.65 1"/></material>
  <material name="string"><color rgba="0.2 0.2 0.2 1"/></material>
  <material name="bob"><color rgba="0.1 0.3 0.9 1"/></material>
  <link name="{bm.FRAME_ID}">
    <visual>
      <origin xyz="0 0 {lz / 2:g}"/>
      <geometry><box size="{lx:g} {ly:g} {lz:g}"/></geometry>
      <material name="body"/>
    </visual>
  </link>
  <link name="pivot_link"/>
  <joint name="pivot_joint" type="fixed">
    <parent link="{bm.FRAME_ID}"/>
    <child link="pivot_link"/>
    <origin xyz="0 0 {h:.6g}"/>
  </joint>
  <link name="pendulum_link">
    <visual>
      <origin xyz="0 0 {-length / 2:.6g}"/>
      <geometry><cylinder radius="0.005" length="{length:.6g}"/></geometry>
      <material name="string"/>
    </visual>
  </link>
  <joint name="{bm.PENDULUM_JOINT}" type="continuous">
    <parent link="pivot_link"/>
    <child link="pendulum_link"/>
    <axis xyz="0 1 0"/>
  </joint>
  <link name="bob_link">
    <inertial>
      <mass value="{mass:.9g}"/>
      <inertia ixx="{inertia:.9g}" ixy="0" ixz="0" iyy="{inertia:.9g}" iyz="0" izz="{inertia:.9g}"/>
    </inertial>
    <visual>
      <geometry><sphere radius="{r:.6g}"/></geometry>
      <material name="bob"/>
    </visual>
  </link>
  <joint name="bob_joint" type="fixed">
    <parent link="pendulum_link"/>
    <child link="bob_link"/>
    <origin xyz="0 0 {-length:.6g}"/>
  </joint>
</robot>
"""


def _marker(
    ns: str, kind: int, color: tuple[float, float, float], points: int = 0, frame_id: str = bm.FRAME_ID
) -> Msg:
    """A visualization_msgs/Marker in ``frame_id`` (id 0 in ``ns``), ``points`` zero points, opaque."""
    store = bm.TYPESTORE.types
    marker_cls = store["visualization_msgs/msg/Marker"]
    point_cls = store["geometry_msgs/msg/Point"]
    pose_cls = store["geometry_msgs/msg/Pose"]
    quat_cls = store["geometry_msgs/msg/Quaternion"]
    color_cls = store["std_msgs/msg/ColorRGBA"]
    vector_cls = store["geometry_msgs/msg/Vector3"]
    duration_cls = store["builtin_interfaces/msg/Duration"]
    marker: Msg = marker_cls(
        header=bm.joint_state(0, [], [], frame_id=frame_id).header,
        ns=ns,
        id=0,
        type=kind,
        action=0,
        pose=pose_cls(
            position=point_cls(x=0.0, y=0.0, z=0.0), orientation=quat_cls(x=0.0, y=0.0, z=0.0, w=1.0)
        ),
        scale=vector_cls(x=0.0, y=0.0, z=0.0),
        color=color_cls(r=color[0], g=color[1], b=color[2], a=1.0),
        lifetime=duration_cls(sec=0, nanosec=0),
        frame_locked=False,
        points=[point_cls(x=0.0, y=0.0, z=0.0) for _ in range(points)],
        colors=[],
        texture_resource="",
        texture=store["sensor_msgs/msg/CompressedImage"](
            header=bm.joint_state(0, [], []).header, format="", data=np.zeros(0, dtype=np.uint8)
        ),
        uv_coordinates=[],
        text="",
        mesh_resource="",
        mesh_file=store["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, dtype=np.uint8)),
        mesh_use_embedded_materials=False,
    )
    return marker


def _marker_array(markers: list[Msg]) -> Msg:
    """visualization_msgs/MarkerArray of ``markers``."""
    array: Msg = bm.TYPESTORE.types[bm.MARKER_ARRAY](markers=markers)
    return array


def marker_mask(t: NDArray[np.float64], rate_hz: float = MARKER_RATE_HZ) -> NDArray[np.bool_]:
    """True on the first sample of every 1/rate_hz interval of t (s): the samples that get markers."""
    tick = np.floor((np.asarray(t, dtype=np.float64) - t[0]) * rate_hz + 1e-9).astype(np.int64)
    mask = np.ones(tick.size, dtype=bool)
    mask[1:] = tick[1:] != tick[:-1]
    return mask


def _stamp(ns: NDArray[np.int64], prefix: str) -> dict[str, object]:
    """{prefix.header.stamp.sec / nanosec: columns} of integer nanoseconds."""
    sec, nanosec = bm.split_stamp(ns)
    return {f"{prefix}header.stamp.sec": sec, f"{prefix}header.stamp.nanosec": nanosec}


def swing_marker_rows(
    ns: NDArray[np.int64],
    theta: NDArray[np.float64],
    accel: NDArray[np.float64],
    length: float,
    frame_id: str = bm.FRAME_ID,
) -> NDArray[np.uint8]:
    """MarkerArray CDR rows in ``frame_id``: the string (pivot → bob), the bob, and the true-acceleration
    arrow along x (ARROW_M_PER_MS2 m per m/s², from above the pivot), one row per sample at ``ns``."""
    h = pivot_height(length)
    string = _marker("string", _LINE_STRIP, (0.2, 0.2, 0.2), points=2, frame_id=frame_id)
    bob = _marker("bob", _SPHERE, (0.1, 0.3, 0.9), frame_id=frame_id)
    truth = _marker("accel_truth", _ARROW, TRUTH_COLOR, points=2, frame_id=frame_id)
    layout = Layout.of(_marker_array([string, bob, truth]), bm.MARKER_ARRAY)
    bx = -length * np.sin(theta)  # bob = pivot + (−l sin θ, 0, −l cos θ)
    bz = h - length * np.cos(theta)
    diameter = 2.0 * bob_radius(length)
    arrow_z = h + 0.1
    cols: dict[str, object] = {}
    for i in range(3):
        cols.update(_stamp(ns, f"markers[{i}]."))
    cols.update(
        {
            "markers[0].scale.x": 0.01,
            "markers[0].points[0].z": h,
            "markers[0].points[1].x": bx,
            "markers[0].points[1].z": bz,
            "markers[1].pose.position.x": bx,
            "markers[1].pose.position.z": bz,
            "markers[1].scale.x": diameter,
            "markers[1].scale.y": diameter,
            "markers[1].scale.z": diameter,
            **_arrow_columns("markers[2].", accel, arrow_z),
        }
    )
    return layout.encode(ns.size, _full(cols, ns.size))


def _arrow_columns(prefix: str, accel: NDArray[np.float64] | float, z: float) -> dict[str, object]:
    """Columns of an ARROW marker from (0, 0, z) to (ARROW_M_PER_MS2 · a, 0, z): shaft 2 cm, head 4 cm."""
    return {
        f"{prefix}scale.x": 0.02,
        f"{prefix}scale.y": 0.04,
        f"{prefix}scale.z": 0.04,
        f"{prefix}points[0].z": z,
        f"{prefix}points[1].x": ARROW_M_PER_MS2 * np.asarray(accel, dtype=np.float64),
        f"{prefix}points[1].z": z,
    }


def _full(cols: Mapping[str, object], n: int) -> dict[str, NDArray[np.generic]]:
    """Every column broadcast to length n (constants become constant columns)."""
    return {k: np.broadcast_to(np.asarray(v), (n,)) for k, v in cols.items()}


def estimate_marker_writer(length: float, frame_id: str = bm.FRAME_ID) -> Callable[[int, int, float], bytes]:
    """(sec, nanosec, â) ↦ CDR of the estimate's one-arrow MarkerArray for a pendulum of ``length`` in
    ``frame_id``: an arrow from (0, 0, z) to (ARROW_M_PER_MS2 · â, 0, z), z above the truth arrow."""
    arrow = _marker("accel_estimate", _ARROW, ESTIMATE_COLOR, points=2, frame_id=frame_id)
    layout = Layout.of(_marker_array([arrow]), bm.MARKER_ARRAY)
    z = pivot_height(length) + 0.2
    constants = _full(_arrow_columns("markers[0].", 0.0, z), 1)
    filled = dataclasses.replace(layout, template=layout.encode(1, constants)[0])
    write = filled.writer(
        ("markers[0].header.stamp.sec", "markers[0].header.stamp.nanosec", "markers[0].points[1].x")
    )

    def marker(sec: int, nanosec: int, accel: float) -> bytes:
        """The MarkerArray for one estimate â (m/s²) stamped (sec, nanosec)."""
        return write(sec, nanosec, ARROW_M_PER_MS2 * accel)

    return marker
