"""Named observation layouts: which slice of an agent's vector means what.

A task declares each agent's vector as an ordered list of named fields with their sizes; its
``observe()`` writes fields by name, scripted policies read them by name, and the video panel
labels them, so no index such as ``obs[8 + j]`` has to be kept in step with the code that wrote
it. The order of the fields is the order of the vector (what trained networks were fed).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class ObsLayout:
    """Ordered ``(name, size)`` fields of one observation vector (build with :meth:`of`)."""

    fields: tuple[tuple[str, int], ...]
    _slices: Mapping[str, slice] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        slices, start = {}, 0
        for name, size in self.fields:
            if name in slices:
                raise ValueError(f"observation field {name!r} appears twice")
            if size < 1:
                raise ValueError(f"observation field {name!r} needs a positive size, got {size}")
            slices[name] = slice(start, start + size)
            start += size
        object.__setattr__(self, "_slices", slices)

    @classmethod
    def of(cls, **sizes: int) -> ObsLayout:
        """``ObsLayout.of(levels=3, position=2)``: fields in keyword order."""
        return cls(tuple(sizes.items()))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(name for name, _ in self.fields)

    @property
    def size(self) -> int:
        """Length of the whole vector."""
        return sum(size for _, size in self.fields)

    def __getitem__(self, name: str) -> slice:
        """The slice of field ``name`` (a ``KeyError`` lists the known fields)."""
        try:
            return self._slices[name]
        except KeyError:
            raise KeyError(f"no observation field {name!r}; fields: {list(self.names)}") from None

    def zeros(self) -> np.ndarray:
        """A float32 vector of this layout, all zeros (what ``observe()`` fills in)."""
        return np.zeros(self.size, np.float32)

    def split(self, vector: np.ndarray) -> dict[str, np.ndarray]:
        """Field name -> view of that field in ``vector``."""
        if len(vector) != self.size:
            raise ValueError(f"expected a vector of {self.size} values, got {len(vector)}")
        return {name: vector[s] for name, s in self._slices.items()}
