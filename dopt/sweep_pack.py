"""Packing a sweep's loose trial files into its pack: ``pack_trials`` and its ``PackResult``.

``pack_trials`` merges the loose ``OUT/trials/<key>.json`` files of a sweep folder
(``dopt.sweep_store``) into ``OUT/trials/pack.jsonl.gz`` (``dopt.trialpack``, the one reader
and writer of packs), holding the folder's ``OutLock``; ``python -m dopt.sweep pack OUT`` runs
it. A loose file is deleted only once its packed line reads back as the same record; a packed
record a newer loose file replaces is kept under ``OUT/trials/outdated/``. ``dopt.sweep`` and
``dopt.sweep_store`` re-export both names.

Standard library only (with ``dopt.jsonio``, ``dopt.sweep_store`` and ``dopt.trialpack``).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path

from dopt import jsonio
from dopt.sweep_store import OUTDATED_DIR, OutLock, check_record
from dopt.trialpack import loose_files, read_pack, write_pack

log = logging.getLogger("dopt.sweep")


@dataclass(frozen=True)
class PackResult:
    """What ``pack_trials`` did to one sweep folder.

    Attributes:
        pack: the pack (``OUT/trials/pack.jsonl.gz``; None when there was nothing to pack).
        n: records in the pack now; size: its bytes.
        added: keys of the loose files packed (their files deleted).
        replaced: {key: where its old packed record went} of the packed records a newer loose
            file replaced (kept under OUT/trials/outdated/, never deleted).
        left: {file name: why} of the loose files not packed (not trial records: left where
            they are; a sweep moves them aside when it reads them).
    """

    out_dir: Path
    pack: Path | None
    n: int
    size: int
    added: list
    replaced: dict
    left: dict

    def line(self) -> str:
        """One line: the folder, records packed, loose files added and left."""
        return (f"{self.out_dir}: {self.n} trials in {self.pack or 'no pack'} "
                f"({self.size / 1e6:.2f} MB); {len(self.added)} loose files packed and deleted"
                + (f", {len(self.replaced)} packed records replaced (old ones under "
                   f"trials/{OUTDATED_DIR}/)" if self.replaced else "")
                + (f"; {len(self.left)} files left loose (not trial records): "
                   + "; ".join(f"{k}: {v}" for k, v in self.left.items()) if self.left else ""))


def _one_line(path: Path) -> str:
    """The record of the loose trial file ``path`` as one line of strict JSON (the file's text
    when it was written by ``dopt.jsonio``; a bare NaN of an older file becomes its note)."""
    return jsonio.dumps(jsonio.loads(path.read_text(), restore_values=False,
                                     strict_numbers=False))


def _same(text_a: str, text_b: str) -> bool:
    """Whether two JSON texts load (``dopt.jsonio.loads``) as the same record, member order
    and NaN included."""
    def load(t):
        return json.dumps(jsonio.loads(t, strict_numbers=False))
    return load(text_a) == load(text_b)


def _keep_outdated(folder: Path, key: str, text: str) -> Path:
    """Write a replaced packed record to OUT/trials/outdated/ under a free name."""
    dest_dir = folder / OUTDATED_DIR
    dest, n = dest_dir / f"{key}.json", 0
    while dest.exists():
        n += 1
        dest = dest_dir / f"{key}.{n}.json"
    jsonio.write_atomic(dest, json.loads(text))
    return dest


def pack_trials(out_dir: Path | str) -> PackResult:
    """Merge the loose trial files of a sweep folder into its pack (``dopt.trialpack``):
    every valid record (``check_record``, any schema) joins the pack, a loose file replacing
    the packed record of its key (the old one is written to OUT/trials/outdated/); the pack is
    written (only when its records change: the same records give the same bytes) and read
    back, and each loose file is deleted only once its line in the pack loads as the same
    record as the file. Checkpoints, corrupt/ and outdated/ are left alone. Holds the folder's
    lock (``OutLock``): a sweep running on it refuses, and packing waits for none.

    Raises:
        FileNotFoundError: ``out_dir`` has no trials/ folder.
        dopt.trialpack.PackError: the existing pack cannot be read (nothing is changed).
        SweepLockedError: a sweep runs on ``out_dir``.
        RuntimeError: the pack does not read back as written (no loose file is deleted).
    """
    out_dir = Path(out_dir)
    folder = out_dir / "trials"
    if not folder.is_dir():
        raise FileNotFoundError(f"{out_dir} has no trials/ folder (not a sweep's folder)")
    with OutLock(out_dir):
        lines = {k: t.text for k, t in read_pack(folder).items()}
        taken: dict[str, Path] = {}
        replaced: dict[str, str] = {}
        left: dict[str, str] = {}
        for key, path in loose_files(folder).items():
            rec, problem = check_record(path)
            if problem is None:
                try:
                    line = _one_line(path)
                    if not _same(line, path.read_text()):
                        problem = "its record does not survive re-serialising"
                except (OSError, ValueError, TypeError) as e:
                    problem = f"cannot be written as one line ({type(e).__name__}: {e})"
            if problem is not None:
                left[path.name] = problem
                continue
            if key in lines and not _same(lines[key], line):
                replaced[key] = lines[key]
            lines[key] = line
            taken[key] = path
        if not lines:
            return PackResult(out_dir, None, 0, 0, [], {}, left)
        kept = {k: _keep_outdated(folder, k, text) for k, text in replaced.items()}
        pack = write_pack(folder, lines)
        back = read_pack(folder)
        for key, path in taken.items():
            if key not in back or not _same(back[key].text, path.read_text()):
                raise RuntimeError(f"{pack}: the record of {key} does not read back as "
                                   f"{path} holds it; no loose file was deleted")
        for path in taken.values():
            path.unlink()
        log.info("%s: %d trials packed in %s (%d loose files added)", out_dir, len(lines),
                 pack, len(taken))
        return PackResult(out_dir, pack, len(lines), pack.stat().st_size, sorted(taken),
                          {k: str(v) for k, v in kept.items()}, left)

__all__ = ["PackResult", "pack_trials"]
