"""Quadric edge-collapse decimation of a triangle mesh to a target number of faces.

Shape letters: V vertices, F faces, M vertices and NS faces of the decimated mesh.

Two back-ends behind one function:

* ``"pymeshlab"`` (default): MeshLab's quadric edge collapse decimation, the paper's own
  back-end. Boundary edges carry quadrics of their own, so the outline of a flat panel is kept
  and targets down to 2 faces are met exactly.
* ``"trimesh"``: ``trimesh.Trimesh.simplify_quadric_decimation`` (fast-simplification). A flat
  panel has all-zero quadrics, so small targets erode its outline (a flat square decimated to
  4 faces keeps well under its full area); kept for comparison only. Needs the
  ``fast-simplification`` package.
"""
from __future__ import annotations

import logging
import threading

import numpy as np

logger = logging.getLogger(__name__)

BACKENDS = ("pymeshlab", "trimesh")

#: pymeshlab crashes when two threads decimate at once; it releases the GIL while it works,
#: so one decimation runs beside other Python threads' numpy work
_PYMESHLAB_LOCK = threading.Lock()


class EmptyDecimationError(ValueError):
    """The back-end returned no faces (pymeshlab can, from a coarse mesh at 2 faces)."""

# pymeshlab keeps a filter parameter that is not passed from the previous call in the same
# process, so every call passes all of them.
_QECD_PARAMETERS = dict(
    targetperc=0.0, qualitythr=0.3, preserveboundary=False, boundaryweight=1.0,
    preservenormal=False, preservetopology=False, optimalplacement=True, planarquadric=False,
    planarweight=0.001, qualityweight=False, autoclean=True, selected=False)


def _compact(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop unreferenced vertices; returns ``(M, 3)`` vertices and re-indexed faces."""
    used = np.unique(faces)
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return np.asarray(vertices, dtype=float)[used], remap[faces]


def _pymeshlab(vertices: np.ndarray, faces: np.ndarray, n_faces: int):
    import pymeshlab

    with _PYMESHLAB_LOCK:
        meshes = pymeshlab.MeshSet()
        meshes.add_mesh(pymeshlab.Mesh(vertex_matrix=vertices,
                                       face_matrix=faces.astype(np.int32)))
        meshes.meshing_decimation_quadric_edge_collapse(targetfacenum=int(n_faces),
                                                        **_QECD_PARAMETERS)
        mesh = meshes.current_mesh()
        return mesh.vertex_matrix(), mesh.face_matrix().astype(np.int64)


def _trimesh(vertices: np.ndarray, faces: np.ndarray, n_faces: int):
    import trimesh

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    try:
        out = mesh.simplify_quadric_decimation(face_count=int(n_faces))
    except ImportError as exc:  # fast-simplification is not a dependency of dopt
        raise ValueError("backend 'trimesh' needs the fast-simplification package") from exc
    return np.asarray(out.vertices), np.asarray(out.faces, dtype=np.int64)


_IMPLEMENTATIONS = {"pymeshlab": _pymeshlab, "trimesh": _trimesh}


def decimate(vertices: np.ndarray, faces: np.ndarray, n_faces: int,
             backend: str = "pymeshlab") -> tuple[np.ndarray, np.ndarray]:
    """Decimate the mesh ``(V, 3)``, ``(F, 3)`` to ``n_faces`` triangles. Thread-safe: pymeshlab
    decimations of several threads run one at a time.

    Returns:
        ``(vertices, faces)`` of the decimated mesh, ``(M, 3)`` and ``(NS, 3)``, without
        unreferenced vertices. NS may differ from ``n_faces`` when the back-end cannot hit it.

    Raises:
        EmptyDecimationError: the back-end returned no faces.
    """
    if backend not in _IMPLEMENTATIONS:
        raise ValueError(f"unknown decimation backend {backend!r}; choose from {BACKENDS}")
    # writable C-ordered copies: the native back-ends reject read-only (frozen goal) arrays
    v, f = _IMPLEMENTATIONS[backend](np.array(vertices, dtype=float, order="C"),
                                     np.array(faces, dtype=np.int64, order="C"), n_faces)
    if len(f) == 0:
        raise EmptyDecimationError(f"decimation to {n_faces} faces ({backend}) returned an "
                                   f"empty mesh")
    return _compact(v, f)
