"""Pilots on what keeps maopg's Mac-IAICC from the authors' logged Box Pushing curves: on the
6x6 grid with the state critics of MacroMARL's scripts, ``box-pushing-6``'s Mac-IAICC passes
through evaluations far below a random team's (both robots pushing the big box from one side,
every push penalised) in every seed, where the authors' logged runs never read below 5.6, and
settles at the 6-tick delivery where theirs read 279-292 (docs/results/box-pushing.md). Their
logs share ACAC's logging cadence (``bench/analysis/published_seeds.py``: row spacing), so they
may come from ACAC's runner, whose exploration falls over 30,000 episodes rather than
MacroMARL's 4,000. Each pilot changes one setting of the study's, 3 seeds, to the published
counter's 500K (2.5M samples, as ACAC's runs); the study's own seeds 0-2 are the baseline row
(``grid6_pilots.py``: where the runs go and how the table reads them).

    python bench/analysis/mac_iaicc_pilots.py run [PILOT ...]
    python bench/analysis/mac_iaicc_pilots.py table > results/box-pushing-6/pilots/mac-iaicc.md
"""

from __future__ import annotations

from grid6_pilots import Pilot, PilotSet, at_text

BUDGET = 2_500_000
"""Samples a pilot trains: past 500K on the published counter while ε stays high (ACAC's)."""

PILOTS = PilotSet(
    "mac-iaicc",
    (0, 1, 2),
    f"Mac-IAICC on the 6x6 grid (state critics, MacroMARL's Box Pushing settings); each seed's "
    f"value on the published counter at {at_text()} (the mean of its last 5 evaluations, 10 "
    "episodes each, sampled, no ε), its lowest evaluation over the whole run and what its final "
    "value says it learnt. The authors' five seeds: 19.1 / 102.4 / 286.6, none below 5.6.",
    {
        "explore-30000": Pilot(
            "ε over 30,000 episodes (ACAC's runner), not MacroMARL's 4,000",
            {"maciaicc.explore_decay": 30_000, "total_samples": BUDGET},
        ),
        "rounds-16": Pilot(
            "rounds of 16 episodes (ACAC's runner), not MacroMARL's 32",
            {"maciaicc.episodes_per_update": 16, "total_samples": BUDGET},
        ),
    },
)

if __name__ == "__main__":
    PILOTS.main(__doc__)
