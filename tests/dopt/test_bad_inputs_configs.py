"""Every config dataclass of dopt type-checks its fields and rejects bad values with a clear
error naming the field."""
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco's first import (dopt.render)

import dataclasses  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from dopt.mpc import MPCConfig  # noqa: E402
from dopt.rollout import FDConfig, RolloutConfig  # noqa: E402
from dopt.tasks.pick.cloth_scene import ClothSceneConfig  # noqa: E402
from dopt.tasks.pick.picker import PickerConfig  # noqa: E402
from dopt.tasks.pick.rope_scene import RopeSceneConfig  # noqa: E402
from dopt.tasks.push.costs import PushWeights  # noqa: E402

# ====================================================================== config dataclasses
CONFIGS = [(RolloutConfig, {}), (FDConfig, {}), (MPCConfig, {"timeout": 5}), (PickerConfig, {}),
           (RopeSceneConfig, {}), (ClothSceneConfig, {}), (PushWeights, {})]


@pytest.mark.parametrize("cls, required", CONFIGS, ids=[c.__name__ for c, _ in CONFIGS])
def test_every_config_field_is_type_checked(cls, required):
    cls(**required)
    for f in dataclasses.fields(cls):
        with pytest.raises(TypeError, match=rf"{cls.__name__}\.{f.name}\b"):
            cls(**{**required, f.name: object()})


@pytest.mark.parametrize("make, exc, match", [
    (lambda: FDConfig(centered="no"), TypeError, r"FDConfig\.centered must be a bool"),
    (lambda: FDConfig(centered=1), TypeError, r"FDConfig\.centered"),
    (lambda: FDConfig(eps=np.nan), ValueError, r"FDConfig\.eps must be finite"),
    (lambda: FDConfig(eps=0.0), ValueError, r"FDConfig\.eps must be > 0"),
    (lambda: FDConfig(eps="1e-3"), TypeError, r"FDConfig\.eps"),
    (lambda: FDConfig(eps=True), TypeError, r"FDConfig\.eps"),
    (lambda: RolloutConfig(threads=2.0), TypeError, r"RolloutConfig\.threads must be an int"),
    (lambda: RolloutConfig(threads=True), TypeError, r"RolloutConfig\.threads"),
    (lambda: RolloutConfig(threads=-1), ValueError, r"RolloutConfig\.threads must be >= 0"),
    (lambda: RolloutConfig(c_kernels="yes"), TypeError, r"RolloutConfig\.c_kernels"),
    (lambda: MPCConfig(timeout=10.5), TypeError, r"MPCConfig\.timeout"),
    (lambda: MPCConfig(timeout=0), ValueError, r"MPCConfig\.timeout must be >= 1"),
    (lambda: MPCConfig(timeout=5, slowdown=np.inf), ValueError, r"MPCConfig\.slowdown"),
    (lambda: MPCConfig(timeout=5, slowdown=0), ValueError, r"MPCConfig\.slowdown must be > 0"),
    (lambda: MPCConfig(timeout=5, synchronous="no"), TypeError, r"MPCConfig\.synchronous"),
    (lambda: MPCConfig(timeout=5, feedback=0), TypeError, r"MPCConfig\.feedback"),
    (lambda: MPCConfig(timeout=5, control_noise=-0.1), ValueError, r"MPCConfig\.control_noise"),
    (lambda: MPCConfig(timeout=5, steps_per_plan=0), ValueError, r"MPCConfig\.steps_per_plan"),
    (lambda: MPCConfig(timeout=5, warmup=1.0), TypeError, r"MPCConfig\.warmup"),
    (lambda: PickerConfig(bound=(0.1, 0.1)), ValueError, r"PickerConfig\.bound must have 3"),
    (lambda: PickerConfig(bound=(0.1, np.nan, 0.1)), ValueError, r"PickerConfig\.bound\[1\]"),
    (lambda: PickerConfig(bound=(0.1, 0.0, 0.1)), ValueError, r"PickerConfig\.bound must be > 0"),
    (lambda: PickerConfig(bound=0.1), TypeError, r"PickerConfig\.bound must be a tuple"),
    (lambda: PickerConfig(speed="fast"), TypeError, r"PickerConfig\.speed"),
    (lambda: PickerConfig(snap=0.0), ValueError, r"PickerConfig\.snap"),
    (lambda: PickerConfig(hold_steps=-1), ValueError, r"PickerConfig\.hold_steps"),
    (lambda: PickerConfig(mass=0), ValueError, r"PickerConfig\.mass"),
    (lambda: PickerConfig(solref=(0.002,)), ValueError, r"PickerConfig\.solref"),
    (lambda: PickerConfig(start=(0, 0, np.inf)), ValueError, r"PickerConfig\.start\[2\]"),
    (lambda: RopeSceneConfig(n=40.0), TypeError, r"RopeSceneConfig\.n must be an int"),
    (lambda: RopeSceneConfig(n=2), ValueError, r"RopeSceneConfig\.n must be >= 3"),
    (lambda: RopeSceneConfig(selfcollide="no"), ValueError,
     r"RopeSceneConfig\.selfcollide must be a bool or one of"),
    (lambda: RopeSceneConfig(iterations=0), ValueError, r"RopeSceneConfig\.iterations"),
    (lambda: RopeSceneConfig(tolerance=np.nan), ValueError, r"RopeSceneConfig\.tolerance"),
    (lambda: RopeSceneConfig(settle=-1.0), ValueError, r"RopeSceneConfig\.settle"),
    (lambda: RopeSceneConfig(edge_solref=(0.004,)), ValueError, r"RopeSceneConfig\.edge_solref"),
    (lambda: ClothSceneConfig(n=True), TypeError, r"ClothSceneConfig\.n"),
    (lambda: ClothSceneConfig(n=1), ValueError, r"ClothSceneConfig\.n must be >= 2"),
    (lambda: ClothSceneConfig(radius=np.nan), ValueError, r"ClothSceneConfig\.radius"),
    (lambda: ClothSceneConfig(cone="round"), ValueError, r"ClothSceneConfig\.cone must be one"),
    (lambda: ClothSceneConfig(selfcollide=0), TypeError, r"ClothSceneConfig\.selfcollide"),
    (lambda: ClothSceneConfig(poisson=0.5), ValueError, r"ClothSceneConfig\.poisson"),
    (lambda: ClothSceneConfig(friction=-1.0), ValueError, r"ClothSceneConfig\.friction"),
    (lambda: PushWeights(goal=np.nan), ValueError, r"PushWeights\.goal must be finite"),
    (lambda: PushWeights(goal=-1.0), ValueError, r"PushWeights\.goal must be >= 0"),
    (lambda: PushWeights(ee="10"), TypeError, r"PushWeights\.ee\b"),
    (lambda: PushWeights(success_radius=0.0), ValueError, r"PushWeights\.success_radius"),
], ids=lambda v: "" if callable(v) or isinstance(v, type) else v)
def test_bad_config_values(make, exc, match):
    with pytest.raises(exc, match=match):
        make()


def test_good_config_values_pass():
    """numpy scalars for numbers, lists or arrays for tuples (a config read back from JSON),
    ints for floats and None where allowed."""
    PickerConfig(bound=[0.1, 0.1, 0.1], speed=np.float32(0.5), snap=np.float32(0.06), kv=1000)
    ClothSceneConfig(n=np.int32(4), radius=None, selfcollide=np.bool_(True))
    MPCConfig(timeout=np.int64(3), slowdown=2)
    FDConfig(eps=1e-6, centered=True)


