"""dopt.render: the fitted camera frames every point, projection agrees with what OpenGL draws,
markers land where the points project, and segmentation masks. The rendering tests skip where no
offscreen OpenGL is available. (The replay of a plan is the pick wing's:
tests/dopt/tasks/pick/test_replay.py.)"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco's first import, where it is the first

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from dopt import render  # noqa: E402
from dopt.tasks.pick.cloth_scene import ClothSceneConfig, make_cloth  # noqa: E402

W, H = 320, 240


@pytest.fixture(scope="module")
def cloth():
    return make_cloth(ClothSceneConfig(n=6))


@pytest.fixture(scope="module")
def gl(cloth):
    """Skip when this machine cannot render offscreen."""
    try:
        with mujoco.Renderer(cloth.model, 8, 8) as r:
            r.render()
    except Exception as e:  # no EGL / OSMesa
        pytest.skip(f"no offscreen OpenGL ({type(e).__name__}: {e})")


def _fovy(scene):
    return scene.model.vis.global_.fovy


# ------------------------------------------------------------------------------ no OpenGL
def test_projection_geometry():
    cam = render.fit_camera(np.array([[0.0, 0.0, 0.0], [0.2, 0.1, 0.0]]), *render.TOP)
    centre = render.project(np.asarray(cam.lookat), cam, W, H)
    np.testing.assert_allclose(centre, [W / 2, H / 2], atol=1e-9)
    # from above x grows to the right and y upwards (rows grow downwards)
    right, up = render.project(np.asarray(cam.lookat) + [[0.05, 0, 0], [0, 0.05, 0]], cam, W, H)
    assert right[0] > W / 2 and abs(right[1] - H / 2) < 1e-6
    assert up[1] < H / 2 and abs(up[0] - W / 2) < 1e-6
    behind = np.asarray(cam.lookat) + [0, 0, 2 * cam.distance]
    assert np.all(np.isnan(render.project(behind, cam, W, H)))


@pytest.mark.parametrize("view", [render.TOP, render.OBLIQUE, (30.0, -20.0)])
def test_fitted_camera_frames_and_fills(view):
    rng = np.random.default_rng(0)
    points = rng.uniform([-0.3, -0.1, 0.0], [0.2, 0.4, 0.1], size=(50, 3))
    cam = render.fit_camera(points, *view, aspect=W / H, fill=0.8)
    px = render.project(points, cam, W, H)
    assert np.all(px >= 0) and np.all(px[:, 0] < W) and np.all(px[:, 1] < H)
    span = (px.max(axis=0) - px.min(axis=0)) / [W, H]
    assert span.max() > 0.75                         # fills the frame along one axis
    mid = (px.max(axis=0) + px.min(axis=0)) / 2      # and is centred
    np.testing.assert_allclose(mid, [W / 2, H / 2], atol=2.0)


def test_fit_camera_rejects_bad_points():
    with pytest.raises(ValueError):
        render.fit_camera(np.zeros((0, 3)))
    with pytest.raises(ValueError):
        render.fit_camera(np.array([[0.0, np.nan, 0.0]]))


def test_markers_and_outline():
    img = np.zeros((40, 60, 3), dtype=np.uint8)
    out = render.draw_markers(img, np.array([[20.0, 10.0], [np.nan, 5.0]]), (255, 0, 0), 5)
    assert tuple(out[10, 20]) == (255, 0, 0) and not img.any()     # a copy, the input kept
    assert not out[30:, 40:].any()
    ring = render.draw_markers(img, np.array([[30.0, 20.0]]), (0, 255, 0), 8, "ring")
    assert not ring[20, 30].any() and ring[20, 30 + 6].any()        # hollow
    line = render.draw_segments(img, np.array([[5.0, 5.0]]), np.array([[50.0, 5.0]]),
                                (9, 9, 9))
    assert (line[5, 5:51] == 9).all() and not line[20].any()
    mask = np.zeros((10, 10), dtype=bool)
    mask[2:8, 2:8] = True
    edge = render.mask_outline(mask, 1)
    assert edge[2, 5] and edge[7, 5] and not edge[5, 5] and edge.sum() == 20


# --------------------------------------------------------------------------- with OpenGL
@pytest.mark.parametrize("view", [render.TOP, render.OBLIQUE])
def test_fitted_camera_sees_every_particle(cloth, gl, view):
    state = cloth.initial_state
    p = cloth.positions(state)
    cam = render.fit_camera(p, *view, fovy=_fovy(cloth), aspect=W / H)
    px = render.project(p, cam, W, H, _fovy(cloth))
    assert np.all(px >= 0) and np.all(px[:, 0] < W) and np.all(px[:, 1] < H)
    picker = mujoco.mj_name2id(cloth.model, mujoco.mjtObj.mjOBJ_GEOM, "picker")
    seg = render.render(cloth.model, state, cloth.scene.layout.spec, cam, W, H,
                        hide_geoms=[picker], segmentation=True)
    mask = render.object_mask(seg)
    # the projection agrees with OpenGL: each inner particle lands on a cloth pixel (pixel i
    # covers [i, i + 1)), each edge particle within a pixel of one
    n = 6
    i, j = np.divmod(np.arange(n * n), n)
    inner = (i > 0) & (i < n - 1) & (j > 0) & (j < n - 1)
    cr = np.floor(px[inner]).astype(int)
    assert mask[cr[:, 1], cr[:, 0]].all()
    rows, cols = np.nonzero(mask)
    gap = [np.hypot(cols + 0.5 - c, rows + 0.5 - r).min() for c, r in px[~inner]]
    assert max(gap) <= 1.5
    assert mask.mean() > 0.3                                         # the cloth fills it


def test_marker_lands_on_its_particle(cloth, gl):
    state = cloth.initial_state
    p = cloth.positions(state)
    cam = render.fit_camera(p, *render.OBLIQUE, fovy=_fovy(cloth), aspect=W / H)
    img = render.render(cloth.model, state, cloth.scene.layout.spec, cam, W, H)
    assert img.shape == (H, W, 3) and img.dtype == np.uint8 and img.std() > 5
    px = render.project(p[[7]], cam, W, H, _fovy(cloth))
    marked = render.draw_markers(img, px, (0, 255, 255), 5)
    c, r = np.floor(px[0]).astype(int)
    assert tuple(marked[r, c]) == (0, 255, 255) != tuple(img[r, c])
    changed = np.argwhere(np.any(marked != img, axis=-1))
    assert np.abs(changed - [r, c]).max() <= 6                       # nowhere else


def test_render_options_leave_the_model_alone(cloth, gl):
    m = cloth.model
    picker = m.geom("picker").id
    before = (m.vis.quality.shadowsize, m.geom_rgba.copy(), m.light_specular.copy())
    cam = render.fit_camera(cloth.positions(cloth.initial_state), *render.TOP,
                            fovy=_fovy(cloth), aspect=W / H)
    shown = render.render(m, cloth.initial_state, cloth.scene.layout.spec, cam, W, H)
    hidden = render.render(m, cloth.initial_state, cloth.scene.layout.spec, cam, W, H,
                           hide_geoms=[picker], geom_alpha={m.geom("floor").id: 0.5})
    assert np.any(shown != hidden)
    assert m.vis.quality.shadowsize == before[0]
    np.testing.assert_array_equal(m.geom_rgba, before[1])
    np.testing.assert_array_equal(m.light_specular, before[2])
    with pytest.raises(ValueError, match="offscreen buffer"):
        render.render(m, cloth.initial_state, cloth.scene.layout.spec, cam,
                      m.vis.global_.offwidth + 1, 10)
