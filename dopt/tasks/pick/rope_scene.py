"""A rope (MuJoCo 1D ``flexcomp``, a discrete elastic rod) on a floor, with the picker.

MuJoCo 4.0 removed ``composite``/cable: the rope is a 1D flexcomp with inextensible edges
(``<edge equality="true"/>``, a flex equality that must stay active) and ``<elasticity young>``
for bending and twist (which adds per-edge twist joints and plastic state). Discrete integrator,
CG, dt 0.01 s and rod damping 0.1, chosen with ``python -m planners.bench rope`` against the
stability verdict (docs/DESIGN-NOTES.md, "Cloth and rope physics"). Young's modulus 1e4 Pa
(not the notes' 1e6): a stiffer rod springs back towards its straight rest shape, a crumpled
1e6 rope straightens itself to 75-100 % of its length within 0.4 s, a 1e4 one stays put (< 3 mm).

Particle i lies at x = -length/2 + i * length/(n-1) when straight.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from dopt.tasks.pick.picker import PickerConfig, picker_mjcf
from dopt.tasks.pick.scene import (
    SOLVERS,
    DeformableScene,
    check_pickable,
    floor_scene_xml,
    physics_fields,
    selfcollide_mode,
)
from dopt.validation import check_config

FLEX = "rope"

#: physics presets: name -> the fields that differ from RopeSceneConfig's defaults (which are
#: "default"), chosen by ``python -m planners.bench rope`` (docs/DESIGN-NOTES.md, "Cloth and
#: rope physics"); "accurate" also by ``python -m planners.bench reference``: edges four times
#: quicker to restore their length stretch a twelfth as much under the rope's weight, and
#: Newton converges where CG's 50 iterations stop short on them (catenary sag, cantilever)
PHYSICS_PRESETS: dict[str, dict] = {
    "fast": {"timestep": 0.02},
    "default": {},
    "accurate": {"timestep": 0.005, "edge_solref": (0.001, 1.0), "solver": "Newton"},
}


@dataclass(frozen=True)
class RopeSceneConfig:
    """Rope, material and solver settings.

    Attributes:
        n: particles (N).
        length: rest length (m).
        mass: total mass (kg).
        radius: particle radius (m).
        young, damping: rod elasticity (bending and twist) and its damping (s). Damping 0.1
            keeps the neighbours of a lifted particle from overshooting it: at 1e-3 and dt
            0.02, 289 of 1000 random pick-and-place actions stretch an edge beyond 50 %
            (docs/results/physics-rope.json).
        edge_solref: solref of the inextensibility constraint. In MuJoCo 4.0 this, not
            ``young``, sets how far the edges stretch: the rope hanging under its own weight
            stretches about as the square of the time constant (0.004 s: 2 %, sagging 5 %
            deeper than the inextensible catenary; ``planners.bench.reference``).
        friction: sliding friction with the floor.
        selfcollide: rope-rope contacts: False / True ("none" / "auto") or MuJoCo's
            midphase by name (``SELFCOLLIDE_MODES``).
        timestep, iterations, tolerance: dt (s) and CG settings.
        settle: seconds the rope settles before the initial state.
    """

    n: int = 40
    length: float = 0.5
    mass: float = 0.05
    radius: float = 0.005
    young: float = 1e4
    damping: float = 0.1
    edge_solref: tuple[float, float] = (0.004, 1.0)
    friction: float = 0.8
    selfcollide: bool | str = False
    timestep: float = 0.01
    solver: str = "CG"
    iterations: int = 50
    tolerance: float = 1e-6
    settle: float = 0.4

    def __post_init__(self):
        check_config(self, positive=("length", "mass", "radius", "young", "timestep"),
                     minimum={"n": 3, "damping": 0, "friction": 0, "iterations": 1,
                              "tolerance": 0, "settle": 0},
                     choices={"solver": SOLVERS})
        selfcollide_mode(self.selfcollide, "RopeSceneConfig.selfcollide")
        spacing = self.length / (self.n - 1)
        if spacing < 2 * self.radius * (1 - 1e-9):      # MuJoCo's flexcomp refuses it
            most = int(self.length / (2 * self.radius) * (1 + 1e-9)) + 1
            raise ValueError(f"RopeSceneConfig.n {self.n} puts the particles {spacing:.3g} m "
                             f"apart, closer than their diameter {2 * self.radius:g} m: a "
                             f"{self.length:g} m rope holds at most {most}")

    @classmethod
    def physics(cls, name: str = "default", **fields) -> RopeSceneConfig:
        """A named physics preset (``PHYSICS_PRESETS``) with ``fields`` on top."""
        return replace(cls(**fields), **physics_fields(PHYSICS_PRESETS, name, fields))


def rope_xml(config: RopeSceneConfig = RopeSceneConfig(),
             picker: PickerConfig = PickerConfig(), pickable: Sequence[int] | None = None) -> str:
    """MJCF of the straight rope on a floor with the picker; ``pickable`` particles get a grasp
    equality (None: all N)."""
    if not isinstance(config, RopeSceneConfig):
        raise TypeError(f"config must be a RopeSceneConfig, got {type(config).__name__}")
    pickable = check_pickable(pickable, config.n, picker)
    c = config
    sp = c.length / (c.n - 1)
    fr = f"{c.friction} 0.005 0.0001"
    flexcomp = f"""<flexcomp name="{FLEX}" type="grid" dim="1" count="{c.n} 1 1"
              spacing="{sp} {sp} {sp}"
              pos="0 0 {c.radius + 1e-4}" radius="{c.radius}" mass="{c.mass}"
              rgba=".2 .3 .8 1">
      <contact selfcollide="{selfcollide_mode(c.selfcollide, 'selfcollide')}" friction="{fr}"
               solref="0.01 1" solimp="0.95 0.99 0.0001"/>
      <edge equality="true" solref="{c.edge_solref[0]} {c.edge_solref[1]}"/>
      <elasticity young="{c.young}" damping="{c.damping}"/>
    </flexcomp>"""
    option = (f'solver="{c.solver}" timestep="{c.timestep}" iterations="{c.iterations}" '
              f'tolerance="{c.tolerance}"')
    return floor_scene_xml(f"rope{c.n}", option, 64, f'friction="{fr}"', flexcomp,
                           picker_mjcf(FLEX, pickable, picker, lowest=c.radius))


def make_rope(config: RopeSceneConfig = RopeSceneConfig(),
              picker: PickerConfig = PickerConfig(), pickable: Sequence[int] | None = None,
              positions: np.ndarray | None = None) -> DeformableScene:
    """The rope at rest on the floor: straight, or placed at ``positions`` (N, 3) first (e.g.
    a crumpled shape from ``deformables.goals.rope_crumpled``) and settled."""
    xml = rope_xml(config, picker, pickable)
    return DeformableScene(mujoco.MjModel.from_xml_string(xml), FLEX, picker,
                           settle=config.settle, positions=positions, xml=xml)
