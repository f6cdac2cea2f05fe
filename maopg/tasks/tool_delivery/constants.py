"""Layout facts and names of the canonical Tool Delivery task (docs/DESIGN.md §7).

Metres in the 7 m x 5 m world. Everything here is plain data, shared by the scene, the options,
the rules, the scripted policy and the tests, so no module repeats a coordinate or a name. What
depends on the robots chosen — where the arm stands, where the Turtlebots wait for a pass — is
in the config (``fetch_base``, ``desk_spots``) instead, and what depends on the team's size in
:mod:`~maopg.tasks.tool_delivery.team`, whose default team reproduces the canonical agents and
layouts below.
"""

from __future__ import annotations

from maopg.tasks.layout import ObsLayout

WORKSHOP = (6.0, 3.0)
"""WA0, where the human takes deliveries."""
TOOL_ROOM_WAIT = (2.5, 3.5)
"""The tool-room wait spot (GoToTR)."""
TURTLEBOT_STARTS = ((3.0, 1.5), (3.0, 2.5))
NUM_TOOLS = 3
NUM_STAGES = 4
"""Stages 0..2 each need tool 0..2; stage 3 is the work after the last tool."""

AGENTS = ("turtlebot0", "turtlebot1", "fetch")
"""The canonical team's agents (``Team.agents`` at the default sizes)."""
T0, T1, FETCH = 0, 1, 2

# Scene names (the Fetch's gripper body is its adapter's, ``ArmAdapter.gripper``).
TOOL = "tool{}/tool"
"""Body of tool j in the arena."""
BASKET = "{}/basket"
"""Body that holds a Turtlebot's load (format with the agent name)."""
STAGE_ON, STAGE_OFF = (0.1, 0.85, 0.2, 1.0), (0.25, 0.25, 0.25, 1.0)
"""Colours of the human's lit and unlit stage-bar segments."""

# Option names (checkpoints index options by position; code finds them by these names).
GO_TO_WS, GO_TO_TR, GET_TOOL = "GoToWS", "GoToTR", "GetTool"
WAIT = "Wait"
STAY = "Stay"


def pass_to(w: int) -> str:
    return f"PassTo({w})"


def search_tool(j: int) -> str:
    return f"SearchTool({j})"


# Observations.
LOCATIONS = ("workshop", "tool_room", "desk", "moving")
"""The kinds of a Turtlebot's one-hot ``location`` field, in order (one entry per workshop,
per bay and per desk of a larger team: ``Team.location``)."""
MAX_STAGED_SEEN = 2
"""The ``staged`` fields count tools on the desk one-hot as 0, 1, or 2 and more."""
TURTLEBOT_OBS = ObsLayout.of(
    location=len(LOCATIONS),
    human_stage=NUM_STAGES,  # one-hot; all zero unless at WA0
    carried=NUM_TOOLS,  # tools in the basket
    staged=MAX_STAGED_SEEN + 1,  # one-hot count; all zero at WA0
)
FETCH_OBS = ObsLayout.of(
    staged=MAX_STAGED_SEEN + 1,  # one-hot count of tools on the desk
    waiting=2,  # which of the two Turtlebots is ready for a pass
)
"""The canonical team's layouts (``Team.turtlebot_layout`` / ``fetch_layout`` in general)."""
