"""A sweep's finished trials packed into one compressed file, and the one reader of them all.

A trial folder (``OUT/trials``, ``dopt.sweep``) holds its finished trials two ways:

- loose, one file per trial, ``<key>.json`` (what a running sweep writes);
- packed, ``PACK_NAME`` (``pack.jsonl.gz``): one line per trial, the JSON record its loose file
  held (strict JSON, ``json.dumps`` of it, so the line is the file's text), lines sorted by
  key, gzip-compressed with a fixed level and no timestamp or name, so packing the same
  records gives the same bytes (``pack_bytes``).

A loose file overrides the packed record of the same key: it is newer (a trial recomputed
since the pack was written). ``stored_trials`` lists a folder's trials both ways, as
``StoredTrial`` (read like a file: ``name``, ``stem``, ``parent``, ``read_text()``), and
``read_trial_text`` reads one by its loose file's path, packed or not; every reader of trial
records (``dopt.sweep``, ``experiments/report*.py``, ``experiments/resummarize.py``,
``dopt-view``) goes through them. ``write_pack`` writes a pack and reads it back;
``dopt.sweep.pack_trials`` (``python -m dopt.sweep pack OUT``) merges loose files into it.

A pack is written only by ``write_pack`` and checked when it is written, so a pack that cannot
be read (not gzip, truncated, a line that is not a JSON object with a valid "key", a key twice)
is a ``PackError`` (a ValueError) naming the pack and the line, never skipped: its trials are
committed results, and recomputing thousands of them silently is worse than stopping.

Standard library only (``experiments/report.py`` reads trials through it).
"""

from __future__ import annotations

import gzip
import io
import json
import zlib
from dataclasses import dataclass
from pathlib import Path

from dopt.jsonio import replace_atomic

#: the pack's file name inside a trial folder
PACK_NAME = "pack.jsonl.gz"
#: gzip's compression level of a pack (fixed: the same records give the same bytes)
COMPRESS_LEVEL = 9

#: {pack path: ((mtime_ns, size, inode), {key: StoredTrial})}: a pack is read once per change
_CACHE: dict[str, tuple[tuple, dict]] = {}


class PackError(ValueError):
    """A pack that cannot be read; the message names the pack (and the line)."""


@dataclass(frozen=True)
class StoredTrial:
    """One finished trial as its folder stores it, read like its loose file.

    Attributes:
        path: the loose file's path, ``<folder>/<key>.json`` (it need not exist when the
            trial is packed).
        text: the record's JSON text when packed (None: the loose file holds it).
        pack: the pack holding it (None when loose); line: its line there (1-based).
    """

    path: Path
    text: str | None = None
    pack: Path | None = None
    line: int | None = None

    @property
    def name(self) -> str:
        return self.path.name

    @property
    def stem(self) -> str:
        return self.path.stem

    @property
    def parent(self) -> Path:
        return self.path.parent

    @property
    def packed(self) -> bool:
        return self.text is not None

    def read_text(self) -> str:
        """The record's JSON text (OSError for a loose file that cannot be read)."""
        return self.text if self.text is not None else self.path.read_text()

    def read_bytes(self) -> bytes:
        return self.text.encode() if self.text is not None else self.path.read_bytes()

    def __str__(self) -> str:
        return (f"{self.pack} line {self.line} ({self.name})" if self.packed
                else str(self.path))


def pack_path(folder: Path | str) -> Path:
    """The pack of the trial folder ``folder`` (``<folder>/pack.jsonl.gz``)."""
    return Path(folder) / PACK_NAME


def _key_problem(key) -> str | None:
    if not isinstance(key, str) or not key:
        return f"its key {key!r} is not a non-empty string"
    if any(ch in key for ch in "/\\\0") or key.startswith("."):
        return f"its key {key!r} is not a valid file name"
    return None


def parse_pack(data: bytes, where: Path | str) -> dict[str, tuple[int, str]]:
    """{key: (line number, line text)} of a pack's compressed bytes ``data`` (``where`` names it
    in errors), in line order.

    Raises:
        PackError: not gzip, truncated, not UTF-8, a line that is not a JSON object with a
            valid "key", or a key twice.
    """
    try:
        text = gzip.decompress(data).decode("utf-8")
    except (OSError, EOFError, zlib.error, UnicodeDecodeError) as e:
        raise PackError(f"trial pack {where} cannot be read ({type(e).__name__}: {e}); "
                        f"restore it from git (git checkout -- {where})") from None
    out: dict[str, tuple[int, str]] = {}
    for n, line in enumerate(text.split("\n"), 1):
        if not line:
            continue
        try:
            rec = json.loads(line)
        except ValueError as e:
            raise PackError(f"trial pack {where} line {n}: not valid JSON ({e})") from None
        if not isinstance(rec, dict):
            raise PackError(f"trial pack {where} line {n}: not a trial record (a JSON "
                            f"{type(rec).__name__}, not an object)")
        if (problem := _key_problem(rec.get("key"))) is not None:
            raise PackError(f"trial pack {where} line {n}: {problem}")
        if rec["key"] in out:
            raise PackError(f"trial pack {where} line {n}: key {rec['key']!r} is packed "
                            f"twice (first on line {out[rec['key']][0]})")
        out[rec["key"]] = (n, line)
    return out


