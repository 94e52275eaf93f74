"""What the viewer shows: an ``Episode`` (a model, its state frames and what is drawn over
them), exact replay of recorded controls, and the sources that turn files into episodes.

A *source* knows one kind of record: ``claims(path, record)`` says whether a file (its JSON
``record``, or None for a folder) is one of its, ``load(path, max_frames)`` builds the
``Episode``. dopt knows no planner: the pick-and-place and MPC trial sources live in
``planners.view`` and are found through the ``dopt.view.sources`` entry points of the installed
distribution (pyproject.toml); the blow-up capture source (``BLOWUP_SOURCE``, ``load_blowup``:
the captures ``dopt.blowup`` writes) is built in.

Shapes: F frames, ns state row, M markers, V ghost vertices, nbody bodies.
"""

from __future__ import annotations

import json
import logging
import shlex
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from dopt.blowup import FORMAT
from dopt.lab import jsonio
from dopt.lab.trialpack import PACK_NAMES, is_stored_trial, read_pack, read_trial_text
from dopt.state import INTEGRATION, StateLayout, check_model, check_spec, check_states
from dopt.validation import check_int, float_array

log = logging.getLogger(__name__)

#: entry-point group of the episode sources of other packages
ENTRY_POINTS = "dopt.view.sources"
#: sub-folders of a trial folder that hold no finished trials (``dopt.lab.sweep``)
SKIPPED_FOLDERS = ("checkpoints", "corrupt", "outdated")


@dataclass(frozen=True)
class Curve:
    """A time series beside the scene: x (n,) (seconds, or iterations when ``x_label`` says
    so) and y (n,) in ``unit``. The plot's cursor marks the current frame: at the frame's
    time (``Episode.times``), or at ``cursor[f]`` (F,) where x is not time (e.g. the CEM
    iteration whose plan is being executed)."""

    name: str
    x: np.ndarray
    y: np.ndarray
    unit: str = ""
    x_label: str = "time (s)"
    cursor: np.ndarray | None = None

    def cursor_x(self, ep: Episode, frame: int) -> float:
        """Where the cursor stands at ``frame`` of ``ep``, in this curve's x."""
        return float(ep.times[frame] if self.cursor is None else self.cursor[frame])


@dataclass(frozen=True)
class Markers:
    """Points drawn over the scene: positions (F, M, 3) per frame (NaN rows hidden), an RGB
    colour (0-255) and a diameter (m); ``tag``: a text written beside the first point in the
    scene (e.g. "goal object"), none when empty."""

    name: str
    positions: np.ndarray
    colour: tuple[int, int, int]
    size: float = 0.012
    tag: str = ""


@dataclass(frozen=True)
class Ghost:
    """The goal drawn as a wire copy of the object (its edges, so that it never blends with
    the object where they overlap): shapes (G, V, 3), which[f] the shape of frame f (-1:
    none), and its triangles (E, 3) or segments (E, 2)."""

    shapes: np.ndarray
    which: np.ndarray
    faces: np.ndarray
    colour: tuple[int, int, int] = (40, 160, 230)
    opacity: float = 0.35
    name: str = "goal shape"


@dataclass(frozen=True)
class Region:
    """A translucent disc on the table: centre (3,) (m), radius (m), height (m)."""

    centre: np.ndarray
    radius: float
    height: float = 0.002
    colour: tuple[int, int, int] = (50, 220, 50)
    name: str = "goal region"


