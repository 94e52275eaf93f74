"""Named DoF groups and index maps."""

import mujoco
import numpy as np
import pytest

from dopt.scene import Scene

FLEX = """<mujoco><option integrator="discrete"/><worldbody><geom type="plane" size="1 1 .1"/>
  <flexcomp name="rope" type="grid" dim="1" count="5 1 1" spacing=".05 .05 .05" radius=".01"
            pos="0 0 .1"/>
  <body name="block" pos=".5 0 .1"><joint name="bx" type="slide" axis="1 0 0"/>
    <geom type="box" size=".02 .02 .02"/></body>
</worldbody></mujoco>"""


def test_mixed_groups(scene):
    g = scene.groups
    assert g["robot"].tolist() == [0, 1, 2, 3, 4]           # slide, hinge, ball (3)
    assert g["object:box"].tolist() == list(range(5, 11))   # free joint: 6 DoFs
    assert g["joint:ball"].tolist() == [2, 3, 4]
    assert scene.dofs().tolist() == list(range(scene.nv))
    assert scene.dofs("joint:hinge", "object:box").tolist() == [1] + list(range(5, 11))
    np.testing.assert_array_equal(scene.tangent_indices([1, 6]), [1, 6, 1 + 17, 6 + 17])


def test_qpos_indices(scene):
    m = scene.model
    box = m.jnt_qposadr[m.joint("box_free").id]
    assert scene.qpos_indices("object:box").tolist() == list(range(box, box + 7))
    # one rotational DoF of a free joint moves its whole quaternion
    assert scene.qpos_indices([8]).tolist() == list(range(box + 3, box + 7))
    assert scene.qpos_indices("joint:ball").tolist() == [2, 3, 4, 5]


def test_flex_vertex_groups():
    sc = Scene.from_xml(FLEX)
    m = sc.model
    verts = [k for k in sc.groups if k.startswith("vertex:")]
    assert len(verts) == m.flex_vertnum[0] == 5
    for k in verts:
        v = int(k.split(":")[1])
        body = m.flex_vertbodyid[v]
        assert sc.groups[k].tolist() == list(range(m.body_dofadr[body],
                                                   m.body_dofadr[body] + m.body_dofnum[body]))
    assert len(sc.groups["flex:rope"]) == sum(len(sc.groups[k]) for k in verts)
    assert sc.groups["object:block"].tolist() == sc.groups["joint:bx"].tolist()


def test_unknown_and_bad_dofs(scene):
    with pytest.raises(ValueError, match="did you mean"):
        scene.dofs("object:bx")
    with pytest.raises(ValueError, match="empty"):
        scene.as_dofs([])
    with pytest.raises(ValueError, match="out of range"):
        scene.as_dofs([-1])
    with pytest.raises(TypeError, match="MjModel"):
        Scene("not a model")
    custom = Scene(scene.model, groups={"pair": [6, 5]})
    assert custom.dofs("pair").tolist() == [5, 6]
    assert isinstance(custom.model, mujoco.MjModel)
