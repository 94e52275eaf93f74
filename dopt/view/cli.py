"""``dopt-view PATH`` (also ``python -m dopt.view PATH``): open trials, MPC episodes and
blow-up captures in the browser, or write one frame as a PNG.

    dopt-view docs/results/runs/fig7-cloth-diagonal          # serve; prints the URL
    dopt-view OUT/trials/simple-seed0-ab12cd34.json --frame 40   # a file, or a packed trial
    dopt-view OUT/blowups/original-seed3 --png blowup.png    # a still, no server

PATH may be a run folder, its ``trials/pack.jsonl.gz``, one trial file (loose or packed), a
summary (``OUT/summary.json`` or a recorded ``docs/results/NAME.json``: the trials of its
sweep folder) or blow-up captures. Serving needs the ``viz`` extra (viser); ``--png`` sets up
offscreen OpenGL itself (``offscreen_gl``: EGL, else OSMesa) unless ``MUJOCO_GL`` is set.
Bad input is one line "dopt-view: error: ..." and exit status 1.
"""

from __future__ import annotations

import argparse
import ctypes.util
import logging
import os
import subprocess
import sys
import time

from dopt.lab.cli import EPILOG, ArgumentParser, guarded, int_at_least, output_file, positive_int

PROG = "dopt-view"
log = logging.getLogger(__name__)


def parser() -> argparse.ArgumentParser:
    p = ArgumentParser(
        prog=PROG, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Replay pick-and-place trials, MPC episodes and blow-up captures in the "
                    "browser (viser, on 127.0.0.1), or write one frame as a PNG.")
    p.add_argument("path", help="a trial file (or the path of a trial packed in its folder's "
                                "pack.jsonl or pack.jsonl.gz), a result or trial folder, a "
                                "pack file, a summary (its sweep's trials), a blow-up capture "
                                "or a folder of them")
    p.add_argument("--trial", help="the episode to open first (its label: the trial file's "
                                   "name without .json, or the capture's folder)")
    p.add_argument("--frame", type=int, default=None,
                   help="the frame to open at (0-based, as the slider counts; -1: the last); "
                        "default: the episode's own (a blow-up's failing step, else 0)")
    p.add_argument("--png", type=output_file,
                   help="write the frame as a PNG, its caption and legend below it, and exit "
                        "(MuJoCo's offscreen renderer; MUJOCO_GL=egl, else osmesa, unless set)")
    p.add_argument("--width", type=positive_int, default=800, help="PNG width (px)")
    p.add_argument("--height", type=positive_int, default=600, help="PNG height (px)")
    p.add_argument("--max-frames", type=int_at_least(2), default=300,
                   help="frames kept per episode (evenly spaced; first and last kept)")
    p.add_argument("--host", default="127.0.0.1", help="address to serve on")
    p.add_argument("--port", type=positive_int, default=8080,
                   help="port to serve on (the next free one when taken)")
    p.add_argument("--list", action="store_true", help="list the episodes found and exit")
    p.add_argument("-v", "--verbose", action="store_true", help="log what is loaded")
    return p


@guarded(PROG)
def main(argv=None) -> int:
    args = parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="%(levelname)s %(name)s: %(message)s")
    chosen = offscreen_gl() if args.png is not None else None
    from dopt.view.episode import collect

    entries = collect(args.path)
    if args.trial is not None and args.trial not in entries:
        raise ValueError(f"no episode {args.trial!r} under {args.path}; there are "
                         f"{', '.join(list(entries)[:8])}{' ...' if len(entries) > 8 else ''}")
    if args.list:
        for label, (source, path) in entries.items():
            print(f"{label}\t{source.name}\t{path}")
        return 0
    first = args.trial or next(iter(entries))
    if args.png is not None:
        try:
            return _still(entries, first, args)
        except Exception as e:
            if chosen != "egl" or not _gl_failure(e) or not _has_library("OSMesa"):
                raise
            log.warning("EGL failed (%s); rendering with OSMesa", e)
            env = {**os.environ, "MUJOCO_GL": "osmesa", "PYOPENGL_PLATFORM": "osmesa"}
            return subprocess.run([sys.executable, "-m", "dopt.view", *_argv(argv)],
                                  env=env, check=False).returncode
    return _serve(entries, first, args)


def offscreen_gl(env=None) -> str | None:
    """Choose MuJoCo's offscreen OpenGL backend before MuJoCo is imported, in ``env`` (a
    mapping; None: this process's environment): the one ``PYOPENGL_PLATFORM`` names (egl,
    osmesa), else ``MUJOCO_GL=egl`` where libEGL is found, else ``osmesa`` where libOSMesa
    is, with ``PYOPENGL_PLATFORM`` to match; returns what it set, or None when ``MUJOCO_GL``
    was already set (the user's choice stands) or this process imported MuJoCo already (it
    read the variable then; logged)."""
    if env is None:
        env = os.environ
        if not env.get("MUJOCO_GL") and "mujoco" in sys.modules:
            log.warning("MuJoCo was imported before the offscreen context was chosen; set "
                        "MUJOCO_GL=egl for a still")
            return None
    if env.get("MUJOCO_GL"):
        return None
    platform = env.get("PYOPENGL_PLATFORM", "").lower()
    if platform in ("egl", "osmesa"):
        backend = platform
    else:
        backend = "egl" if _has_library("EGL") or not _has_library("OSMesa") else "osmesa"
    env["MUJOCO_GL"] = backend
    env.setdefault("PYOPENGL_PLATFORM", backend)
    return backend


def _has_library(name: str) -> bool:
    return ctypes.util.find_library(name) is not None


def _gl_failure(e: BaseException) -> bool:
    return any(w in f"{type(e).__name__} {e}" for w in ("EGL", "OpenGL", "gladLoadGL", "GL"))


def _argv(argv) -> list[str]:
    return list(sys.argv[1:] if argv is None else argv)


def _frame(frame: int | None, n_frames: int, default: int) -> int:
    if frame is None:
        return default
    k = frame + n_frames if frame < 0 else frame
    if not 0 <= k < n_frames:
        raise ValueError(f"--frame {frame} is outside the episode's {n_frames} frames "
                         f"(0..{n_frames - 1}, or -1 for the last)")
    return k


def _still(entries: dict, first: str, args) -> int:
    from dopt.view.still import write_png

    source, path = entries[first]
    ep = source.load(path, args.max_frames)
    k = _frame(args.frame, ep.n_frames, ep.start_frame)
    out = write_png(ep, k, args.png, args.width, args.height)
    print(f"{PROG}: wrote {out} ({first}, frame {k} of {ep.n_frames})")
    return 0


def _serve(entries: dict, first: str, args) -> int:
    try:
        import viser  # noqa: F401
    except ImportError:
        raise RuntimeError("serving needs viser: pip install -e '.[viz]' (or write a still "
                           "with --png)") from None
    from dopt.view.player import Viewer

    viewer = Viewer(entries, args.host, args.port, args.max_frames, first=first)
    if args.frame is not None:
        viewer.show(_frame(args.frame, viewer.episode.n_frames, 0))
    print(f"{PROG}: {len(entries)} episode(s) from {args.path} at {viewer.url} "
          f"(Ctrl-C stops)", flush=True)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        viewer.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
