"""The values of ``env.appearance``: how a scene task's world looks, episode by episode.

This module holds the names alone (no MuJoCo, no numpy), so a task's settings, ``--help`` and
the settings reference list them without importing the simulator. What each one draws is in
:mod:`maopg.sim.look_draws`, how a draw is shown in :mod:`maopg.sim.appearance`.

Training levels, each drawn afresh every episode from the episode's seed:

- ``off`` (default): the scene exactly as its task builds it, model and images unchanged;
- ``light``: the colours of the floors, walls and furniture from the training palette, and
  the lights' intensities and colour jittered a little; nothing else changes, and the compiled
  model is the one ``off`` compiles;
- ``full``: ``light``'s colours on textures of their own (checks, speckles, tiles, plain), the
  lights moved, turned and dimmed or brightened, each robot's camera jittered by a few
  centimetres and degrees, and up to four distractor objects standing by the walls.

The held-out sets, never drawn in training (:mod:`maopg.sim.look_draws` says why they cannot
meet it):

- ``heldout``: ``full``'s kind of draw from other palettes (dark, neon, pale colours), other
  textures (gradients, crosses, bold checks, at other scales) and lights outside the training
  ranges (much dimmer or brighter, visibly coloured, moved and turned further); the cameras
  jittered as in training;
- ``mounts``: geometry held out instead: ``full``'s draw with each robot camera turned and
  moved on its mount further than training ever does (what a depth camera sees change);
- the named presets, each one fixed look from ``heldout``'s kind, the same every episode, to
  look at (``python -m eval video RUN env.appearance=dusk``): ``dusk`` (dim, warm light on dark
  colours), ``neon`` (bright coloured light on saturated colours) and ``glare`` (a harsh,
  very bright light on pale colours).
"""

from __future__ import annotations

OFF = "off"
TRAINING = (OFF, "light", "full")
"""The levels a policy may be trained under."""
HELDOUT = "heldout"
"""Colours, textures and lights never drawn in training."""
MOUNTS = "mounts"
"""Training's looks with the cameras moved on their mounts further than training does."""
PRESETS = ("dusk", "neon", "glare")
"""Fixed looks of ``heldout``'s kind."""
APPEARANCES = (*TRAINING, HELDOUT, MOUNTS, *PRESETS)
"""Every value ``env.appearance`` takes."""