@dataclass(frozen=True)
class Episode:
    """One viewable run.

    Attributes:
        name: its label (a trial key, a capture's folder).
        model: the compiled model the states belong to.
        states: (F, ns) state rows of ``spec`` (frames in time order).
        times: (F,) simulation time of each frame (s).
        captions: F one-line texts (stage, action, optimisation at that frame).
        summary: markdown shown beside the scene (metrics, the replay's check).
        spec: mjtState bits of the rows (default ``mjSTATE_INTEGRATION``).
        curves, markers, regions: drawn beside and over the scene.
        ghost: the goal as a translucent object, or None.
        shade: (F, nbody) in [0, 1] per body (NaN: its own colour): how much of each object
            is in the optimiser's set at that frame (the SVR paper's Fig. 1).
        marked_body: a body drawn in red (a blow-up's offender), or None.
        start_frame: the frame shown first.
        replay_error: max |replayed final state - recorded final state| (None: not replayed).
        hidden_geoms: geom ids not drawn (e.g. a goal site's stand-in).
    """

    name: str
    model: mujoco.MjModel
    states: np.ndarray
    times: np.ndarray
    captions: Sequence[str]
    summary: str = ""
    spec: int = INTEGRATION
    curves: Sequence[Curve] = ()
    markers: Sequence[Markers] = ()
    regions: Sequence[Region] = ()
    ghost: Ghost | None = None
    shade: np.ndarray | None = None
    marked_body: int | None = None
    start_frame: int = 0
    replay_error: float | None = None
    hidden_geoms: tuple[int, ...] = field(default_factory=tuple)

    def __post_init__(self):
        check_model(self.model)
        check_spec(self.spec)
        states = self._states()              # blow-up frames may be non-finite
        F = len(states)
        if F < 1:
            raise ValueError(f"episode {self.name!r} has no frames")
        if np.shape(self.times) != (F,) or len(self.captions) != F:
            raise ValueError(f"episode {self.name!r}: times {np.shape(self.times)} and "
                             f"{len(self.captions)} captions for {F} frames")
        for m in self.markers:
            if np.shape(m.positions)[:1] != (F,) or np.shape(m.positions)[2:] != (3,):
                raise ValueError(f"markers {m.name!r} must have shape ({F}, M, 3), got "
                                 f"{np.shape(m.positions)}")
        if self.shade is not None and np.shape(self.shade) != (F, self.model.nbody):
            raise ValueError(f"shade must have shape ({F}, {self.model.nbody}), got "
                             f"{np.shape(self.shade)}")
        for c in self.curves:
            if c.cursor is not None and np.shape(c.cursor) != (F,):
                raise ValueError(f"curve {c.name!r}: cursor must have shape ({F},), got "
                                 f"{np.shape(c.cursor)}")
        if self.ghost is not None and np.shape(self.ghost.which) != (F,):
            raise ValueError(f"ghost.which must have shape ({F},), got "
                             f"{np.shape(self.ghost.which)}")
        check_int(self.start_frame, "start_frame", 0)
        if self.start_frame >= F:
            raise ValueError(f"start_frame {self.start_frame} is beyond the {F} frames")

    def _states(self) -> np.ndarray:
        size = mujoco.mj_stateSize(self.model, self.spec)
        states = np.asarray(self.states, dtype=float)
        if states.ndim != 2 or states.shape[1] != size:
            raise ValueError(f"states must have shape (F, {size}), got {states.shape}")
        return states

    @property
    def n_frames(self) -> int:
        return len(self.states)


# ------------------------------------------------------------------------------ replay
def replay_controls(model: mujoco.MjModel, start_state: np.ndarray, controls: np.ndarray,
                    spec: int = INTEGRATION,
                    control_spec: int = int(mujoco.mjtState.mjSTATE_CTRL)) -> np.ndarray:
    """Re-simulate recorded controls from a recorded start with ``mj_step``, exactly as an MPC
    agent or an executed rollout stepped them: (ns,), (T, nc) -> states (T + 1, ns) of
    ``spec``, row t + 1 the state after step t. As in ``dopt.mpc.MPCResult`` and
    ``RolloutService.trajectory``, row t holds the control executed at step t (row 0 is the
    start with control row 0 set) and the last row the last control.

    ``control_spec``: the mjtState bits one control row sets before each step (``mjSTATE_CTRL``:
    nu values; the pick scenes' picker: ctrl | eq_active).

    Raises:
        TypeError / ValueError: a model that is not an MjModel, a start that is not a valid
            state row of ``spec``, controls that are not finite (T, nc) rows.
    """
    check_model(model)
    spec, control_spec = check_spec(spec), check_spec(control_spec, "control_spec")
    x0 = check_states(model, start_state, spec, batched=False, name="start_state")
    nc = mujoco.mj_stateSize(model, control_spec)
    U = float_array(controls, "controls", ndim=2)
    if U.shape[1] != nc:
        raise ValueError(f"controls must have shape (T, {nc}) for control_spec "
                         f"{control_spec}, got {U.shape}")
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, x0, spec)
    out = np.empty((len(U) + 1, len(x0)))
    out[0] = x0
    for t, row in enumerate(U):
        mujoco.mj_setState(model, data, row, control_spec)
        mujoco.mj_getState(model, data, out[t], spec)       # row t: the control it executes
        mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, out[t + 1], spec)
    return out


