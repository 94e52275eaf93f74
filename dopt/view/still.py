"""A still of an episode's frame with MuJoCo's offscreen renderer: the same view the browser
shows (shaded objects, the marked body red, the goal ghost as translucent dots, the markers
drawn on the image as ``dopt.render`` draws them, a scale bar on the floor; a goal region is
the model's own site, which MuJoCo draws), as an (H, W, 3) uint8 image; ``write_png`` adds
below it the episode's name, the frame's caption and the legend (``dopt.view.legend``).

Needs an offscreen OpenGL context: ``MUJOCO_GL=egl`` (or osmesa) before MuJoCo is imported.
Shapes: H, W image size, M markers, V ghost vertices.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from dopt import atomic
from dopt.render import OBLIQUE, draw_markers, draw_segments, fit_camera, project
from dopt.validation import check_int
from dopt.view.episode import Episode, drawable_state
from dopt.view.legend import (
    BAR_COLOUR,
    LegendItem,
    floor_height,
    floor_items,
    legend_items,
    length_text,
    nice_length,
)
from dopt.view.mjscene import MARK_COLOUR, flex_vertices, geom_rgba, shade_colour

#: the fonts tried for the caption, then PIL's own
FONTS = ("DejaVuSans.ttf", "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf")


def frame_image(ep: Episode, frame: int, width: int = 800, height: int = 600,
                view: tuple[float, float] = OBLIQUE) -> np.ndarray:
    """Frame ``frame`` of ``ep`` as an (H, W, 3) uint8 image from a free camera at
    ``view`` (azimuth, elevation in degrees) fitted to the moving objects, with a scale bar
    of ``scale_bar(ep, frame)[0]`` m on the floor at their near edge.

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
    d, points = _posed(ep, frame)
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
    length, ends = scale_bar(m, points)
    px = project(ends, cam, width, height, float(g.fovy))
    return _label_bar(draw_segments(image, px[:1], px[1:], BAR_COLOUR, width=4),
                      px, length_text(length))


def scale_bar(model: mujoco.MjModel, points: np.ndarray) -> tuple[float, np.ndarray]:
    """A scale bar for the scene points (P, 3): its length (m, ``nice_length`` of their
    extent) and its ends (2, 3) on the floor (``floor_height``), along x, in front of their
    lowest y."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    length = nice_length(float(np.max(hi[:2] - lo[:2])))
    start = np.array([lo[0], lo[1] - 0.6 * length, floor_height(model, points) + 1e-3])
    return length, np.stack([start, start + [length, 0.0, 0.0]])


def _label_bar(image: np.ndarray, px: np.ndarray, text: str) -> np.ndarray:
    from PIL import Image, ImageDraw

    if not np.isfinite(px).all():
        return image
    out = Image.fromarray(image)
    centre = px.mean(axis=0)
    ImageDraw.Draw(out).text((float(centre[0]), float(centre[1]) + 6), text,
                             fill=BAR_COLOUR, font=font(13), anchor="mt")
    return np.asarray(out)


def annotate(image: np.ndarray, lines, items) -> np.ndarray:
    """``image`` (H, W, 3) with a white band below it: ``lines`` of text (wrapped to the
    width), then the legend ``items`` (``LegendItem``), a swatch and a name each, in
    columns. Returns (H + h, W, 3) uint8."""
    from PIL import Image, ImageDraw

    H, W = image.shape[:2]
    face, pad, row = font(13), 8, 18
    draw = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    wrapped = [w for line in lines for w in _wrap(draw, line, face, W - 2 * pad)]
    widths = [26 + draw.textlength(i.name, font=face) for i in items]
    col = int(max(widths, default=0)) + 16
    per_row = max(1, (W - 2 * pad) // max(col, 1))
    n_rows = -(-len(items) // per_row)
    out = Image.new("RGB", (W, H + pad * 2 + row * (len(wrapped) + n_rows)), "white")
    out.paste(Image.fromarray(image), (0, 0))
    draw = ImageDraw.Draw(out)
    y = H + pad
    for text in wrapped:
        draw.text((pad, y), text, fill=(0, 0, 0), font=face)
        y += row
    for k, item in enumerate(items):
        x, yy = pad + (k % per_row) * col, y + (k // per_row) * row
        _swatch(draw, item, x, yy + 3)
        draw.text((x + 26, yy), item.name, fill=(0, 0, 0), font=face)
    return np.asarray(out)


def _swatch(draw, item: LegendItem, x: int, y: int) -> None:
    c = tuple(item.colour)
    if item.kind == "dot":
        draw.ellipse((x + 4, y, x + 14, y + 10), fill=c, outline=(0, 0, 0))
    elif item.kind == "ring":
        draw.ellipse((x + 4, y, x + 14, y + 10), outline=c, width=2)
    elif item.kind == "line":
        draw.line((x, y + 5, x + 20, y + 5), fill=c, width=3)
    elif item.kind == "ramp":
        for i in range(20):
            t = i / 19
            draw.line((x + i, y, x + i, y + 10), fill=tuple(
                int(round((1 - t) * a + t * b)) for a, b in zip(c, item.end, strict=True)))
    else:
        draw.rectangle((x, y, x + 20, y + 10), fill=c)


def _wrap(draw, text: str, font, width: int) -> list[str]:
    words, lines = text.split(), [""]
    for w in words:
        trial = f"{lines[-1]} {w}".strip()
        if draw.textlength(trial, font=font) <= width or not lines[-1]:
            lines[-1] = trial
        else:
            lines.append(w)
    return lines


def font(size: int):
    """A PIL font of ``size`` px: DejaVu Sans where installed, else PIL's own."""
    from PIL import ImageFont

    for name in FONTS:
        try:
            return ImageFont.truetype(name, size)
        except OSError:
            continue
    return ImageFont.load_default()


def caption_lines(ep: Episode, frame: int) -> list[str]:
    """What a still says below the image: the episode and its summary (markdown's emphasis
    and line breaks dropped), then the frame, its time and its caption."""
    summary = ep.summary.replace("**", "").replace("  \n", "\n").splitlines()
    return [f"{ep.name}: {summary[0]}" if summary else ep.name, *summary[1:],
            f"frame {frame + 1}/{ep.n_frames} · t = {ep.times[frame]:.3f} s · "
            f"{ep.captions[frame]}"]


def write_png(ep: Episode, frame: int, path, width: int = 800, height: int = 600) -> Path:
    """``frame_image`` with its caption (``caption_lines``) and legend (the episode's and the
    scale bar's) below it, written as a PNG at ``path`` (its folder created; atomically,
    ``dopt.atomic``); returns the path."""
    from PIL import Image

    image = frame_image(ep, frame, width, height)
    length, _ = scale_bar(ep.model, _posed(ep, frame)[1])
    image = annotate(image, caption_lines(ep, frame),
                     legend_items(ep, browser=False) + floor_items(length)[1:])
    path = Path(path)
    with atomic.writing(path) as tmp:
        Image.fromarray(image).save(tmp)
    return path


def _posed(ep: Episode, frame: int) -> tuple[mujoco.MjData, np.ndarray]:
    """MjData at the frame's state (forward-computed) and the points the camera frames."""
    d = mujoco.MjData(ep.model)
    mujoco.mj_setState(ep.model, d, drawable_state(ep.states, frame), ep.spec)
    mujoco.mj_forward(ep.model, d)
    return d, _framed_points(ep.model, d)


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
