"""A MuJoCo model drawn in a viser scene and moved state by state.

Each visible geom (groups 0-2, alpha > 0) becomes a mesh in its body's frame; bodies that move
get a frame node whose pose follows ``xpos`` / ``xquat``; each flex becomes one mesh (2D:
its triangles, 3D: its surface) or a polyline with its particles (1D), whose vertices follow
``flexvert_xpos``. Colours follow the model (``geom_rgba``, its material, ``flex_rgba``); a
shade per body (``Episode.shade``) recolours objects, a marked body is drawn red.

``geom_mesh`` (a geom's triangles in its body frame) and ``shade_colour`` have no viser in
them; ``SceneView`` needs a ``viser.ViserServer``.

Shapes: V vertices, E faces (triangles) or segments, nbody bodies.
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

from dopt.state import check_model

log = logging.getLogger(__name__)

#: geom groups drawn (MuJoCo's viewer shows 0-2 by default)
VISIBLE_GROUPS = (0, 1, 2)
#: size (m) of a plane whose size is 0 (infinite in MuJoCo)
PLANE_SIZE = 2.0
#: colours of a shade of 0 (no DoF in the set) and 1 (all of them)
SHADE_LOW, SHADE_HIGH = np.array([225, 225, 225]), np.array([200, 30, 30])
MARK_COLOUR = (255, 0, 0)


def shade_colour(value: float, own: np.ndarray) -> tuple[int, int, int]:
    """The colour of a body shaded ``value`` in [0, 1] (NaN: its own colour ``own`` (3,))."""
    if not np.isfinite(value):
        return tuple(int(c) for c in own)
    v = float(np.clip(value, 0.0, 1.0))
    return tuple(int(round(c)) for c in (1 - v) * SHADE_LOW + v * SHADE_HIGH)


def geom_rgba(model: mujoco.MjModel, g: int) -> np.ndarray:
    """(4,) RGBA in [0, 1] of geom ``g``: its material's where it has one."""
    mat = int(model.geom_matid[g])
    return np.array(model.mat_rgba[mat] if mat >= 0 else model.geom_rgba[g], dtype=float)


def geom_mesh(model: mujoco.MjModel, g: int) -> tuple[np.ndarray, np.ndarray] | None:
    """Triangles of geom ``g`` in its body's frame: vertices (V, 3), faces (E, 3); None for
    a type that is not drawn (height fields, SDFs)."""
    import trimesh

    t, s = int(model.geom_type[g]), np.asarray(model.geom_size[g], dtype=float)
    T = mujoco.mjtGeom
    if t == T.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=s[0])
    elif t == T.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(s)
    elif t == T.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(height=2 * s[1], radius=s[0], count=[16, 16])
    elif t == T.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=s[0], height=2 * s[1], sections=32)
    elif t == T.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2 * s)
    elif t == T.mjGEOM_PLANE:
        ext = [2 * s[0] if s[0] > 0 else PLANE_SIZE, 2 * s[1] if s[1] > 0 else PLANE_SIZE, 1e-3]
        mesh = trimesh.creation.box(extents=ext)
        mesh.apply_translation([0, 0, -5e-4])
    elif t == T.mjGEOM_MESH:
        m = int(model.geom_dataid[g])
        va, vn = int(model.mesh_vertadr[m]), int(model.mesh_vertnum[m])
        fa, fn = int(model.mesh_faceadr[m]), int(model.mesh_facenum[m])
        verts, faces = model.mesh_vert[va:va + vn].copy(), model.mesh_face[fa:fa + fn].copy()
        return _posed(model, g, verts), faces
    else:
        return None
    return _posed(model, g, np.asarray(mesh.vertices)), np.asarray(mesh.faces)


def _posed(model: mujoco.MjModel, g: int, verts: np.ndarray) -> np.ndarray:
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, model.geom_quat[g])
    return verts @ rot.reshape(3, 3).T + model.geom_pos[g]