def drawable_state(states: np.ndarray, frame: int) -> np.ndarray:
    """Row ``frame`` of states (F, ns), or the last finite row before it (a blow-up's last
    rows can hold NaN, which cannot be drawn)."""
    for f in range(frame, -1, -1):
        if np.isfinite(states[f]).all():
            return states[f]
    return np.nan_to_num(states[frame])


def frame_rows(n_rows: int, max_frames: int, must: Sequence[int] = ()) -> np.ndarray:
    """At most about ``max_frames`` evenly spaced row indices of ``n_rows`` (the first and last
    always, and every index in ``must``), sorted: (F,) int."""
    n_rows, max_frames = check_int(n_rows, "n_rows", 1), check_int(max_frames, "max_frames", 2)
    every = max(1, int(np.ceil((n_rows - 1) / (max_frames - 1))))
    rows = set(range(0, n_rows, every)) | {n_rows - 1}
    rows |= {int(r) for r in must if 0 <= int(r) < n_rows}
    return np.array(sorted(rows), dtype=int)


# ------------------------------------------------------------------------------ sources
def read_record(path: Path) -> dict | None:
    """The JSON object of a file, or of the trial packed under its name in its folder's pack
    (``dopt.lab.trialpack.read_trial_text``), or None when it is not one (logged)."""
    try:
        record = jsonio.loads(read_trial_text(path), strict_numbers=False)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        log.info("%s: not a JSON record (%s)", path, e)
        return None
    return record if isinstance(record, dict) else None


def sources() -> list:
    """The episode sources: the built-in blow-up captures, then every ``dopt.view.sources``
    entry point of the installed distributions (``planners.view``: pick and MPC trials)."""
    from importlib.metadata import entry_points

    found = [BLOWUP_SOURCE]
    for ep in sorted(entry_points(group=ENTRY_POINTS), key=lambda e: e.name):
        try:
            found.append(ep.load())
        except Exception as e:                 # a broken plug-in must not hide the others
            log.warning("episode source %s (%s) failed to load: %s", ep.name, ep.value, e)
    return found


def candidates(path: Path) -> list[Path]:
    """The files and folders under ``path`` a source may claim: ``path`` itself when it is a
    file, a packed trial (its loose file's path) or a blow-up capture; for a folder its JSON
    files, those of its ``trials/`` (not checkpoints, corrupt or outdated ones) and the trials
    packed there (``dopt.lab.trialpack``: each as the path its loose file would have), its
    sub-folders and those of its ``blowups/``, in name order. A pack file
    (``trials/pack.jsonl`` or ``.gz``) stands for its folder, a summary (``summary_folder``) for the
    sweep folder it summarises."""
    path = Path(path)
    if path.name in PACK_NAMES and path.is_file():
        return candidates(path.parent)
    folder = summary_folder(path)
    if folder is not None:
        return candidates(folder)
    if is_stored_trial(path) or (path / "blowup.json").is_file():
        return [path]
    found: list[Path] = []
    for folder in (path, path / "trials", path / "blowups"):
        if not folder.is_dir():
            continue
        names = {}
        for p in folder.iterdir():
            if p.name in SKIPPED_FOLDERS or p.name.startswith("."):
                continue
            if (p.is_file() and p.suffix == ".json") or (p / "blowup.json").is_file():
                names[p.name] = p
        for t in read_pack(folder).values():        # a loose file overrides its packed record
            names.setdefault(t.name, t.path)
        found += [names[n] for n in sorted(names)]
    return found


