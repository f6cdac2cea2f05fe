"""Segmentation classes: which kind of thing each geom of a compiled scene is.

A camera's ``seg`` channel (:mod:`maopg.sim.channels`) gives every pixel the class of the
surface it shows, from a small set that stays the same across runs, builds and team sizes:

- ``background`` (id 0): no surface, the sky;
- ``floor``, ``wall``: the room, i.e. the world body's own geoms: a plane or a geom whose name
  has the word ``floor`` is floor, any other is wall (walls, partitions, pillars);
- ``robot``: every geom of every robot's body tree;
- ``distractor``: the geoms of a body (or a world geom) whose name, or a part of it between
  ``/``, starts with ``distractor`` (what domain randomisation adds to a scene);
- then the task's prop classes, in the order the task declares them: a prop is a body attached
  to the world that is none of the above, and its *kind* is its name's last part without the
  instance number (``tool0/tool`` → ``tool``, ``t1/sofa`` → ``sofa``, ``small_box1`` →
  ``small_box``); the task
  maps kinds to classes (Water Filling: sofa, armchair, ... → ``furniture``). A world geom
  whose kind the task maps (Box Pushing's ``goal``) takes that class instead of floor or wall.
  A kind the task does not map is a class of its own, after the declared ones, in name order.

The table is made once per task build (:func:`class_table`) and a frame's colour-coded ids are
turned into class ids per pixel with it (:meth:`ClassTable.lookup`).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import mujoco
import numpy as np

FIXED_CLASSES = ("background", "floor", "wall", "robot", "distractor")
"""The classes every scene has, with the same ids in every task (0-4)."""
DISTRACTOR = "distractor"


def kind_of(name: str) -> str:
    """A body's or geom's kind: its name's last part (after the attachment prefixes) without
    the instance number (``jar0/jar`` → ``jar``, ``t1/sofa`` → ``sofa``, ``small_box1`` →
    ``small_box``)."""
    last = name.rsplit("/", 1)[-1]
    return re.sub(r"[_\d]+$", "", last) or last


def is_distractor(name: str) -> bool:
    """Whether a part of ``name`` between ``/`` starts with ``distractor``."""
    return any(part.startswith(DISTRACTOR) for part in name.split("/"))


@dataclass(frozen=True)
class ClassTable:
    """The class names (id = index) and the class id of every geom and site of one model."""

    classes: tuple[str, ...]
    geom_class: np.ndarray
    """``uint8 [ngeom]``."""
    site_class: np.ndarray
    """``uint8 [nsite]``: a site shows its body's class."""

    def lookup(self, scene: mujoco.MjvScene) -> np.ndarray:
        """``uint8 [scene.ngeom + 1]``: the class of each segmentation id of ``scene`` as
        MuJoCo colours it (0: nothing drawn, ``segid + 1``: the scene's geom ``segid``)."""
        table = np.zeros(scene.ngeom + 1, dtype=np.uint8)
        for geom in scene.geoms[: scene.ngeom]:
            if geom.segid < 0:
                continue
            if geom.objtype == mujoco.mjtObj.mjOBJ_GEOM:
                table[geom.segid + 1] = self.geom_class[geom.objid]
            elif geom.objtype == mujoco.mjtObj.mjOBJ_SITE:
                table[geom.segid + 1] = self.site_class[geom.objid]
        return table


def class_table(
    model: mujoco.MjModel, robot_bodies: Iterable[int], prop_classes: Mapping[str, str]
) -> ClassTable:
    """The :class:`ClassTable` of ``model`` whose robots' root bodies are ``robot_bodies`` and
    whose props' kinds map to classes by ``prop_classes`` (the module docstring)."""
    robots = {int(model.body_rootid[b]) for b in robot_bodies}
    body_kind: dict[int, str] = {}  # the kind, or a fixed class, of each root body
    for body in range(1, model.nbody):
        root = int(model.body_rootid[body])
        if root in body_kind:
            continue
        name = model.body(root).name
        body_kind[root] = (
            "robot" if root in robots else DISTRACTOR if is_distractor(name) else kind_of(name)
        )
    geom_kind = []
    for geom in range(model.ngeom):
        body = int(model.geom_bodyid[geom])
        if body == 0:
            geom_kind.append(_world_kind(model, geom, prop_classes))
        else:
            geom_kind.append(body_kind[int(model.body_rootid[body])])
    undeclared = sorted({k for k in geom_kind if k not in prop_classes})
    classes = tuple(dict.fromkeys((*FIXED_CLASSES, *prop_classes.values(), *undeclared)))
    if len(classes) > 256:
        raise ValueError(f"{len(classes)} segmentation classes do not fit a byte")
    ids = {name: i for i, name in enumerate(classes)}

    def class_id(kind: str) -> int:
        return ids[prop_classes.get(kind, kind)] if kind not in FIXED_CLASSES else ids[kind]

    geom_class = np.array([class_id(k) for k in geom_kind], dtype=np.uint8)
    site_root = (int(model.body_rootid[model.site_bodyid[s]]) for s in range(model.nsite))
    site_class = np.array(
        [ids["wall"] if r == 0 else class_id(body_kind[r]) for r in site_root], dtype=np.uint8
    )
    return ClassTable(classes, geom_class, site_class)


def _world_kind(model: mujoco.MjModel, geom: int, prop_classes: Mapping[str, str]) -> str:
    """The kind of one of the world body's geoms (the module docstring)."""
    name = model.geom(geom).name
    if is_distractor(name):
        return DISTRACTOR
    if name and kind_of(name) in prop_classes:
        return kind_of(name)
    words = name.rsplit("/", 1)[-1].split("_")
    if model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_PLANE or "floor" in words:
        return "floor"
    return "wall"
