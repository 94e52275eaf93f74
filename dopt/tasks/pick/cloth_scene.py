"""A square cloth (MuJoCo 2D ``flexcomp`` on a particle grid) on a floor, with the picker.

Continuum elasticity ``elastic2d="both"`` under the discrete integrator and the CG solver.
The default sheet (Young's modulus 5e5 Pa at 1 mm, dt 5 ms, an alternating triangulation) is
the cheapest setting of ``python -m planners.bench cloth`` whose random pick-and-place actions
and scripted folds the stability verdict leaves unflagged (docs/DESIGN-NOTES.md, "Cloth and
rope physics").

Vertex i = ix * n + iy (y fastest) sits at x = -side/2 + ix * spacing, y = -side/2 + iy * spacing,
the numbering of ``deformables.goals``.
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

FLEX = "cloth"
#: how each grid square is split (``ClothSceneConfig.triangulation``)
TRIANGULATIONS = ("mujoco", "anti", "alternating")

#: physics presets: name -> the fields that differ from ClothSceneConfig's defaults (which are
#: "default"), chosen by ``python -m planners.bench cloth`` (docs/DESIGN-NOTES.md, "Cloth and
#: rope physics")
PHYSICS_PRESETS: dict[str, dict] = {
    "fast": {"young": 5e4, "timestep": 0.02, "bending": False, "triangulation": "mujoco"},
    "default": {},
    "accurate": {"timestep": 0.0025},
}


@dataclass(frozen=True)
class ClothSceneConfig:
    """Cloth, material and solver settings.

    Attributes:
        n: particles per side (N = n * n).
        side: edge length (m).
        mass: total mass (kg).
        radius: particle radius (m); None: min(4 mm, spacing / 4).
        young, poisson, thickness, damping: continuum elasticity of the sheet.
        bending: the sheet resists bending as well as stretching (``elastic2d="both"``); False:
            stretching only (``"stretch"``), a membrane that costs about half a step at 40 x 40.
        friction: sliding friction (cloth-floor and cloth-cloth).
        cone, impratio: friction cone and the frictional-to-normal impedance ratio. An elliptic
            cone with impratio 10 and friction 1.5 keep the resting half of the cloth in place
            while the other half is dragged over it; with the notes' pyramidal cone and
            friction 0.8 the whole cloth creeps by centimetres during a fold.
        selfcollide: self-collision (needed when layer order matters: multi-layer folds):
            False / True ("none" / "auto", which is sap for a sheet) or MuJoCo's midphase by
            name ("bvh", "sap", "narrow"; ``SELFCOLLIDE_MODES``).
        passive: MuJoCo 4.0's passive flex contact (``<contact passive="true">``): contacts
            with the sheet itself and with static geometry (the floor) leave the constraint
            solver and become a frictionless penalty force; contacts with the picker stay.
        triangulation: how each grid square is split into two triangles, with the names of
            ``deformables.goals.grid_faces``: "mujoco" along (ix, iy)-(ix+1, iy+1) (MuJoCo's
            own grid), "anti" along the other diagonal, "alternating" the two in a
            checkerboard. Linear triangles lock: a crease across their diagonals must stretch
            them, so on "mujoco" a stiff sheet folds badly along x = -y (the diagonal goal).
        timestep: dt (s); plan and evaluate with the same dt (folds depend on it).
        iterations, tolerance: CG solver settings (20-30 iterations; 10 breaks fold symmetry).
        settle: seconds the flat cloth settles before the initial state.
    """

    n: int = 16
    side: float = 0.3
    mass: float = 0.1
    radius: float | None = None
    young: float = 5e5
    poisson: float = 0.2
    thickness: float = 1e-3
    damping: float = 1e-3
    bending: bool = True
    friction: float = 1.5
    cone: str = "elliptic"
    impratio: float = 10.0
    selfcollide: bool | str = False
    passive: bool = False
    triangulation: str = "alternating"
    timestep: float = 0.005
    solver: str = "CG"
    iterations: int = 30
    tolerance: float = 1e-6
    settle: float = 0.2

    def __post_init__(self):
        check_config(self, positive=("side", "mass", "radius", "young", "thickness", "impratio",
                                     "timestep"),
                     minimum={"n": 2, "poisson": 0, "damping": 0, "friction": 0,
                              "iterations": 1, "tolerance": 0, "settle": 0},
                     choices={"cone": ("elliptic", "pyramidal"), "solver": SOLVERS,
                              "triangulation": TRIANGULATIONS})
        selfcollide_mode(self.selfcollide, "ClothSceneConfig.selfcollide")
        if not self.poisson < 0.5:
            raise ValueError(f"ClothSceneConfig.poisson must be < 0.5, got {self.poisson!r}")

    @classmethod
    def physics(cls, name: str = "default", **fields) -> ClothSceneConfig:
        """A named physics preset (``PHYSICS_PRESETS``) with ``fields`` on top."""
        return replace(cls(**fields), **physics_fields(PHYSICS_PRESETS, name, fields))

    @property
    def spacing(self) -> float:
        return self.side / (self.n - 1)

    @property
    def particle_radius(self) -> float:
        return min(0.004, self.spacing / 4) if self.radius is None else float(self.radius)


def cloth_xml(config: ClothSceneConfig = ClothSceneConfig(),
              picker: PickerConfig = PickerConfig(), pickable: Sequence[int] | None = None) -> str:
    """MJCF of the cloth on a floor with the picker; ``pickable`` particles get a grasp
    equality (None: all N)."""
    if not isinstance(config, ClothSceneConfig):
        raise TypeError(f"config must be a ClothSceneConfig, got {type(config).__name__}")
    ids = check_pickable(pickable, config.n * config.n, picker)
    c = config
    n, sp, r = c.n, c.spacing, c.particle_radius
    fr = f"{c.friction} 0.005 0.0001"
    flexcomp = f"""<flexcomp name="{FLEX}" type="direct" dim="2"
              point="{_grid_points(n, sp)}" element="{_grid_triangles(n, c.triangulation)}"
              pos="0 0 {r + 1e-4}" radius="{r}" mass="{c.mass}" rgba=".8 .3 .2 1">
      <contact selfcollide="{selfcollide_mode(c.selfcollide, 'selfcollide')}" condim="3"
               friction="{fr}"{' passive="true"' if c.passive else ''}
               solref="0.01 1" solimp="0.95 0.99 0.0001"/>
      <elasticity young="{c.young}" poisson="{c.poisson}" thickness="{c.thickness}"
                  elastic2d="{'both' if c.bending else 'stretch'}" damping="{c.damping}"/>
    </flexcomp>"""
    option = (f'solver="{c.solver}" timestep="{c.timestep}" iterations="{c.iterations}" '
              f'tolerance="{c.tolerance}" cone="{c.cone}" impratio="{c.impratio}"')
    return floor_scene_xml(f"cloth{n}", option, max(64, n * n // 2),
                           f'condim="3" friction="{fr}"', flexcomp,
                           picker_mjcf(FLEX, ids, picker, lowest=r))


def _grid_points(n: int, spacing: float) -> str:
    """The flexcomp ``point`` list of the n x n grid centred on the origin, vertex ix * n + iy
    (MuJoCo's grid numbering and placement)."""
    ix, iy = np.divmod(np.arange(n * n), n)
    xyz = np.stack([(ix - (n - 1) / 2) * spacing, (iy - (n - 1) / 2) * spacing,
                    np.zeros(n * n)], axis=1)
    return " ".join(f"{v:.9g}" for v in xyz.ravel())


def _grid_triangles(n: int, triangulation: str) -> str:
    """The flexcomp ``element`` list: two counter-clockwise triangles per grid square, split
    as ``triangulation`` names (``TRIANGULATIONS``; the faces of
    ``deformables.goals.grid_faces``, which dopt does not import; tested equal)."""
    ix, iy = (a.ravel() for a in np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij"))
    a, b, c, d = ix * n + iy, (ix + 1) * n + iy, ix * n + iy + 1, (ix + 1) * n + iy + 1
    along_main = np.stack([a, b, d, a, d, c], axis=1)       # split a-d
    along_anti = np.stack([a, b, c, b, d, c], axis=1)       # split b-c
    main = {"mujoco": np.ones_like(a, bool), "anti": np.zeros_like(a, bool),
            "alternating": (ix + iy) % 2 == 0}[triangulation]
    return " ".join(map(str, np.where(main[:, None], along_main, along_anti).ravel()))


def make_cloth(config: ClothSceneConfig = ClothSceneConfig(),
               picker: PickerConfig = PickerConfig(),
               pickable: Sequence[int] | None = None) -> DeformableScene:
    """The flat cloth at rest on the floor, with the picker above it."""
    xml = cloth_xml(config, picker, pickable)
    return DeformableScene(mujoco.MjModel.from_xml_string(xml), FLEX, picker,
                           settle=config.settle, xml=xml)