def summary_folder(path: Path) -> Path | None:
    """The sweep folder a summary file summarises, or None when ``path`` is not a summary (a
    JSON object with "provenance" and no "result"): its own folder when that holds
    ``trials/`` (``OUT/summary.json``), else the ``--out`` of the command that wrote it (a
    recorded ``docs/results/NAME.json``), found from the working folder or from any folder
    above the summary. The folder holds the trials of every summary written into it.

    Raises:
        ValueError: a summary whose trials folder cannot be found (named in the message).
    """
    path = Path(path)
    if not (path.is_file() and path.suffix == ".json"):
        return None
    record = read_record(path)
    if not isinstance(record, dict) or "provenance" not in record or "result" in record:
        return None
    if (path.parent / "trials").is_dir():
        return path.parent
    provenance = record.get("provenance")
    command = provenance.get("command", "") if isinstance(provenance, dict) else ""
    words = shlex.split(command) if isinstance(command, str) else []
    out = next((w.split("=", 1)[1] for w in words if w.startswith("--out=")), None)
    if out is None and "--out" in words[:-1]:
        out = words[words.index("--out") + 1]
    if out is not None:
        for base in (Path.cwd(), *path.resolve().parents):
            if (base / out).is_dir():
                return base / out
    raise ValueError(f"{path} is a summary, but its trials folder was not found "
                     f"(its command's --out: {out!r}); open that folder instead")


def collect(path, source_list: Sequence | None = None) -> dict[str, tuple[object, Path]]:
    """{label: (source, path)} of every episode under ``path`` (a trial file, a trial or result
    folder, a trial pack, a summary, a blow-up capture or a folder of them), labels in file
    order.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        ValueError: nothing under it is an episode any source opens (the message names the
            sources tried).
    """
    path = Path(path)
    if not (path.exists() or is_stored_trial(path)):
        raise FileNotFoundError(f"{path} does not exist (nor is it a packed trial)")
    srcs = sources() if source_list is None else list(source_list)
    out: dict[str, tuple[object, Path]] = {}
    for p in candidates(path):
        trial = not p.is_dir()                      # a file, or a packed trial
        record = read_record(p) if trial else None
        for src in srcs:
            if src.claims(p, record):
                label = p.stem if trial else p.name
                out[label if label not in out else str(p)] = (src, p)
                break
    if not out:
        names = [getattr(s, "name", type(s).__name__) for s in srcs]
        hint = ("" if len(names) > 1 else "; the pick and MPC trial sources need the package "
                "installed: pip install -e .")
        raise ValueError(f"{path}: no trial file, trial folder, pack, summary or blow-up "
                         f"capture found (sources: {', '.join(names)}{hint})")
    return out


# ------------------------------------------------------------------------------ blow-ups
def load_blowup(path, max_frames: int = 400):
    """A capture folder as a ``dopt.view.episode.Episode`` opening at the state after the
    failing step, the offending body marked.

    Raises:
        FileNotFoundError / ValueError: no capture there, or one of another format.
    """
    path = Path(path)
    meta_file = path / "blowup.json"
    if not meta_file.is_file():
        raise FileNotFoundError(f"{path} holds no blowup.json")
    meta = json.loads(meta_file.read_text())
    if meta.get("format") != FORMAT:
        raise ValueError(f"{meta_file}: format {meta.get('format')!r}, expected {FORMAT!r}")
    model = mujoco.MjModel.from_binary_path(str(path / "model.mjb"))
    rows = np.load(path / "states.npy")
    first, step = int(meta["first_row"]), int(meta["step"])
    failing = min(max(step + 1 - first, 0), len(rows) - 1)
    keep = frame_rows(len(rows), max_frames, must=[failing])
    layout = StateLayout.of(model, int(meta["spec"]))
    times = (rows[keep, layout["time"]].ravel() if "time" in layout.slices
             else (first + keep) * model.opt.timestep)
    captions = [f"rollout row {first + r} (after step {first + r - 1})"
                + ("  <- the verdict flagged this step" if r == failing else "")
                for r in keep]
    body = meta.get("body_id")
    summary = (f"**Blow-up** {meta.get('label') or path.name}  \n"
               f"step {step}: {meta['reason']}  \nbody: {meta.get('body')}  \n"
               f"{len(rows)} states kept (rows {first}..{first + len(rows) - 1})")
    return Episode(path.name, model, rows[keep], np.nan_to_num(times), captions, summary,
                   spec=int(meta["spec"]), marked_body=None if body is None else int(body),
                   start_frame=int(np.searchsorted(keep, failing)))


class BlowupSource:
    """The episode source of capture folders (``dopt.view.episode.sources``)."""

    name = "blowup"

    def claims(self, path: Path, record: dict | None) -> bool:
        return record is None and Path(path).is_dir() and (Path(path) / "blowup.json").is_file()

    def load(self, path: Path, max_frames: int = 400):
        return load_blowup(path, max_frames)


BLOWUP_SOURCE = BlowupSource()
