"""Small MJCF models shared by the dopt tests."""

# free, ball, hinge and slide joints, contacts with the floor and between bodies, motors with
# limited ctrl (one control sits at its limit in the tests) and one unlimited
MIXED_JOINTS = """
<mujoco>
  <option timestep="0.005"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 .1"/>
    <body name="arm" pos="0 0 .4">
      <joint name="slide" type="slide" axis="1 0 0" damping=".5"/>
      <geom type="box" size=".05 .05 .05" mass="1"/>
      <body name="link" pos="0 0 -.1">
        <joint name="hinge" type="hinge" axis="0 1 0" damping=".1"/>
        <geom type="capsule" fromto="0 0 0 0 0 -.2" size=".03" mass=".3"/>
        <body name="wrist" pos="0 0 -.22">
          <joint name="ball" type="ball" damping=".05"/>
          <geom type="capsule" fromto="0 0 0 .1 0 -.05" size=".02" mass=".1"/>
        </body>
      </body>
    </body>
    <body name="box" pos=".15 0 .041">
      <freejoint name="box_free"/>
      <geom type="box" size=".04 .04 .04" mass=".2"/>
    </body>
    <body name="ball_obj" pos="-.2 .1 .031">
      <freejoint/>
      <geom type="sphere" size=".03" mass=".1"/>
    </body>
  </worldbody>
  <actuator>
    <motor joint="slide" ctrlrange="-5 5" ctrllimited="true"/>
    <motor joint="hinge" ctrlrange="-1 1" ctrllimited="true"/>
    <motor joint="ball" gear="0 1 0" ctrllimited="false"/>
  </actuator>
</mujoco>
"""

# two boxes stacked on the floor in a 3 KB arena: their contacts overflow it (mju_error,
# "out of memory"); lifted apart, they fit
TINY_ARENA = """<mujoco><size memory="3K"/><worldbody><geom type="plane" size="1 1 .1"/>
<body pos="0 0 .05"><freejoint/><geom type="box" size=".05 .05 .05"/></body>
<body pos="0 0 .16"><freejoint/><geom type="box" size=".05 .05 .05"/></body></worldbody></mujoco>"""


def moving_state(scene):
    """An mjSTATE_INTEGRATION row (ns,) of ``scene`` (MIXED_JOINTS) in motion, with contacts:
    random velocities, then 40 steps of random controls (seeded)."""
    import mujoco
    import numpy as np

    m = scene.model
    d = mujoco.MjData(m)
    rng = np.random.default_rng(3)
    d.qvel[:] = rng.normal(0, 0.3, m.nv)
    for _ in range(40):
        d.ctrl[:] = rng.uniform(-1, 1, m.nu)
        mujoco.mj_step(m, d)
    assert d.ncon > 0
    return scene.state_of(d)

# TINY_ARENA's boxes apart (one 1 cm above the floor) in a 10 KB arena, and a mocap box: set
# onto the low box (mocap_pos 0 0 .1), the contacts overflow the arena in PrimalAllocate
# (mju_error) on the step it moves
MOCAP_ARENA = """<mujoco><size memory="10K"/><worldbody><geom type="plane" size="1 1 .1"/>
<body pos="0 0 .06"><freejoint/><geom type="box" size=".05 .05 .05"/></body>
<body pos="0 0 2"><freejoint/><geom type="box" size=".05 .05 .05"/></body>
<body mocap="true" pos="3 0 1"><geom type="box" size=".05 .05 .05"/></body></worldbody></mujoco>"""

# A box on a slide joint, position-actuated, 10 cm beside a free box, no gravity, in a 9 KB
# arena: held at ctrl 0 it fits; driven to ctrl -0.2 (onto the free box) the contacts overflow
# the arena in PrimalAllocate (mju_error) at step 37
ACTUATED_ARENA = """<mujoco><size memory="9K"/><option gravity="0 0 0"/><worldbody>
<geom type="plane" size="1 1 .1"/>
<body pos="0 0 .06"><freejoint/><geom type="box" size=".05 .05 .05"/></body>
<body pos=".2 0 .06"><joint name="x" type="slide" axis="1 0 0"/>
<geom type="box" size=".05 .05 .05"/></body></worldbody>
<actuator><position joint="x" kp="200" ctrlrange="-1 1"/></actuator></mujoco>"""

#: two sliders in a row, the first actuated, no gravity: a scene whose rest is exact
SLIDER = """<mujoco><option timestep="0.005" gravity="0 0 0"/><worldbody>
  <body name="a"><joint name="ax" type="slide" axis="1 0 0" damping=".5"/>
  <geom size=".05" mass="1"/></body>
  <body name="b" pos=".11 0 0"><joint name="bx" type="slide" axis="1 0 0" damping=".5"/>
  <geom size=".05" mass=".5"/></body></worldbody>
  <actuator><motor joint="ax" ctrlrange="-100000 100000" ctrllimited="true"/></actuator>
</mujoco>"""
