"""Where everything of a Tool Delivery team stands: the scaled family's layout (plain data).

The task scales the way the macro-action literature scales it (Xiao et al.'s Warehouse A–E,
MacDeepMARL): **one bay per Fetch** — a tool room with the Fetch, its staging desk and its
wait spot — and **one workshop and tool sequence per human**: human ``h`` needs its own three
tools (tools ``3h .. 3h+2``, a wrench, a hammer and a screwdriver) in order, and they lie on
a shelf of their own in the bay of Fetch ``h % fetches``. Turtlebots are shared: any of them may
fetch from any desk and deliver to any workshop.

Why the layout is as it is. Turtlebots drive straight to their waypoints (``GoTo``, as in the
canonical task), so every straight route between the waypoints a Turtlebot may use — its start,
its desk spot in every bay, every wait spot and every workshop — must miss the furniture
(``tests/tasks/test_tool_delivery_teams.py`` checks this on the compiled scene). Hence:

- Bay 0 is the canonical tool room; bay 1 is its mirror image across ``y = 5`` (the world grows
  to 7 m x 10 m), so the two bays' desk spots face each other across one open aisle and a trip
  between bays never passes a Fetch. A third bay would put a bay's furniture between two
  others: at most two Fetches.
- A bay's first shelf stands where the canonical one does (west of the Fetch); a second human of
  the same bay gets a second shelf south of the Fetch, the only other place within the arm's
  reach that no route crosses: at most two humans per Fetch.
- Each Turtlebot has its own desk spot in every bay (the canonical two plus four more on a
  second row, all within the arm's reach and clear of the desk and shelf): at most six
  Turtlebots. Ground robots do not collide with each other, only the spots' routes matter.
- Workshops lie on the east side, 2 m apart: bay ``b``'s humans at ``y = 3`` and ``y = 1``
  (mirrored in bay 1), so each human works near the bay that holds its tools.

The default team (2 Turtlebots, 1 Fetch, 1 human) is exactly the canonical task: its arena is
``assets/arenas/tool_delivery.xml`` unchanged and its names are the canonical ones
(``turtlebot0``, ``turtlebot1``, ``fetch``; ``GoToWS``, ``PassTo(0)``, ``SearchTool(j)``, ...).
Names gain an index only where there are several targets: ``fetch0, fetch1`` with two Fetches,
``GoToWS(h)`` with several humans, ``GoToTR(f)`` / ``GetTool(f)`` with several Fetches,
``SearchTool(h,j)`` with several humans.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

from maopg.tasks.layout import ObsLayout
from maopg.tasks.tool_delivery.config import Config
from maopg.tasks.tool_delivery.constants import (
    GET_TOOL,
    GO_TO_TR,
    GO_TO_WS,
    LOCATIONS,
    MAX_STAGED_SEEN,
    NUM_STAGES,
    NUM_TOOLS,
    TOOL_ROOM_WAIT,
    TURTLEBOT_STARTS,
    WORKSHOP,
    search_tool,
)

BAY_HEIGHT = 5.0
"""A bay is the canonical world's 5 m along y; the world is ``5 m x fetches`` tall."""
EXTRA_DESK_SPOTS = ((1.0, 2.6), (0.4, 2.6), (1.6, 2.6), (2.0, 2.3))
"""Desk spots of Turtlebots 2..5 in bay 0 (the config's ``desk_spots`` are 0 and 1's)."""
EXTRA_STARTS = ((3.0, 3.5), (4.0, 2.5), (4.0, 3.5), (4.0, 1.5))
"""Start positions of Turtlebots 2..5 (0 and 1 start where the canonical task has them)."""
DESK = (1.75, 1.8)
"""Centre of bay 0's staging desk (the arena's)."""
SHELVES = (((0.3, 1.8), 0.0), ((0.9, 0.75), math.pi / 2))
"""Bay 0's shelf spots (centre, yaw): the canonical one west of the Fetch, a second one south."""
SLOT_SPACING, SHELF_TOP = 0.3, 0.82
"""A shelf's slot ``j`` lies at ``(0, (j - 1) * SLOT_SPACING, SHELF_TOP)`` in the shelf's frame
(the slot sites of ``assets/props/shelf.xml``), where a new shelf's tools start."""
WORKSHOP_ROWS = (WORKSHOP[1], 1.0)
"""The y of the first and second workshop of bay 0 (2 m apart, clear of each other's bench)."""
HUMAN_OFFSET = 0.75
"""The human stands this far east of its workshop spot (the arena's human at x = 6.75)."""
TOOL_FILES = ("tool_wrench.xml", "tool_hammer.xml", "tool_screwdriver.xml")
"""The prop of each tool kind ``j`` (the arena's tools 0..2)."""


