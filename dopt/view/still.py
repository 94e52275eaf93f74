"""A still of an episode's frame with MuJoCo's offscreen renderer: the same view the browser
shows (shaded objects, the marked body red, the goal ghost as translucent dots, the markers
drawn on the image as ``dopt.render`` draws them; a goal region is the model's own site, which
MuJoCo draws), as an (H, W, 3) uint8 image or a PNG.

Needs an offscreen OpenGL context: ``MUJOCO_GL=egl`` (or osmesa) before MuJoCo is imported.
Shapes: H, W image size, M markers, V ghost vertices.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from dopt import atomic
from dopt.render import OBLIQUE, draw_markers, fit_camera, project
from dopt.validation import check_int
from dopt.view.episode import Episode, drawable_state
from dopt.view.mjscene import MARK_COLOUR, flex_vertices, geom_rgba, shade_colour


def frame_image(ep: Episode, frame: int, width: int = 800, height: int = 600,
                view: tuple[float, float] = OBLIQUE) -> np.ndarray:
    """Frame ``frame`` of ``ep`` as an (H, W, 3) uint8 image from a free camera at
    ``view`` (azimuth, elevation in degrees) fitted to the moving objects.

    Raises:
        ValueError: a frame outside the episode, a size below 1.
    """
    if not isinstance(ep, Episode):
        raise TypeError(f"ep must be a dopt.view.episode.Episode, got {type(ep).__name__}")
    frame = check_int(frame, "frame")
    if not 0 <= frame < ep.n_frames:
        raise ValueError(f"frame {frame} is outside the episode's {ep.n_frames} frames "
                         f"(0..{ep.n_frames - 1})")
    width, height = check_int(width, "width", 1), check_int(height, "height", 1)
    m = ep.model
    g = m.vis.global_
    g.offwidth, g.offheight = max(g.offwidth, width), max(g.offheight, height)
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, drawable_state(ep.states, frame), ep.spec)
    mujoco.mj_forward(m, d)
    points = _framed_points(m, d)
    cam = fit_camera(points, *view, fovy=float(g.fovy), aspect=width / height, fill=0.8)
    with mujoco.Renderer(m, height, width) as renderer:
        renderer.update_scene(d, cam)
        scn = renderer.scene
        _recolour(scn, ep, frame)
        if ep.ghost is not None and int(ep.ghost.which[frame]) >= 0:
            _add_dots(scn, ep.ghost.shapes[int(ep.ghost.which[frame])], ep.ghost.colour,
                      ep.ghost.opacity, 0.0025)
        image = renderer.render()
    for mk in ep.markers:
        pts = np.asarray(mk.positions[frame], dtype=float)
        pts = pts[np.isfinite(pts).all(axis=1)]
        if len(pts):
            px = project(pts, cam, width, height, float(g.fovy))
            image = draw_markers(image, px, mk.colour, radius=5.0)
    if ep.marked_body is not None:
        px = project(d.xpos[ep.marked_body][None], cam, width, height, float(g.fovy))
        image = draw_markers(image, px, MARK_COLOUR, radius=14.0, style="ring")
    return image


def write_png(ep: Episode, frame: int, path, width: int = 800, height: int = 600) -> Path:
    """``frame_image`` written as a PNG at ``path`` (its folder created; atomically,
    ``dopt.atomic``); returns the path."""
    from PIL import Image

    image = frame_image(ep, frame, width, height)
    path = Path(path)
    with atomic.writing(path) as tmp:
        Image.fromarray(image).save(tmp)
    return path


def _framed_points(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    """World points the camera frames: flex vertices and the bodies that move (not the
    world's floor)."""
    pts = [flex_vertices(m, d, f) for f in range(m.nflex)]
    moving = [b for b in range(1, m.nbody) if m.body_weldid[b] != 0 and m.body_geomnum[b]]
    if moving:
        pts.append(np.asarray(d.xpos[moving]))
    return np.concatenate(pts) if pts else np.zeros((1, 3))


def _recolour(scn: mujoco.MjvScene, ep: Episode, frame: int) -> None:
    """Shade geoms and flexes of the built scene as the browser does; the marked body red."""
    m = ep.model
    shade = None if ep.shade is None else ep.shade[frame]
    for i in range(scn.ngeom):
        geom = scn.geoms[i]
        if geom.objtype == mujoco.mjtObj.mjOBJ_GEOM:
            body = int(m.geom_bodyid[geom.objid])
            if ep.marked_body is not None and body == ep.marked_body:
                geom.rgba[:3] = np.array(MARK_COLOUR) / 255
            elif shade is not None and np.isfinite(shade[body]):
                own = np.round(255 * geom_rgba(m, geom.objid)[:3])
                geom.rgba[:3] = np.array(shade_colour(shade[body], own)) / 255
        elif geom.objtype == mujoco.mjtObj.mjOBJ_FLEX and shade is not None:
            f = geom.objid
            a, n = int(m.flex_vertadr[f]), int(m.flex_vertnum[f])
            values = shade[m.flex_vertbodyid[a:a + n]]
            values = values[np.isfinite(values)]
            if len(values):
                geom.rgba[:3] = np.array(shade_colour(values.mean(), np.zeros(3))) / 255


def _add_dots(scn: mujoco.MjvScene, points: np.ndarray, colour, opacity: float,
              radius: float) -> None:
    rgba = np.array([*np.asarray(colour) / 255, opacity], dtype=np.float32)
    for p in points[: max(scn.maxgeom - scn.ngeom, 0)]:
        _user_geom(scn, mujoco.mjtGeom.mjGEOM_SPHERE, [radius] * 3, p, rgba)


def _user_geom(scn: mujoco.MjvScene, kind, size, pos, rgba) -> None:
    if scn.ngeom >= scn.maxgeom:
        return
    mujoco.mjv_initGeom(scn.geoms[scn.ngeom], kind, np.asarray(size, float),
                        np.asarray(pos, float), np.eye(3).ravel(), rgba)
    scn.ngeom += 1
