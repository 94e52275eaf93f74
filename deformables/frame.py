"""The working frame of a reduction: positions centred and scaled to about unit size.

Shape letters: N particles.

The rope and cloth reductions compute nothing in absolute units, but floating point does: a
rope 1e6 m from the origin loses the closed-form segment costs of the rope fit to cancellation
(12 keys instead of 4), pymeshlab decimates in single precision (the side fold 1e5 m up got
13 keys and no model under the threshold), and squared distances overflow at 1e200 m or
underflow at 1e-200 m. So both work in a frame whose origin is near the goal and whose unit is
its extent:

* the unit is the power of two that puts ``extent`` (the largest span of the positions along
  x, y or z) in [1/4, 1/2) units, ``2 ** (floor(log2(extent)) + 2)``; dividing by it is exact.
  Goals of 0.25-0.5 m, the library's sizes, are worked on in plain metres, bit for bit as
  before the frame existed: pymeshlab's quadric edge collapse breaks its many ties by rounding
  and is not exactly scale-equivariant even under powers of two (a 40 x 40 underneath fold
  with 0.02 mm of noise, left unprojected, decimates to 20, 15, 16 or 17 faces in units of
  1, 1/2, 1/4 or 1/8 m), so another unit would move counts the tests pin on such goals;
* the origin is the centre of the positions' bounding box rounded to a multiple of that unit:
  for a goal several extents from the origin every coordinate is within a factor
  of two of the origin's, so subtracting it is exact (Sterbenz), and goals about the origin
  (every goal of ``deformables.goals``) are not moved at all.

The range supported is where float64 resolves the goal: coordinates within
``COORDINATE_LIMIT`` (1e300 m) of the origin, particles at least ``MIN_SPACING`` (1e-300 m)
apart, and at most ``MAX_SPACINGS_FROM_ORIGIN`` (1e12) particle spacings from the origin
(float64 rounds such a coordinate to 2e-4 of a spacing; farther, rounding reads as noise).
:func:`check_range` names the one that is exceeded.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: largest supported |coordinate|, metres: spans and sums of them stay finite
COORDINATE_LIMIT = 1e300
#: smallest supported particle spacing, metres: coordinates stay normal float64 numbers
MIN_SPACING = 1e-300
#: largest supported distance from the origin, in particle spacings (rounding 2e-4 spacing)
MAX_SPACINGS_FROM_ORIGIN = 1e12


@dataclass(frozen=True)
class Frame:
    """A working frame: ``unit = (metres - origin) / scale``.

    Attributes:
        origin: ``(3,)`` the frame's origin, metres.
        scale: metres per unit, a power of two.
    """

    origin: np.ndarray
    scale: float

    @classmethod
    def of(cls, positions: np.ndarray) -> Frame:
        """The frame of ``positions`` ``(N, 3)`` (finite, not all at one point, within
        ``COORDINATE_LIMIT``: see :func:`check_coordinates`)."""
        low, high = positions.min(axis=0), positions.max(axis=0)
        extent = float(np.max(high - low))
        scale = float(2.0 ** (np.floor(np.log2(extent)) + 2))
        origin = np.round((0.5 * low + 0.5 * high) / scale) * scale
        return cls(origin, scale)

    def to_unit(self, points: np.ndarray) -> np.ndarray:
        """``points`` ``(..., 3)`` metres -> units of the frame."""
        return (np.asarray(points, dtype=float) - self.origin) / self.scale

    def to_metres(self, points: np.ndarray) -> np.ndarray:
        """``points`` ``(..., 3)`` units of the frame -> metres."""
        return np.asarray(points, dtype=float) * self.scale + self.origin

    def moved(self, positions: np.ndarray) -> Frame:
        """The frame with this scale and the origin of ``positions`` ``(N, 3)`` (another
        point set of the same goal, such as a cloth's rest sheet: same unit, own origin)."""
        low, high = positions.min(axis=0), positions.max(axis=0)
        return Frame(np.round((0.5 * low + 0.5 * high) / self.scale) * self.scale, self.scale)


def check_coordinates(positions: np.ndarray, name: str = "positions") -> None:
    """ValueError if a coordinate of the finite ``positions`` ``(N, 3)`` exceeds
    ``COORDINATE_LIMIT`` in magnitude."""
    largest = float(np.max(np.abs(positions)))
    if largest > COORDINATE_LIMIT:
        raise ValueError(f"{name} has coordinates up to {largest:.3g} m; the supported range "
                         f"is |coordinate| <= {COORDINATE_LIMIT:g} m")


def check_range(positions: np.ndarray, spacing: float, name: str = "positions") -> None:
    """ValueError unless float64 resolves ``positions`` ``(N, 3)`` whose particles are
    ``spacing`` metres apart: the spacing at least ``MIN_SPACING`` and the coordinates within
    ``MAX_SPACINGS_FROM_ORIGIN`` spacings of the origin (the message names the limit)."""
    if not spacing >= MIN_SPACING:
        raise ValueError(f"{name} has particles {spacing:.3g} m apart (median); the supported "
                         f"range is a spacing of at least {MIN_SPACING:g} m (float64 resolves "
                         f"smaller coordinates only as subnormal numbers)")
    largest = float(np.max(np.abs(positions)))
    if largest > MAX_SPACINGS_FROM_ORIGIN * spacing:
        raise ValueError(f"{name} lies {largest:.3g} m from the origin with particles "
                         f"{spacing:.3g} m apart: {largest / spacing:.3g} spacings, beyond the "
                         f"supported {MAX_SPACINGS_FROM_ORIGIN:g} (float64 rounds such "
                         f"coordinates by more than 2e-4 of a spacing); move the goal nearer "
                         f"the origin")
