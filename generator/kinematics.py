"""Joint kinematics of a posed body, in plain numpy: the walking gait cycle and rotations.

:func:`gait_angles` gives the sagittal joint angles of a walking pose at a phase of the
gait cycle (hip, knee and foot pitch from a table after Winter's normal-walking averages,
arm swing against the opposite leg); :func:`rx`, :func:`ry`, :func:`rz` and :func:`rot_to`
are the rotations :class:`generator.body.BodyModel` composes a pose from.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["gait_angles", "rx", "ry", "rz", "rot_to"]


def _interp_cyclic(phase, table):
    xs = np.linspace(0.0, 1.0, len(table))
    return float(np.interp(phase % 1.0, xs, table))


# Sagittal angles (degrees) over one gait cycle from the left heel strike (phase 0), sampled
# at phases 0, 0.1, ..., 1.0; after Winter's normal-walking averages, rounded.
_HIP = [25, 20, 10, 0, -8, -12, -5, 12, 24, 28, 25]          # + = flexion (thigh forward)
_KNEE = [5, 18, 12, 5, 3, 10, 38, 60, 40, 12, 5]              # + = flexion
_FOOT = [-18, -4, 0, 0, 4, 22, 35, 12, -5, -15, -18]          # world pitch, + = toes down


def gait_angles(phase: float, stride: float = 1.0, arm_swing: float = 1.0) -> dict:
    """Joint angles (radians) of a walking pose at ``phase`` in [0, 1).

    Returns ``hip_L, knee_L, foot_L, hip_R, knee_R, foot_R, shoulder_L, shoulder_R,
    elbow_L, elbow_R, twist``. The right leg runs half a cycle behind the left; each arm
    swings against the opposite leg.
    """
    r = math.radians
    out = {}
    for side, ph in (("L", phase), ("R", phase + 0.5)):
        out[f"hip_{side}"] = r(_interp_cyclic(ph, _HIP)) * stride
        out[f"knee_{side}"] = r(_interp_cyclic(ph, _KNEE)) * stride
        out[f"foot_{side}"] = r(_interp_cyclic(ph, _FOOT)) * stride
    swing = r(18.0) * arm_swing
    c = math.cos(2 * math.pi * (phase - 0.05))
    out["shoulder_L"] = -swing * c
    out["shoulder_R"] = swing * c
    out["elbow_L"] = r(12) + r(18) * max(0.0, -c) * arm_swing
    out["elbow_R"] = r(12) + r(18) * max(0.0, c) * arm_swing
    out["twist"] = r(6) * c * stride
    return out


def rx(a):
    """Rotation matrix (3, 3) by ``a`` radians about the x axis."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    """Rotation matrix (3, 3) by ``a`` radians about the y axis."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    """Rotation matrix (3, 3) by ``a`` radians about the z axis."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rot_to(a, b):
    """Smallest rotation taking direction ``a`` to direction ``b``."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(a @ b)
    s = float(np.linalg.norm(v))
    if s < 1e-12:
        return np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx * ((1 - c) / s ** 2)
