"""Pilots on why maopg's ACAC leaves the small boxes in fewer seeds than its authors' on the 6x6
grid: ``box-pushing-6``'s ACAC delivers the big box in 3 seeds of 5, the authors' logged runs in
5 of 5 (docs/results/box-pushing.md). Four of the authors' seeds read 35-39 at 50K on the
published counter, the same plateau (both small boxes), and 299 at 100K
(``published_seeds.py``); maopg's trapped seeds never leave it. Each pilot sets one detail
where ACAC's public code departs from its published description back to the code's form
(``maopg.learner.acac``), one at a time:

- ``drop-cut``: an agent's last decision whose option the episode's end cut short — typically
  a robot on its way to the big box when its partner's small box ends the episode — is left
  out of its actor's loss, as the code does; maopg trains on it, and once the critic expects
  both small boxes such a decision reads a negative advantage;
- ``last-advantage``: the critic's target at an episode's last step is its advantage alone, as
  the code computes it, which keeps a lasting advantage of about half the last reward on the
  final push (some +150 on the big box's).

Five seeds each (0-4, the study's), not three: the outcome is a seed's, caught or not, at a rate
near 2 in 5, which three seeds cannot tell from 0 in 5. The study's runs at the same seeds are
the baseline row, and the ``acac-seeds`` study (seeds 5-9) is a second sample of it
(``grid6_pilots.py``: where the runs go and how the table reads them).

    python bench/analysis/acac_pilots.py run [PILOT ...]
    python bench/analysis/acac_pilots.py table > results/box-pushing-6/pilots/acac.md
"""

from __future__ import annotations

from pathlib import Path

from grid6_pilots import Pilot, PilotSet, at_text

PILOTS = PilotSet(
    "acac",
    (0, 1, 2, 3, 4),
    f"ACAC on the 6x6 grid at its published settings; each seed's value on the published "
    f"counter at {at_text()} (the mean of its last 5 evaluations, 10 episodes each, sampled, no "
    "ε), its lowest evaluation over the whole run and what its final value says it learnt. The "
    "authors' five seeds all deliver the big box: 299.3 / 299.3 / 299.3.",
    {
        "drop-cut": Pilot(
            "decisions cut short by the episode's end left out of the actors' loss (ACAC's code)",
            {"acac.cut_decisions": "drop"},
        ),
        "last-advantage": Pilot(
            "the critic's target at an episode's last step is its advantage alone (ACAC's code)",
            {"acac.last_target": "advantage"},
        ),
    },
    also=Path("results/acac-seeds/runs"),
)

if __name__ == "__main__":
    PILOTS.main(__doc__)