def flex_topology(model: mujoco.MjModel, f: int) -> tuple[np.ndarray, int]:
    """What is drawn of flex ``f``: triangles (E, 3) (2D: its elements, 3D: its surface) or
    segments (E, 2) (1D), in vertex indices local to the flex; and its dimension."""
    dim = int(model.flex_dim[f])
    if dim == 3:
        a, n = int(model.flex_shelldataadr[f]), int(model.flex_shellnum[f])
        return model.flex_shell[a:a + 3 * n].reshape(-1, 3).astype(np.int64), dim
    a, n = int(model.flex_elemdataadr[f]), int(model.flex_elemnum[f])
    return model.flex_elem[a:a + (dim + 1) * n].reshape(-1, dim + 1).astype(np.int64), dim


def flex_vertices(model: mujoco.MjModel, data: mujoco.MjData, f: int) -> np.ndarray:
    """(V, 3) world positions of flex ``f``'s vertices (after ``mj_forward``)."""
    a, n = int(model.flex_vertadr[f]), int(model.flex_vertnum[f])
    return np.array(data.flexvert_xpos[a:a + n])


def face_up(verts: np.ndarray, faces: np.ndarray) -> bool:
    """Whether triangles (E, 3) of vertices (V, 3) face up (+z) on the whole: the z of the
    sum of their area-weighted normals is >= 0."""
    a, b, c = (verts[faces[:, k]] for k in range(3))
    return bool(np.cross(b - a, c - a)[:, 2].sum() >= 0)


def _tuple(colour) -> tuple[int, int, int]:
    return tuple(int(c) for c in colour)


