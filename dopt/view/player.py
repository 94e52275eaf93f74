"""The browser viewer: a viser server that plays episodes frame by frame.

``Viewer(entries)`` serves on 127.0.0.1 (viser; needs the ``viz`` extra): the scene
(``dopt.view.mjscene``) with the episode's goal ghost (as wire), markers (spheres, a tag
beside the tagged ones: the MPC goal object and its target), regions, and the floor's grid
with a scale bar; and a panel with the trial dropdown (switching loads the trial, once,
without restarting), the frame slider, Back / Play / Next buttons, the playback speed, the
frame's caption, the episode's summary, the legend of every marker and shade
(``dopt.view.legend``) and its curves, each with a cursor at the current frame. Nothing here
needs a display; ``url`` is what to open.

Shapes: F frames, M markers, ns state row.
"""

from __future__ import annotations

import logging
import threading
import time

import numpy as np

from dopt.view.episode import Curve, Episode, drawable_state
from dopt.view.legend import (
    BAR_COLOUR,
    GRID_COLOUR,
    floor_height,
    floor_items,
    legend_html,
    legend_items,
    length_text,
    nice_length,
)
from dopt.view.mjscene import SceneView, flex_vertices, segment_points

log = logging.getLogger(__name__)

#: playback speeds offered (simulation seconds per wall second)
SPEEDS = ("0.25x", "0.5x", "1x", "2x", "4x", "8x")
#: playback loop period (s)
TICK = 1 / 30
#: the plots' cursor colour, its series' name and its scale (fixed: it spans the plot)
CURSOR_COLOUR, CURSOR_NAME, CURSOR_SCALE = "black", "current frame", "cursor"


def edges(faces: np.ndarray) -> np.ndarray:
    """The unique edges (E, 2) of triangles (T, 3), or segments (E, 2) as they are."""
    faces = np.asarray(faces, dtype=np.int64)
    if faces.shape[1] == 2:
        return faces
    pairs = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    return np.unique(np.sort(pairs, axis=1), axis=0)


