"""Packing a sweep's loose trial files into its pack: ``pack_trials`` and its ``PackResult``.

``pack_trials`` appends the loose ``OUT/trials/<key>.json`` files of a sweep folder
(``dopt.lab.sweep_store``) to ``OUT/trials/pack.jsonl`` (``dopt.lab.trialpack``, the one reader and
writer of packs: uncompressed and append-only, so that git stores a re-pack as the delta of its
new lines), holding the folder's ``OutLock``; ``python -m dopt.lab.sweep pack OUT`` runs it. An
earlier ``pack.jsonl.gz`` is read and left as it is: a loose file whose record it already holds
is not packed again, a newer one is appended to ``pack.jsonl`` and overrides it. A loose file
is deleted only once the packs read back its record. A packed record that a newer loose file
replaces stays on its line (``PackResult.replaced`` names it). ``repair=True`` first repairs a
``pack.jsonl`` whose last line was cut (``dopt.lab.trialpack.repair_pack``; the cut line goes to
``OUT/trials/corrupt/``). ``dopt.lab.sweep`` and ``dopt.lab.sweep_store`` re-export both names.

Standard library only (with ``dopt.lab.jsonio``, ``dopt.lab.sweep_store`` and
``dopt.lab.trialpack``).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path

from dopt.lab import jsonio
from dopt.lab.sweep_store import CORRUPT_DIR, OutLock, check_record
from dopt.lab.trialpack import append_pack, loose_files, pack_path, read_pack, repair_pack

log = logging.getLogger("dopt.lab.sweep")


@dataclass(frozen=True)
class PackResult:
    """What ``pack_trials`` did to one sweep folder.

    Attributes:
        pack: the folder's ``pack.jsonl`` (None when it has none: nothing was ever appended).
        n: records in the folder's packs now (``pack.jsonl`` and ``pack.jsonl.gz`` together);
            size: ``pack.jsonl``'s bytes.
        added: keys of the loose files packed (their files deleted; a file whose record the
            packs held already is deleted without being appended).
        replaced: {key: where its old packed record stays (pack and line)} of the packed
            records a newer loose file replaced (appended after them: packs are never
            rewritten).
        left: {file name: why} of the loose files not packed (not trial records: left where
            they are; a sweep moves them aside when it reads them).
        repaired: where the cut last line of ``pack.jsonl`` went (``repair=True``; the pack
            itself when only its newline was missing), else None.
    """

    out_dir: Path
    pack: Path | None
    n: int
    size: int
    added: list
    replaced: dict
    left: dict
    repaired: Path | None = None

    def line(self) -> str:
        """One line: the folder, records packed, loose files added and left."""
        return (f"{self.out_dir}: {self.n} trials packed"
                + (f", {self.pack} holds {self.size / 1e6:.2f} MB" if self.pack else "")
                + (f"; its cut last line repaired ({self.repaired})" if self.repaired else "")
                + f"; {len(self.added)} loose files packed and deleted"
                + (f", {len(self.replaced)} packed records replaced (the old lines stay)"
                   if self.replaced else "")
                + (f"; {len(self.left)} files left loose (not trial records): "
                   + "; ".join(f"{k}: {v}" for k, v in self.left.items()) if self.left else ""))


def _one_line(path: Path) -> str:
    """The record of the loose trial file ``path`` as one line of strict JSON (the file's text
    when it was written by ``dopt.lab.jsonio``; a bare NaN of an older file becomes its note)."""
    return jsonio.dumps(jsonio.loads(path.read_text(), restore_values=False,
                                     strict_numbers=False))


def _same(text_a: str, text_b: str) -> bool:
    """Whether two JSON texts load (``dopt.lab.jsonio.loads``) as the same record, member order
    and NaN included."""
    def load(t):
        return json.dumps(jsonio.loads(t, strict_numbers=False))
    return load(text_a) == load(text_b)


def _packable(path: Path) -> tuple[str | None, str | None]:
    """(its line, None) of a loose trial file that can be packed, else (None, why not)."""
    _, problem = check_record(path)
    if problem is not None:
        return None, problem
    try:
        line = _one_line(path)
    except (OSError, ValueError, TypeError) as e:
        return None, f"cannot be written as one line ({type(e).__name__}: {e})"
    if not _same(line, path.read_text()):
        return None, "its record does not survive re-serialising"
    return line, None


def pack_trials(out_dir: Path | str, *, repair: bool = False) -> PackResult:
    """Append the loose trial files of a sweep folder to its pack (``dopt.lab.trialpack``): every
    valid record (``check_record``, any schema) the packs do not hold already (as the same
    record) is appended to ``pack.jsonl``, in key order, replacing the packed record of its
    key (the old line stays); the pack is read back, and each loose file is deleted only once
    the packs give the same record as the file. Checkpoints, corrupt/ and outdated/ are left
    alone. Holds the folder's lock (``OutLock``): a sweep running on it refuses, and packing
    waits for none. ``repair``: repair a cut last line of ``pack.jsonl`` first
    (``dopt.lab.trialpack.repair_pack``, the cut line kept under OUT/trials/corrupt/).

    Raises:
        FileNotFoundError: ``out_dir`` has no trials/ folder.
        dopt.lab.trialpack.PackError: a pack cannot be read (nothing is changed;
            ``CutPackError``: a cut last line, without ``repair``).
        SweepLockedError: a sweep runs on ``out_dir``.
        RuntimeError: the pack does not read back as written (no loose file is deleted).
    """
    out_dir = Path(out_dir)
    folder = out_dir / "trials"
    if not folder.is_dir():
        raise FileNotFoundError(f"{out_dir} has no trials/ folder (not a sweep's folder)")
    with OutLock(out_dir):
        repaired = repair_pack(folder, folder / CORRUPT_DIR) if repair else None
        packed = read_pack(folder)
        new: dict[str, str] = {}
        taken: dict[str, Path] = {}
        replaced: dict[str, str] = {}
        left: dict[str, str] = {}
        for key, path in loose_files(folder).items():
            line, problem = _packable(path)
            if problem is not None:
                left[path.name] = problem
                continue
            old = packed.get(key)
            if old is None or not _same(old.text, line):
                new[key] = line
                if old is not None:
                    replaced[key] = f"{old.pack} line {old.line}"
            taken[key] = path
        pack = append_pack(folder, new)
        back = read_pack(folder)
        for key, path in taken.items():
            if key not in back or not _same(back[key].text, path.read_text()):
                raise RuntimeError(f"{pack_path(folder)}: the record of {key} does not read "
                                   f"back as {path} holds it; no loose file was deleted")
        for path in taken.values():
            path.unlink()
        log.info("%s: %d trials packed (%d loose files added, %d appended to %s)", out_dir,
                 len(back), len(taken), len(new), pack)
        return PackResult(out_dir, pack, len(back), pack.stat().st_size if pack else 0,
                          sorted(taken), replaced, left, repaired)


__all__ = ["PackResult", "pack_trials"]
