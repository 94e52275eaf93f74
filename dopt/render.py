"""Offscreen pictures of MuJoCo states as numpy arrays: a camera fitted to a set of points,
projection of 3D points to pixels and markers drawn on the image. The frames of a replayed
pick-and-place plan are the pick wing's (``dopt.tasks.pick.replay``): this module knows no task.

Everything here returns arrays (``(H, W, 3) uint8`` images); composing figures, titles and
writing files is the caller's business. Rendering needs an offscreen OpenGL context: set
``MUJOCO_GL=egl`` (or osmesa) before ``mujoco`` is first imported; without one
``mujoco.Renderer`` raises, and so do the functions that render.

    cam = fit_camera(points, *TOP, fovy=model.vis.global_.fovy, aspect=640 / 480)
    image = render(model, state, spec, cam, 640, 480)
    image = draw_markers(image, project(points, cam, 640, 480, model.vis.global_.fovy))

Markers are drawn on the image (not added to the 3D scene), so a particle under a layer of
cloth stays visible. Shapes: N points, F frames, ns state row.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from dopt.state import check_model, check_spec, check_states
from dopt.validation import check_int, check_real, float_array, index_array

#: (azimuth, elevation) in degrees of the standard views: straight down (x right, y up in the
#: image) and an oblique view from the front left
TOP = (90.0, -90.0)
OBLIQUE = (120.0, -40.0)


# ------------------------------------------------------------------------------ camera
def camera_frame(azimuth: float, elevation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """forward, up, right unit vectors (3,) of a free camera at these angles (degrees), as
    ``mjv_updateCamera`` computes them (right = forward x up is the image's +column)."""
    a, e = np.deg2rad(azimuth), np.deg2rad(elevation)
    forward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
    return forward, up, np.cross(forward, up)


def fit_camera(points: np.ndarray, azimuth: float = TOP[0], elevation: float = TOP[1], *,
               fovy: float = 45.0, aspect: float = 4 / 3, fill: float = 0.85,
               min_extent: float = 0.05) -> mujoco.MjvCamera:
    """A free camera at (azimuth, elevation) that sees every point, the points filling
    ``fill`` of the frame along its tighter axis and centred in it.

    Args:
        points: (N, 3) world positions (m) to frame.
        azimuth, elevation: the view direction (degrees; elevation -90 looks straight down).
        fovy: vertical field of view (degrees); free cameras use ``model.vis.global_.fovy``.
        aspect: image width / height.
        fill: fraction (0, 1] of the half-width / half-height the farthest point may reach.
        min_extent: the points are framed as if they spanned at least this (m), so that a
            single point does not fill the image.
    """
    p = float_array(points, "points")
    if p.shape[-1:] != (3,) or not p.size:
        raise ValueError(f"points must be a non-empty (N, 3) array, got shape {p.shape}")
    p = p.reshape(-1, 3)
    azimuth, elevation = check_real(azimuth, "azimuth"), check_real(elevation, "elevation")
    fovy, aspect = _fovy(fovy), check_real(aspect, "aspect", positive=True)
    if not 0 < check_real(fill, "fill") <= 1:
        raise ValueError(f"fill must be in (0, 1], got {fill}")
    min_extent = check_real(min_extent, "min_extent", minimum=0)
    lo, hi = p.min(axis=0), p.max(axis=0)
    centre = 0.5 * (lo + hi)
    pad = np.maximum(min_extent - (hi - lo), 0.0) / 2
    p = np.concatenate([p, centre + pad * np.array([[1, 1, 1], [-1, -1, -1]])])
    forward, up, right = camera_frame(azimuth, elevation)
    tan_v = np.tan(np.deg2rad(fovy) / 2) * fill
    tan_h = tan_v * aspect
    lookat = centre
    distance = 1.0
    for _ in range(6):                      # fit the distance, re-centre, fit again
        rel = p - lookat
        x, y, z = rel @ right, rel @ up, rel @ forward
        distance = max(np.max(np.abs(x) / tan_h - z), np.max(np.abs(y) / tan_v - z), 1e-3)
        depth = distance + z
        u, v = x / depth, y / depth          # tangent-plane coordinates of each point
        du, dv = 0.5 * (u.max() + u.min()), 0.5 * (v.max() + v.min())
        if abs(du) < 1e-4 * tan_h and abs(dv) < 1e-4 * tan_v:
            break
        lookat = lookat + distance * (du * right + dv * up)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = lookat
    cam.distance, cam.azimuth, cam.elevation = float(distance), float(azimuth), float(elevation)
    return cam


def project(points: np.ndarray, camera: mujoco.MjvCamera, width: int, height: int,
            fovy: float = 45.0) -> np.ndarray:
    """Pixel coordinates (column, row; row 0 at the top, as ``Renderer.render`` returns the
    image; pixel i covers [i, i + 1)) of world points (..., 3) -> (..., 2) seen by a free
    camera; points behind the camera (or NaN) come out NaN."""
    p = float_array(points, "points", finite=False)
    if p.shape[-1:] != (3,):
        raise ValueError(f"points must have shape (..., 3), got {p.shape}")
    if not isinstance(camera, mujoco.MjvCamera):
        raise TypeError(f"camera must be a mujoco.MjvCamera, got {type(camera).__name__}")
    width, height = check_int(width, "width", 1), check_int(height, "height", 1)
    fovy = _fovy(fovy)
    forward, up, right = camera_frame(camera.azimuth, camera.elevation)
    eye = np.asarray(camera.lookat) - camera.distance * forward
    rel = p - eye
    x, y, z = rel @ right, rel @ up, rel @ forward
    tan_v = np.tan(np.deg2rad(fovy) / 2)
    tan_h = tan_v * width / height
    with np.errstate(divide="ignore", invalid="ignore"):
        col = 0.5 * width * (1 + x / (z * tan_h))
        row = 0.5 * height * (1 - y / (z * tan_v))
    out = np.stack([col, row], axis=-1)
    out[~(z > 0)] = np.nan
    return out


def _fovy(fovy) -> float:
    fovy = check_real(fovy, "fovy")
    if not 0 < fovy < 180:
        raise ValueError(f"fovy must be in (0, 180) degrees, got {fovy}")
    return fovy


# ---------------------------------------------------------------------------- rendering
def _size(model: mujoco.MjModel, width: int, height: int) -> tuple[int, int]:
    width, height = check_int(width, "width", 1), check_int(height, "height", 1)
    g = model.vis.global_
    if width > g.offwidth or height > g.offheight:
        raise ValueError(f"{width} x {height} is larger than the model's offscreen buffer "
                         f"{g.offwidth} x {g.offheight} (<visual><global offwidth offheight>)")
    return int(width), int(height)


def render_states(model: mujoco.MjModel, states: np.ndarray, spec: int,
                  cameras: mujoco.MjvCamera | Sequence[mujoco.MjvCamera], width: int = 640,
                  height: int = 480, *, hide_geoms: Sequence[int] = (),
                  geom_alpha: Mapping[int, float] | None = None,
                  specular: float | None = 0.1, segmentation: bool = False,
                  shadow_size: int | None = 1024) -> np.ndarray:
    """Images of state rows (F, ns) (``spec`` the mjtState bits they hold) from each camera:
    -> (F, C, H, W, 3) uint8, one offscreen context for all. A single camera gives
    (F, H, W, 3).

    ``hide_geoms``: geom ids left out of the pictures (e.g. a gripper that would hide the
    object from above). ``geom_alpha``: {geom id: opacity} (e.g. a see-through floor shows
    what was pushed under it; a transparent geom gets no shadow). ``specular``: the lights'
    specular intensity (None: the model's; the default 0.1 keeps a headlight from washing out
    a flat cloth seen from above). ``segmentation``: instead of colours, (..., H, W, 2) int32
    of the object id and ``mjtObj`` type seen at each pixel (-1 where nothing is);
    ``object_mask`` of it. ``shadow_size``: the shadow map's size in texels (None: the
    model's, usually 4096, which a software OpenGL renders several times slower than 1024).
    None of these options changes the model.
    """
    check_model(model)
    spec = check_spec(spec)
    width, height = _size(model, width, height)
    single = isinstance(cameras, mujoco.MjvCamera)
    cams = [cameras] if single else list(cameras) if isinstance(cameras, Sequence) else None
    if not cams or not all(isinstance(c, mujoco.MjvCamera) for c in cams):
        raise TypeError(f"cameras must be a mujoco.MjvCamera or a non-empty sequence of them, "
                        f"got {cameras!r}")
    states = np.atleast_2d(check_states(model, states, spec, name="states"))
    hide = set(index_array(hide_geoms, "hide_geoms", model.ngeom, allow_empty=True).tolist())
    if geom_alpha is not None and not isinstance(geom_alpha, Mapping):
        raise TypeError(f"geom_alpha must be a mapping geom id -> opacity, got {geom_alpha!r}")
    alpha = {}
    for g, a in (geom_alpha or {}).items():
        g = int(index_array(g, "geom_alpha: geom id", model.ngeom)[0])
        if not 0 <= check_real(a, f"geom_alpha[{g}]") <= 1:
            raise ValueError(f"geom_alpha[{g}] must be an opacity in [0, 1], got {a}")
        alpha[g] = float(a)
    if specular is not None:
        specular = check_real(specular, "specular", minimum=0)
    if shadow_size is not None:
        shadow_size = check_int(shadow_size, "shadow_size", 1)
    data = mujoco.MjData(model)
    out = np.empty((len(states), len(cams), height, width, 2 if segmentation else 3),
                   dtype=np.int32 if segmentation else np.uint8)
    quality = model.vis.quality
    shadowsize = quality.shadowsize
    if shadow_size is not None:            # read once, when the rendering context is made
        quality.shadowsize = int(shadow_size)
    try:
        renderer = mujoco.Renderer(model, height, width)
    finally:
        quality.shadowsize = shadowsize
    with renderer:
        if segmentation:
            renderer.enable_segmentation_rendering()
        for f, state in enumerate(states):
            mujoco.mj_setState(model, data, state, spec)
            mujoco.mj_forward(model, data)
            for c, cam in enumerate(cams):
                renderer.update_scene(data, cam)
                _adjust(renderer.scene, hide, alpha, specular)
                out[f, c] = renderer.render()
    return out[:, 0] if single else out


def _adjust(scn: mujoco.MjvScene, hide: set, alpha: dict, specular: float | None) -> None:
    """Hide geoms (invisible and shadowless), set geoms' opacity and the lights' specular in
    a built scene."""
    if hide or alpha:
        for i in range(scn.ngeom):
            g = scn.geoms[i]
            if g.objtype != mujoco.mjtObj.mjOBJ_GEOM:
                continue
            if g.objid in hide:
                g.rgba[3] = 0.0
                g.size[:] = 0.0
                g.pos[2] = -1e3
            elif g.objid in alpha:
                g.rgba[3] = alpha[g.objid]
    if specular is not None:
        for i in range(scn.nlight):
            scn.lights[i].specular[:] = specular


def render(model: mujoco.MjModel, state: np.ndarray, spec: int, camera: mujoco.MjvCamera,
           width: int = 640, height: int = 480, **options) -> np.ndarray:
    """One image (H, W, 3) uint8 of a state row (ns,) from a free camera (``options``: those
    of ``render_states``)."""
    check_model(model)
    state = check_states(model, state, check_spec(spec), batched=False, name="state")
    if not isinstance(camera, mujoco.MjvCamera):
        raise TypeError(f"camera must be a mujoco.MjvCamera, got {type(camera).__name__}")
    return render_states(model, state[None], spec, camera, width, height, **options)[0]


def object_mask(segmentation: np.ndarray, objtype: int = mujoco.mjtObj.mjOBJ_FLEX,
                objid: int | None = None) -> np.ndarray:
    """Where a segmentation image (..., H, W, 2) (``render_states(segmentation=True)``) sees
    objects of ``objtype`` (a flex by default; ``objid`` None: any of them) -> (..., H, W)
    bool."""
    seg = np.asarray(segmentation)
    if seg.ndim < 3 or seg.shape[-1] != 2:
        raise ValueError(f"segmentation must have shape (..., H, W, 2), got {seg.shape}")
    mask = seg[..., 1] == int(objtype)
    return mask if objid is None else mask & (seg[..., 0] == int(objid))


def mask_outline(mask: np.ndarray, width: int = 2) -> np.ndarray:
    """The boundary of a mask (H, W) bool, ``width`` pixels thick on its inside -> (H, W)."""
    m = np.asarray(mask, dtype=bool)
    if m.ndim != 2:
        raise ValueError(f"mask must have shape (H, W), got {m.shape}")
    inner = m.copy()
    for _ in range(check_int(width, "width", 1)):
        pad = np.pad(inner, 1, constant_values=False)
        inner = (inner & pad[:-2, 1:-1] & pad[2:, 1:-1] & pad[1:-1, :-2] & pad[1:-1, 2:])
    return m & ~inner


# ------------------------------------------------------------------------------ markers
def draw_markers(image: np.ndarray, pixels: np.ndarray, colour=(255, 215, 0),
                 radius: float = 6.0, style: str = "dot",
                 outline=(0, 0, 0)) -> np.ndarray:
    """A copy of ``image`` (H, W, 3) with a marker at each point (M, 2) (column, row in
    ``project``'s coordinates, radius in pixels; NaN rows are skipped): "dot" a filled disc
    with an outline, "ring" a hollow circle, "cross" an x, "square" a hollow square;
    ``outline`` None draws none."""
    if style not in ("dot", "ring", "cross", "square"):
        raise ValueError(f"unknown marker style {style!r}")
    img = _image(image)
    h, w = img.shape[:2]
    rows, cols = np.mgrid[0:h, 0:w]
    colour = _colour(colour, img, "colour")
    outline = None if outline is None else _colour(outline, img, "outline")
    radius = check_real(radius, "radius", positive=True)
    px = float_array(pixels, "pixels", finite=False)
    if px.shape[-1:] != (2,):
        raise ValueError(f"pixels must have shape (M, 2) (column, row), got {px.shape}")
    for c, r in px.reshape(-1, 2):
        if not (np.isfinite(c) and np.isfinite(r)):
            continue
        r0, r1 = int(max(r - radius - 3, 0)), int(min(r + radius + 4, h))
        c0, c1 = int(max(c - radius - 3, 0)), int(min(c + radius + 4, w))
        if r0 >= r1 or c0 >= c1:
            continue
        dr, dc = rows[r0:r1, c0:c1] + 0.5 - r, cols[r0:r1, c0:c1] + 0.5 - c  # pixel centres
        dist = np.hypot(dr, dc)
        if style == "dot":
            inner, edge = dist <= radius - 1.5, dist <= radius
        elif style == "ring":
            inner = np.abs(dist - radius + 1.5) <= 1.2
            edge = np.abs(dist - radius + 1.5) <= 2.4
        elif style == "square":
            cheb = np.maximum(np.abs(dr), np.abs(dc))
            inner = np.abs(cheb - radius + 1.5) <= 1.0
            edge = np.abs(cheb - radius + 1.5) <= 2.2
        else:
            across = np.minimum(np.abs(dr - dc), np.abs(dr + dc)) / np.sqrt(2)
            inside = np.maximum(np.abs(dr), np.abs(dc)) <= radius
            inner, edge = inside & (across <= 1.2), inside & (across <= 2.4)
        patch = img[r0:r1, c0:c1]
        if outline is not None:
            patch[edge & ~inner] = outline
        patch[inner] = colour
    return img


def _image(image) -> np.ndarray:
    """A copy of an (H, W, C) image."""
    img = np.array(image, copy=True)
    if img.ndim != 3 or img.dtype.kind not in "uif":
        raise ValueError(f"image must be an (H, W, C) numeric array, got shape {img.shape} "
                         f"dtype {img.dtype}")
    return img


def _colour(colour, img: np.ndarray, name: str) -> np.ndarray:
    c = float_array(colour, name, (img.shape[2],))
    return c.astype(img.dtype)


def draw_segments(image: np.ndarray, start: np.ndarray, end: np.ndarray,
                  colour=(0, 0, 0), width: float = 1.5) -> np.ndarray:
    """A copy of ``image`` with a line from each start pixel (M, 2) to its end pixel (M, 2)."""
    img = _image(image)
    h, w = img.shape[:2]
    rows, cols = np.mgrid[0:h, 0:w]
    colour = _colour(colour, img, "colour")
    width = check_real(width, "width", positive=True)
    start = float_array(start, "start", finite=False)
    if start.shape[-1:] != (2,):
        raise ValueError(f"start must have shape (M, 2) (column, row), got {start.shape}")
    end = float_array(end, "end", finite=False)
    if end.shape != start.shape:
        raise ValueError(f"end must have the shape of start {start.shape}, got {end.shape}")
    for a, b in zip(start.reshape(-1, 2), end.reshape(-1, 2), strict=True):
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
            continue
        c0, c1 = int(max(min(a[0], b[0]) - width - 1, 0)), int(min(max(a[0], b[0]) + width + 2, w))
        r0, r1 = int(max(min(a[1], b[1]) - width - 1, 0)), int(min(max(a[1], b[1]) + width + 2, h))
        if r0 >= r1 or c0 >= c1:
            continue
        q = np.stack([cols[r0:r1, c0:c1], rows[r0:r1, c0:c1]], axis=-1) + 0.5
        d = b - a
        t = np.clip(((q - a) @ d) / max(d @ d, 1e-12), 0.0, 1.0)
        dist = np.linalg.norm(q - (a + t[..., None] * d), axis=-1)
        img[r0:r1, c0:c1][dist <= width / 2 + 0.5] = colour
    return img