def cursor_data(curve: Curve, at: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A curve's plot data with a vertical cursor at x = ``at``: x (n + 2,) with ``at``
    inserted twice, y (n + 2,) interpolated there, and the cursor series (n + 2,) on its own
    fixed 0..1 scale (``CURSOR_SCALE``), NaN but 0 and 1 at the two inserted points: uPlot
    draws it as a vertical segment over the plot's height (the canvas skips the NaN points;
    on the curve's own scale they would spoil its range)."""
    x, y = np.asarray(curve.x, dtype=float), np.asarray(curve.y, dtype=float)
    at = float(np.clip(at, x[0], x[-1]))
    i = int(np.searchsorted(x, at, side="right"))
    value = float(np.interp(at, x, y))
    cursor = np.full(len(x) + 2, np.nan)
    cursor[i:i + 2] = 0.0, 1.0
    return (np.concatenate([x[:i], [at, at], x[i:]]),
            np.concatenate([y[:i], [value, value], y[i:]]), cursor)


class Viewer:
    """A viser server showing the episodes of ``entries`` ({label: (source, path)},
    ``dopt.view.episode.collect``), one at a time.

    Args:
        entries: the episodes to offer; the first is shown (or ``first``).
        host, port: where to serve (the port moves up when taken; ``url`` says where).
        max_frames: frames kept per episode.
        start_frame: the frame shown first (None: the episode's own, e.g. a blow-up's
            failing step); clamped to the episode.
    """

    def __init__(self, entries: dict, host: str = "127.0.0.1", port: int = 8080,
                 max_frames: int = 300, start_frame: int | None = None,
                 first: str | None = None):
        import viser

        if not entries:
            raise ValueError("no episode to show")
        if first is not None and first not in entries:
            raise ValueError(f"no episode {first!r}; there are {', '.join(entries)}")
        self.entries, self.max_frames, self.start_frame = dict(entries), max_frames, start_frame
        self.server = viser.ViserServer(host=host, port=port, label="dopt-view", verbose=False)
        self.server.scene.set_up_direction("+z")
        self._lock = threading.RLock()
        self._cache: dict[str, Episode] = {}
        self.episode: Episode | None = None
        self.frame, self.playing = 0, False
        self._nodes: list = []
        self._plots: list = []
        self._build_panel()
        self.select(first or next(iter(self.entries)))
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._play_loop, name="dopt-view-play",
                                        daemon=True)
        self._thread.start()

    @property
    def url(self) -> str:
        return f"http://{self.server.get_host()}:{self.server.get_port()}"

    # ------------------------------------------------------------------ panel
    def _build_panel(self) -> None:
        gui = self.server.gui
        labels = tuple(self.entries)
        self.trial = gui.add_dropdown("trial", labels, initial_value=labels[0],
                                      visible=len(labels) > 1)
        self.summary = gui.add_markdown("")
        self.caption = gui.add_markdown("")
        self.slider = gui.add_slider("frame", min=0, max=1, step=1, initial_value=0)
        self.back = gui.add_button("Back")
        self.play = gui.add_button("Play")
        self.next = gui.add_button("Next")
        self.speed = gui.add_dropdown("speed", SPEEDS, initial_value="1x")
        self.legend = gui.add_html("")
        self.trial.on_update(lambda _: self.select(self.trial.value))
        self.slider.on_update(lambda _: self.show(int(self.slider.value)))
        self.back.on_click(lambda _: self.step(-1))
        self.next.on_click(lambda _: self.step(+1))
        self.play.on_click(lambda _: self.toggle())

    def load(self, label: str) -> Episode:
        """The episode of ``label`` (loaded once; the source replays it)."""
        if label not in self._cache:
            source, path = self.entries[label]
            log.info("loading %s (%s)", label, path)
            self._cache[label] = source.load(path, self.max_frames)
        return self._cache[label]

    def select(self, label: str) -> None:
        """Show the episode of ``label`` from its start frame."""
        with self._lock:
            if label == getattr(self, "label", None):
                return
            self.playing = False
            self.play.label = "Play"
            ep = self.load(label)
            self.label = label
            self._clear()
            self.episode = ep
            self.view = SceneView(self.server, ep.model, "/ep/mj", ep.hidden_geoms)
            self._add_overlays(ep)
            self._add_plots(ep)
            self.summary.content = ep.summary
            first = ep.start_frame if self.start_frame is None else self.start_frame
            self.frame = int(np.clip(first, 0, ep.n_frames - 1))
            self.slider.max = max(ep.n_frames - 1, 1)
            self._aim_camera(ep)
            bar = self._add_floor(ep)
            self.legend.content = legend_html(legend_items(ep) + floor_items(bar))
            if self.trial.value != label:
                self.trial.value = label
            self.show(self.frame, force=True)

    def _clear(self) -> None:
        plots = [p[0] for p in self._plots]
        markers = [h for _, nodes, _ in getattr(self, "_markers", []) for h in nodes]
        for handle in self._nodes + plots + markers:
            handle.remove()
        self._nodes, self._plots, self._markers = [], [], []
        if getattr(self, "view", None) is not None:
            for handle in self.view.handles():
                handle.remove()

    def _add_floor(self, ep: Episode) -> float:
        """The floor's grid under the episode's objects and a scale bar at its near edge;
        returns the bar's length (m)."""
        pts = self._all_points(ep)
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        length = nice_length(float(np.max(hi[:2] - lo[:2])))
        z = floor_height(ep.model, pts) + 5e-4
        cells = 2 * int(np.ceil(0.8 * np.max(hi[:2] - lo[:2]) / length)) + 4
        centre = np.array([*np.round(0.5 * (lo[:2] + hi[:2]) / length) * length, z])
        scene = self.server.scene
        self._nodes.append(scene.add_grid(
            "/ep/floor", cells * length, cells * length, cell_size=length,
            section_size=5 * length, cell_color=GRID_COLOUR, section_color=GRID_COLOUR,
            position=tuple(centre), shadow_opacity=0.0))
        start = np.array([lo[0], lo[1] - 0.6 * length, z + 5e-4])
        bar = np.stack([start, start + [length, 0, 0]])[None]
        self._nodes.append(scene.add_line_segments("/ep/scale_bar", bar, BAR_COLOUR,
                                                   thickness=4, thickness_units="screen"))
        self._nodes.append(scene.add_label("/ep/scale_label", length_text(length),
                                           position=tuple(start + [length / 2, 0, 0]),
                                           anchor="top-center"))
        return length

    def _all_points(self, ep: Episode) -> np.ndarray:
        """Scene points (flex vertices, moving bodies) at the first and last frames."""
        pts = []
        for f in (0, ep.n_frames - 1):
            self.view.show(drawable_state(ep.states, f), ep.spec)
            pts.append(self._scene_points())
        pts = np.concatenate(pts)
        return pts if len(pts) else np.zeros((1, 3))

    def _add_overlays(self, ep: Episode) -> None:
        scene = self.server.scene
        if ep.ghost is not None:
            g = ep.ghost
            self._ghost_edges = edges(g.faces)
            shape = g.shapes[max(int(g.which[0]), 0)]
            node = scene.add_line_segments("/ep/ghost", segment_points(shape, self._ghost_edges),
                                           g.colour, thickness=1.5, thickness_units="screen")
            self._nodes.append(node)
            self._ghost, self._ghost_shape = node, -2
        for k, r in enumerate(ep.regions):
            import trimesh
            disc = trimesh.creation.cylinder(radius=r.radius, height=r.height, sections=48)
            self._nodes.append(scene.add_mesh_simple(
                f"/ep/region{k}", np.asarray(disc.vertices) + r.centre + [0, 0, r.height / 2],
                np.asarray(disc.faces), color=r.colour, opacity=0.45, cast_shadow=False))
        self._markers = []
        for k, m in enumerate(ep.markers):
            nodes = [scene.add_icosphere(f"/ep/markers{k}/{j}", m.size / 2, m.colour,
                                         subdivisions=2, cast_shadow=False)
                     for j in range(np.shape(m.positions)[1])]
            if m.tag:
                nodes.append(scene.add_label(f"/ep/markers{k}/tag", m.tag,
                                             anchor="bottom-center"))
            self._markers.append((m, nodes, bool(m.tag)))
        self._mark = None
        if ep.marked_body is not None:
            import mujoco
            name = (mujoco.mj_id2name(ep.model, mujoco.mjtObj.mjOBJ_BODY, ep.marked_body)
                    or f"body {ep.marked_body}")
            self._mark = scene.add_label("/ep/mark", f"blow-up: {name}", anchor="bottom-center")
            self._mark_dot = scene.add_point_cloud("/ep/mark_dot", np.zeros((1, 3)), (255, 0, 0),
                                                   point_size=0.03, point_shape="circle",
                                                   precision="float32")
            self._nodes += [self._mark, self._mark_dot]

    def _add_plots(self, ep: Episode) -> None:
        import viser.uplot as up

        for c in ep.curves:
            if len(c.x) < 2:
                continue
            series = (up.Series(label=c.x_label),
                      up.Series(label=f"{c.name} ({c.unit})", stroke="red", width=2),
                      up.Series(label=CURSOR_NAME, stroke=CURSOR_COLOUR, width=1.5,
                                scale=CURSOR_SCALE, spanGaps=False, points={"show": False}))
            # the cursor stands at an end at the first and last frames: keep it inside
            x = np.asarray(c.x, dtype=float)
            pad = max(0.5 * float(np.median(np.diff(x))), 0.02 * float(x[-1] - x[0]))
            x_scale = {"time": False, "auto": False,
                       "range": (float(x[0]) - pad, float(x[-1]) + pad)}
            handle = self.server.gui.add_uplot(
                cursor_data(c, c.cursor_x(ep, 0)), series, title=c.name, aspect=1.6,
                scales={"x": x_scale, CURSOR_SCALE: {"auto": False, "range": (0.0, 1.0)}},
                axes=({"label": c.x_label}, {"label": c.unit}))
            self._plots.append((handle, c))

    def _aim_camera(self, ep: Episode) -> None:
        """Frame the objects: where the episode shades bodies (MPC), those bodies and the
        goal regions (not the arm); else the flexes and the moving bodies."""
        p = self._scene_points()
        if ep.shade is not None:
            objects = np.flatnonzero(np.isfinite(ep.shade).any(axis=0))
            p = np.concatenate([self.view.data.xpos[objects].reshape(-1, 3),
                                *[np.asarray(r.centre, dtype=float)[None] for r in ep.regions]])
        if not len(p):
            return
        lo, hi = np.percentile(p, 2, axis=0), np.percentile(p, 98, axis=0)
        centre, extent = 0.5 * (lo + hi), float(np.max(hi - lo))
        # a few objects' centres span less than the objects do: step back further
        distance = (0.9 if ep.shade is None else 1.8) * max(extent, 0.2) + 0.1
        cam = self.server.initial_camera
        cam.look_at = tuple(centre)
        cam.position = tuple(centre + distance * np.array([0.0, -0.75, 0.9]))
        for client in self.server.get_clients().values():
            client.camera.look_at, client.camera.position = cam.look_at, cam.position

    def _scene_points(self) -> np.ndarray:
        v = self.view
        pts = [flex_vertices(v.model, v.data, f) for f in range(v.model.nflex)]
        pts += [v.data.xpos[list(v.frames)]] if v.frames else []
        return np.concatenate(pts) if pts else np.empty((0, 3))

    # ------------------------------------------------------------------ frames
    def show(self, frame: int, force: bool = False) -> None:
        """Draw frame ``frame`` of the current episode (clamped)."""
        with self._lock:
            ep = self.episode
            frame = int(np.clip(frame, 0, ep.n_frames - 1))
            if frame == self.frame and not force:
                return
            self.frame = frame
            with self.server.atomic():
                state = drawable_state(ep.states, frame)
                shade = None if ep.shade is None else ep.shade[frame]
                self.view.show(state, ep.spec, shade, ep.marked_body)
                self._show_overlays(ep, frame)
            if int(self.slider.value) != frame:
                self.slider.value = frame
            self.caption.content = (f"frame {frame + 1}/{ep.n_frames} · t = "
                                    f"{ep.times[frame]:.3f} s  \n{ep.captions[frame]}")

    def _show_overlays(self, ep: Episode, frame: int) -> None:
        g = ep.ghost
        if g is not None and int(g.which[frame]) != self._ghost_shape:
            self._ghost_shape = k = int(g.which[frame])
            self._ghost.visible = k >= 0
            if k >= 0:
                self._ghost.points = segment_points(g.shapes[k],
                                                    self._ghost_edges).astype(np.float32)
        for m, nodes, tagged in self._markers:
            pts = np.asarray(m.positions[frame], dtype=float)
            shown = np.isfinite(pts).all(axis=1)
            for node, p, ok in zip(nodes, pts, shown, strict=False):
                node.visible = bool(ok)
                if ok:
                    node.position = tuple(p)
            if tagged:
                nodes[-1].visible = bool(shown.any())
                if shown.any():
                    nodes[-1].position = tuple(pts[np.argmax(shown)] + [0, 0, m.size])
        for handle, curve in self._plots:
            handle.data = cursor_data(curve, curve.cursor_x(ep, frame))
        if self._mark is not None:
            at = self.view.body_position(ep.marked_body)
            self._mark.position = at + [0, 0, 0.03]
            self._mark_dot.points = at[None].astype(np.float32)

    def step(self, by: int) -> None:
        """Move ``by`` frames and pause."""
        with self._lock:
            self.playing = False
            self.play.label = "Play"
            self.show(self.frame + by)

    def toggle(self) -> None:
        """Play from the current frame (from the start at the end), or pause."""
        with self._lock:
            self.playing = not self.playing
            if self.playing and self.frame >= self.episode.n_frames - 1:
                self.show(0)
            self.play.label = "Pause" if self.playing else "Play"
            self._clock = (time.perf_counter(), float(self.episode.times[self.frame]))

    def _play_loop(self) -> None:
        while not self._stop.wait(TICK):
            try:
                self._tick()
            except Exception:                       # keep serving; the log names it
                log.exception("playback failed")
                self.playing = False

    def _tick(self) -> None:
        with self._lock:
            if not self.playing:
                return
            ep = self.episode
            wall0, sim0 = self._clock
            speed = float(self.speed.value.rstrip("x"))
            target = sim0 + speed * (time.perf_counter() - wall0)
            frame = int(np.searchsorted(ep.times, target, side="right") - 1)
            if frame >= ep.n_frames - 1:
                self.playing = False
                self.play.label = "Play"
            self.show(max(frame, self.frame))

    def close(self) -> None:
        """Stop playback and the server."""
        self._stop.set()
        self._thread.join(timeout=2)
        self.server.stop()