def read_pack(folder: Path | str) -> dict[str, StoredTrial]:
    """{key: StoredTrial} of the records packed in the trial folder ``folder`` (in line order;
    {} when it has no pack). Read once per change of the file.

    Raises:
        PackError: the pack cannot be read (``parse_pack``).
    """
    path = pack_path(folder)
    try:
        st = path.stat()
    except (FileNotFoundError, NotADirectoryError):
        return {}
    stamp = (st.st_mtime_ns, st.st_size, st.st_ino)
    cached = _CACHE.get(str(path))
    if cached is not None and cached[0] == stamp:
        return dict(cached[1])
    lines = parse_pack(path.read_bytes(), path)
    trials = {k: StoredTrial(Path(folder) / f"{k}.json", text, path, n)
              for k, (n, text) in lines.items()}
    _CACHE[str(path)] = (stamp, trials)
    return dict(trials)


def loose_files(folder: Path | str) -> dict[str, Path]:
    """{file stem: path} of the loose trial files of ``folder`` (``*.json``; hidden files, the
    temporary files of killed writes, left out), in name order."""
    folder = Path(folder)
    if not folder.is_dir():
        return {}
    return {p.stem: p for p in sorted(folder.glob("*.json"))
            if not p.name.startswith(".") and p.is_file()}


def stored_trials(folder: Path | str) -> list[StoredTrial]:
    """Every finished trial of the trial folder ``folder``: its loose files, and its packed
    records whose key has no loose file (a loose file overrides the packed record), in file
    name order. Nothing is checked beyond the pack's lines (``read_pack``).

    Raises:
        PackError: the pack cannot be read.
    """
    packed = read_pack(folder)
    loose = {k: StoredTrial(p) for k, p in loose_files(folder).items()}
    merged = {**{k: t for k, t in packed.items() if k not in loose}, **loose}
    return [merged[k] for k in sorted(merged, key=lambda k: f"{k}.json")]


def read_trial_text(path: Path | str) -> str:
    """The JSON text of the trial whose loose file is ``path`` (``<folder>/<key>.json``): the
    file when it exists, else the record packed under that key in the folder's pack.

    Raises:
        FileNotFoundError: neither exists. PackError: the pack cannot be read.
    """
    path = Path(path)
    if path.is_file():
        return path.read_text()
    found = read_pack(path.parent).get(path.stem) if path.suffix == ".json" else None
    if found is None:
        raise FileNotFoundError(f"{path}: no such trial file, nor packed in "
                                f"{pack_path(path.parent)}")
    return found.text


def is_stored_trial(path: Path | str) -> bool:
    """Whether ``path`` is a loose trial file or names a packed one (``read_trial_text``)."""
    path = Path(path)
    if path.is_file():
        return True
    try:
        return path.suffix == ".json" and path.stem in read_pack(path.parent)
    except PackError:
        return False


def pack_bytes(lines: dict[str, str]) -> bytes:
    """The pack of {key: record's JSON text on one line}: the lines sorted by key, each ended
    by a newline, gzip at ``COMPRESS_LEVEL`` without name or timestamp (the same records give
    the same bytes)."""
    for k, line in lines.items():
        if "\n" in line or "\r" in line:
            raise ValueError(f"the record of {k!r} is not one line")
    text = "".join(lines[k] + "\n" for k in sorted(lines))
    buf = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", compresslevel=COMPRESS_LEVEL, fileobj=buf,
                       mtime=0) as f:
        f.write(text.encode("utf-8"))
    return buf.getvalue()


def write_pack(folder: Path | str, lines: dict[str, str]) -> Path:
    """Write the pack of {key: JSON text} into the trial folder ``folder`` atomically (a
    temporary file, then renamed over the pack) unless the pack holds exactly these lines
    already (it is then left as it is), and read it back.

    Raises:
        RuntimeError: the pack read back does not hold exactly ``lines`` (the old pack is
            put back when there was one).
    """
    path = pack_path(folder)
    if path.is_file() and {k: t.text for k, t in read_pack(folder).items()} == lines:
        return path
    data = pack_bytes(lines)
    old = path.read_bytes() if path.is_file() else None
    replace_atomic(path, data, suffix=".jsonl.gz", fsync=True)
    back = {k: t.text for k, t in read_pack(folder).items()}
    if back != lines:
        if old is not None:
            replace_atomic(path, old, suffix=".jsonl.gz", fsync=True)
        raise RuntimeError(f"trial pack {path} does not read back as written")
    return path


__all__ = ["COMPRESS_LEVEL", "PACK_NAME", "PackError", "StoredTrial", "is_stored_trial",
           "loose_files", "pack_bytes", "pack_path", "parse_pack", "read_pack",
           "read_trial_text", "stored_trials", "write_pack"]