def indexed(name: str, i: int, count: int) -> str:
    """``name`` when there is one target, ``name(i)`` when there are several."""
    return name if count == 1 else f"{name}({i})"


@dataclass(frozen=True)
class Team:
    """The sizes of a team and every position and name that follows from them."""

    turtlebots: int
    fetches: int
    humans: int
    fetch_base: tuple[float, float]
    desk_spots: tuple[tuple[float, float], ...]

    @classmethod
    def of(cls, config: Config) -> Team:
        """The team of a config (which checked its sizes when it was made)."""
        spots = (*config.desk_spots, *EXTRA_DESK_SPOTS)
        return cls(config.turtlebots, config.fetches, config.humans, config.fetch_base, spots)

    @property
    def canonical_arena(self) -> bool:
        """One Fetch and one human: the arena file as it is (any number of Turtlebots)."""
        return self.fetches == 1 and self.humans == 1

    @property
    def height(self) -> float:
        """The world's extent along y (m)."""
        return BAY_HEIGHT * self.fetches

    def in_bay(self, bay: int, xy: tuple[float, float]) -> tuple[float, float]:
        """A point of bay 0's layout, placed in ``bay`` (bay 1 mirrors bay 0 across y = 5)."""
        return (xy[0], xy[1]) if bay == 0 else (xy[0], self.height - xy[1])

    # ------------------------------------------------------------------ agents
    @cached_property
    def agents(self) -> tuple[str, ...]:
        """Turtlebots first, then the Fetches (checkpoints index agents in this order)."""
        fetches = ["fetch"] if self.fetches == 1 else [f"fetch{f}" for f in range(self.fetches)]
        return (*(f"turtlebot{w}" for w in range(self.turtlebots)), *fetches)

    def fetch_agent(self, f: int) -> int:
        return self.turtlebots + f

    def fetch_of_agent(self, agent: int) -> int:
        return agent - self.turtlebots

    @property
    def turtlebot_ids(self) -> range:
        return range(self.turtlebots)

    @property
    def fetch_ids(self) -> range:
        return range(self.fetches)

    # ------------------------------------------------------------------ tools and humans
    @property
    def num_tools(self) -> int:
        return NUM_TOOLS * self.humans

    @staticmethod
    def tool(h: int, j: int) -> int:
        """Human ``h``'s tool of stage ``j``."""
        return NUM_TOOLS * h + j

    @staticmethod
    def owner(tool: int) -> int:
        """The human who needs ``tool``."""
        return tool // NUM_TOOLS

    def bay_of_human(self, h: int) -> int:
        """The bay (= Fetch) whose shelf holds human ``h``'s tools."""
        return h % self.fetches

    def humans_of(self, f: int) -> list[int]:
        return [h for h in range(self.humans) if self.bay_of_human(h) == f]

    def tools_of(self, f: int) -> list[int]:
        """Fetch ``f``'s tools, in its option order (by human, then by stage)."""
        return [self.tool(h, j) for h in self.humans_of(f) for j in range(NUM_TOOLS)]

    # ------------------------------------------------------------------ positions
    @cached_property
    def workshops(self) -> tuple[tuple[float, float], ...]:
        """Where Turtlebots deliver to each human (human 0's is the canonical WA0)."""
        rows = [(WORKSHOP[0], WORKSHOP_ROWS[h // self.fetches]) for h in range(self.humans)]
        return tuple(self.in_bay(self.bay_of_human(h), xy) for h, xy in enumerate(rows))

    @cached_property
    def wait_spots(self) -> tuple[tuple[float, float], ...]:
        """Each bay's tool-room wait spot (GoToTR)."""
        return tuple(self.in_bay(b, TOOL_ROOM_WAIT) for b in self.fetch_ids)

    @cached_property
    def fetch_bases(self) -> tuple[tuple[float, float], ...]:
        return tuple(self.in_bay(b, self.fetch_base) for b in self.fetch_ids)

    def desk_spot(self, f: int, w: int) -> tuple[float, float]:
        """Where Turtlebot ``w`` waits for a pass from Fetch ``f``."""
        return self.in_bay(f, self.desk_spots[w])

    @cached_property
    def starts(self) -> tuple[tuple[float, float], ...]:
        return (*TURTLEBOT_STARTS, *EXTRA_STARTS)[: self.turtlebots]

    def desk_center(self, f: int) -> tuple[float, float]:
        return self.in_bay(f, DESK)

    def shelf_pose(self, h: int) -> tuple[tuple[float, float], float]:
        """Centre and yaw of the shelf with human ``h``'s tools (its back to the nearest wall)."""
        (xy, yaw), bay = SHELVES[h // self.fetches], self.bay_of_human(h)
        return self.in_bay(bay, xy), (-yaw if bay == 1 else yaw)

    # ------------------------------------------------------------------ scene names
    @staticmethod
    def numbered(prefix: str, i: int) -> str:
        """The canonical scene name for item 0 (``desk``), numbered ones after it (``desk1``)."""
        return prefix if i == 0 else f"{prefix}{i}"

    def desk(self, f: int) -> str:
        return self.numbered("desk", f)

    def shelf(self, h: int) -> str:
        return self.numbered("shelf", h)

    def human(self, h: int) -> str:
        return self.numbered("human", h)

    def shelf_slot(self, tool: int) -> str:
        """The site where ``tool`` rests on its shelf."""
        return f"{self.shelf(self.owner(tool))}/slot{tool % NUM_TOOLS}"

    def bench_slot(self, tool: int) -> str:
        """The site on its human's bench where a delivered ``tool`` ends."""
        return f"{self.human(self.owner(tool))}/slot{tool % NUM_TOOLS}"

    # ------------------------------------------------------------------ option names
    def go_to_ws(self, h: int) -> str:
        return indexed(GO_TO_WS, h, self.humans)

    def go_to_tr(self, f: int) -> str:
        return indexed(GO_TO_TR, f, self.fetches)

    def get_tool(self, f: int) -> str:
        return indexed(GET_TOOL, f, self.fetches)

    def search_tool(self, tool: int) -> str:
        """``SearchTool(j)`` with one human, ``SearchTool(h,j)`` with several."""
        j = tool % NUM_TOOLS
        return search_tool(j) if self.humans == 1 else f"SearchTool({self.owner(tool)},{j})"

    # ------------------------------------------------------------------ observations
    def location(self, kind: str, i: int = 0) -> int:
        """Index in a Turtlebot's ``location`` field: workshop ``0..H-1``, then tool-room wait
        spot ``0..F-1``, then own desk spot ``0..F-1``, then ``moving`` (the canonical
        ``LOCATIONS`` at one human and one Fetch)."""
        counts = dict(zip(LOCATIONS, (self.humans, self.fetches, self.fetches, 1), strict=True))
        return sum(counts[k] for k in LOCATIONS[: LOCATIONS.index(kind)]) + i

    @cached_property
    def turtlebot_layout(self) -> ObsLayout:
        """A Turtlebot's observation (the canonical one at one human and one Fetch):

        - ``location``: one-hot, see :meth:`location`;
        - ``human_stage``: one-hot stage (0..3) of the human whose workshop it is at, all zero
          elsewhere;
        - ``carried``: one entry per tool (``3h + j``), the tools in its basket;
        - ``staged``: per desk ``f`` a one-hot count (0, 1, 2 or more) at ``3f .. 3f+2``; all
          zero at a workshop (the desks are out of sight there).
        """
        return ObsLayout.of(
            location=self.location("moving") + 1,
            human_stage=NUM_STAGES,
            carried=self.num_tools,
            staged=(MAX_STAGED_SEEN + 1) * self.fetches,
        )

    @cached_property
    def fetch_layout(self) -> ObsLayout:
        """A Fetch's observation: ``staged``, the one-hot count of tools on its own desk, and
        ``waiting``, one entry per Turtlebot ready for a pass at its desk."""
        return ObsLayout.of(staged=MAX_STAGED_SEEN + 1, waiting=self.turtlebots)