def segment_points(verts: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """(E, 2, 3) end points of segments (E, 2) of vertices (V, 3)."""
    return np.stack([verts[segments[:, 0]], verts[segments[:, 1]]], axis=1)


class SceneView:
    """A model's geoms and flexes under ``root`` in a viser scene, posed by ``show``.

    Args:
        server: a ``viser.ViserServer``.
        model: the compiled model.
        root: the scene-tree prefix of every node.
        hidden_geoms: geom ids not drawn.
    """

    def __init__(self, server, model: mujoco.MjModel, root: str = "/mj",
                 hidden_geoms=()):
        self.server, self.model, self.root = server, check_model(model), root
        self.data = mujoco.MjData(model)
        mujoco.mj_forward(model, self.data)
        self.frames: dict[int, object] = {}          # moving body -> frame handle
        self.geoms: dict[int, tuple[object, np.ndarray]] = {}   # geom -> (handle, own colour)
        #: flex -> ([(handle, own colour)], dimension, topology)
        self.flexes: dict[int, tuple[list, int, np.ndarray]] = {}
        self._colours: dict[int, tuple] = {}    # id(handle) -> colour set
        self._build_geoms(set(int(g) for g in hidden_geoms))
        self._build_flexes()

    def _build_geoms(self, hidden: set) -> None:
        m, d, scene = self.model, self.data, self.server.scene
        for g in range(m.ngeom):
            rgba = geom_rgba(m, g)
            if g in hidden or rgba[3] <= 0 or int(m.geom_group[g]) not in VISIBLE_GROUPS:
                continue
            tri = geom_mesh(m, g)
            if tri is None:
                continue
            b = int(m.geom_bodyid[g])
            moving = b != 0 and (int(m.body_weldid[b]) != 0 or int(m.body_mocapid[b]) >= 0)
            if moving and b not in self.frames:
                self.frames[b] = scene.add_frame(f"{self.root}/body{b}", show_axes=False,
                                                 position=d.xpos[b], wxyz=d.xquat[b])
            parent = f"{self.root}/body{b}" if moving else f"{self.root}/static"
            verts = tri[0] if moving else tri[0] @ d.xmat[b].reshape(3, 3).T + d.xpos[b]
            own = np.round(255 * rgba[:3]).astype(int)
            handle = scene.add_mesh_simple(
                f"{parent}/geom{g}", verts, tri[1], color=tuple(int(c) for c in own),
                opacity=None if rgba[3] >= 1 else float(rgba[3]),
                receive_shadow=True, cast_shadow=rgba[3] >= 1)
            self.geoms[g] = (handle, own)

    def _build_flexes(self) -> None:
        """A 1D flex: line segments; 3D: its surface, both sides; 2D (cloth): two meshes over
        the same vertices, one per face (the face up at the start in the flex's colour, the
        other darker, ``underside_colour``), so folded layers read as the
        two sides of one cloth and each layer hides the one beneath it."""

        m, scene = self.model, self.server.scene
        for f in range(m.nflex):
            topo, dim = flex_topology(m, f)
            verts = flex_vertices(m, self.data, f)
            own = np.round(255 * np.asarray(m.flex_rgba[f][:3])).astype(int)
            name = f"{self.root}/flex{f}"
            if dim == 1:
                parts = [(scene.add_line_segments(name, segment_points(verts, topo),
                                                  _tuple(own),
                                                  thickness=2 * float(m.flex_radius[f])),
                          own)]
            elif dim == 3:
                parts = [(scene.add_mesh_simple(name, verts, topo, color=_tuple(own),
                                                side="double", flat_shading=False), own)]
            else:
                up = face_up(verts, topo)
                under = np.array(underside_colour(own))
                parts = [(scene.add_mesh_simple(f"{name}/{side}", verts, topo,
                                                color=_tuple(c), side=side,
                                                flat_shading=False), c)
                         for side, c in (("front", own if up else under),
                                         ("back", under if up else own))]
            self.flexes[f] = (parts, dim, topo)

    def handles(self) -> list:
        """Every scene node this view added (to remove them)."""
        out = [h for h, _ in self.geoms.values()]
        out += [h for parts, *_ in self.flexes.values() for h, _ in parts]
        return out + list(self.frames.values())

    def show(self, state: np.ndarray, spec: int, shade: np.ndarray | None = None,
             marked: int | None = None) -> None:
        """Pose everything at the state row (ns,) of ``spec``; ``shade`` (nbody,) recolours
        bodies (NaN: own colour), ``marked`` draws a body red."""
        m, d = self.model, self.data
        mujoco.mj_setState(m, d, np.asarray(state, dtype=float), spec)
        mujoco.mj_forward(m, d)
        for b, frame in self.frames.items():
            frame.position, frame.wxyz = d.xpos[b].copy(), d.xquat[b].copy()
        for f, (parts, dim, topo) in self.flexes.items():
            verts = flex_vertices(m, d, f)
            value = self._flex_shade(f, shade)
            for handle, own in parts:
                if dim == 1:
                    handle.points = segment_points(verts, topo).astype(np.float32)
                else:
                    handle.vertices = verts.astype(np.float32)
                self._recolour(handle, own, value)
        for g, (handle, own) in self.geoms.items():
            b = int(m.geom_bodyid[g])
            value = np.nan if shade is None else shade[b]
            if marked is not None and b == marked:
                self._set_colour(handle, MARK_COLOUR)
            else:
                self._recolour(handle, own, value)

    def _flex_shade(self, f: int, shade: np.ndarray | None) -> float:
        if shade is None:
            return np.nan
        a, n = int(self.model.flex_vertadr[f]), int(self.model.flex_vertnum[f])
        values = shade[self.model.flex_vertbodyid[a:a + n]]
        values = values[np.isfinite(values)]
        return float(values.mean()) if len(values) else np.nan

    def _recolour(self, handle, own: np.ndarray, value: float) -> None:
        self._set_colour(handle, shade_colour(value, own))

    def _set_colour(self, handle, colour: tuple) -> None:
        if self._colours.get(id(handle)) == colour:
            return
        self._colours[id(handle)] = colour
        if hasattr(handle, "colors"):                 # line segments
            handle.colors = np.tile(np.array(colour, dtype=np.uint8), (len(handle.points), 2, 1))
        else:
            handle.color = colour

    def body_position(self, body: int) -> np.ndarray:
        """(3,) world position of a body in the state last shown."""
        return np.array(self.data.xpos[body])

#: the underside of a cloth is drawn in its own colour times this
UNDERSIDE = 0.55


def underside_colour(own) -> tuple[int, int, int]:
    """The colour a cloth's underside is drawn in: its own (3,) darkened."""
    return tuple(int(round(UNDERSIDE * c)) for c in np.asarray(own, dtype=float)[:3])
