"""Re-mounting a compiled scene's cameras: field of view, position and orientation on the mount.

A task's camera settings (``env.camera_fovy``, ``env.camera_offset``, ``env.camera_rotation``)
change the compiled model's arrays (``model.cam_fovy``, ``cam_pos``, ``cam_quat``) after the
scene is built, not the MJCF: every task built from any robot file gets them, and nothing of the
physics changes. Offsets and rotations are in the camera's own frame (MuJoCo's: x right, y up,
looking along -z), so ``[0, 0.1, 0]`` raises a camera 10 cm along its own up axis and a
rotation of ``[-10, 0, 0]`` tilts its view 10 degrees down, whatever the robot's geometry.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True)
class Mount:
    """How a camera sits on its body: what :func:`mount_camera` starts from."""

    fovy: float
    pos: np.ndarray
    quat: np.ndarray

    @classmethod
    def of(cls, model: mujoco.MjModel, camera: int) -> Mount:
        """The camera's mount as the model has it now."""
        return cls(
            float(model.cam_fovy[camera]),
            model.cam_pos[camera].copy(),
            model.cam_quat[camera].copy(),
        )


def rotation_quat(degrees: Sequence[float]) -> np.ndarray:
    """The unit quaternion of turning ``degrees`` about x, then about the turned y, then about
    the twice-turned z (intrinsic x-y-z)."""
    quat = np.array([1.0, 0.0, 0.0, 0.0])
    for axis, angle in enumerate(degrees):
        half = np.radians(angle) / 2
        turn = np.zeros(4)
        turn[0], turn[1 + axis] = np.cos(half), np.sin(half)
        mujoco.mju_mulQuat(quat, quat.copy(), turn)
    return quat


def mount_camera(
    model: mujoco.MjModel,
    camera: int,
    home: Mount,
    *,
    fovy: float | None = None,
    offset: Sequence[float] = (0.0, 0.0, 0.0),
    rotation: Sequence[float] = (0.0, 0.0, 0.0),
) -> None:
    """Put ``camera`` at its ``home`` mount moved by ``offset`` (metres) and turned by
    ``rotation`` (degrees, :func:`rotation_quat`), both in the camera's own frame, with field
    of view ``fovy`` (degrees; ``None``: home's). Starting from ``home`` makes it idempotent.
    ``data.cam_xpos``/``cam_xmat`` follow at the next ``mj_forward`` (or ``mj_camlight``)."""
    axes = np.empty(9)
    mujoco.mju_quat2Mat(axes, home.quat)
    model.cam_pos[camera] = home.pos + axes.reshape(3, 3) @ np.asarray(offset, dtype=np.float64)
    quat = np.empty(4)
    mujoco.mju_mulQuat(quat, home.quat, rotation_quat(rotation))
    model.cam_quat[camera] = quat
    model.cam_fovy[camera] = home.fovy if fovy is None else fovy
