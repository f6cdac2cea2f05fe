"""Fetch: a fixed-base arm that searches the shelf, stages tools on the desk and hands them over."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from maopg.sim.robots.base import ArmAdapter

ARM_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_pitch")


@dataclass(frozen=True)
class FetchConstants:
    """Link sizes, PD gains and postures: the one place to tune the Fetch arm."""

    #: Shoulder height above the base origin and link lengths (must match fetch.xml).
    shoulder_height: float = 1.0
    upper_arm: float = 0.7
    forearm: float = 0.7
    hand: float = 0.18
    #: PD gains per arm joint (pan, lift, elbow, wrist pitch): about critically damped with
    #: the joints' armature, settling within ~1 s.
    kp: tuple[float, float, float, float] = (150.0, 150.0, 100.0, 30.0)
    kv: tuple[float, float, float, float] = (40.0, 40.0, 20.0, 3.0)
    finger_kp: float = 200.0
    finger_kv: float = 10.0
    #: Finger opening (m per finger) when open / closed on a tool.
    finger_open: float = 0.04
    finger_closed: float = 0.012
    #: Folded start posture (rad): gripper above the near edge of the desk, pointing down.
    home: tuple[float, float, float, float] = (0.0, 1.3, -2.5, -0.37)


class FetchAdapter(ArmAdapter):
    """Binds a Fetch: joint-space PD targets, an open/closed gripper and analytic IK.

    ``ik`` solves the pan angle from the target's bearing and the planar 2-link (lift, elbow)
    problem for the wrist point, elbow up, with the hand at the requested pitch (-pi/2 = pointing
    straight down). Targets are expressed in the base frame, so any spawn pose works.
    """

    Constants = FetchConstants

    def __init__(self, model, data, prefix, constants=None) -> None:
        super().__init__(model, data, prefix, constants)
        c = self.constants
        self._act = np.array([self.actuator_id(j) for j in ARM_JOINTS])
        self._qadr = np.array([self.joint_qpos_adr(j) for j in ARM_JOINTS])
        self._fingers = [self.actuator_id(f) for f in ("finger_l", "finger_r")]
        for j, kp, kv in zip(ARM_JOINTS, c.kp, c.kv, strict=True):
            self.set_position_gains(j, kp, kv)
        self._finger_qadr = [self.joint_qpos_adr(f) for f in ("finger_l", "finger_r")]
        for f in ("finger_l", "finger_r"):
            self.set_position_gains(f, c.finger_kp, c.finger_kv)
        self._grasp = self.object_id(mujoco.mjtObj.mjOBJ_SITE, "grasp")
        self._target = self.joint_positions()
        self._closed = False

    def set_initial_pose(self) -> None:
        """Start folded with the gripper open."""
        self.data.qpos[self._qadr] = self.constants.home
        self.data.qpos[self._finger_qadr] = self.constants.finger_open

    def reset(self) -> None:
        self._closed = False
        self.hold()

    def hold(self) -> None:
        self._target = self.joint_positions()

    def set_arm_targets(self, q: np.ndarray) -> None:
        self._target = np.asarray(q, dtype=float).copy()

    def set_gripper(self, closed: bool) -> None:
        self._closed = bool(closed)

    def joint_positions(self) -> np.ndarray:
        return self.data.qpos[self._qadr].copy()

    def reached(self, tol: float = 0.02) -> bool:
        """Every arm joint within ``tol`` rad of its target."""
        return bool(np.max(np.abs(self.data.qpos[self._qadr] - self._target)) <= tol)

    def apply(self) -> None:
        self.data.ctrl[self._act] = self._target
        c = self.constants
        opening = c.finger_closed if self._closed else c.finger_open
        for a in self._fingers:
            self.data.ctrl[a] = opening

    @property
    def grasp_site_position(self) -> np.ndarray:
        return self.data.site_xpos[self._grasp].copy()

    def ik(self, xyz_world: Sequence[float], pitch: float = -math.pi / 2) -> np.ndarray:
        c = self.constants
        base = self.data.xpos[self.root_body_id]
        rot = self.data.xmat[self.root_body_id].reshape(3, 3)
        p = rot.T @ (np.asarray(xyz_world, dtype=float) - base)
        pan = math.atan2(p[1], p[0])
        # Wrist point in the arm's vertical plane (r outward, z up from the shoulder).
        r = math.hypot(p[0], p[1]) - c.hand * math.cos(pitch)
        z = p[2] - c.shoulder_height - c.hand * math.sin(pitch)
        l1, l2 = c.upper_arm, c.forearm
        cos_elbow = (r * r + z * z - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)
        if abs(cos_elbow) > 1.0:
            raise ValueError(
                f"{self.prefix}: target {tuple(np.round(xyz_world, 3))} is out of reach "
                f"(wrist distance {math.hypot(r, z):.3f} m, arm length {l1 + l2:.3f} m)"
            )
        elbow = -math.acos(cos_elbow)  # negative: elbow above the wrist
        lift = math.atan2(z, r) - math.atan2(l2 * math.sin(elbow), l1 + l2 * math.cos(elbow))
        return np.array([pan, lift, elbow, pitch - lift - elbow])
