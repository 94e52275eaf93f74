"""A sweep's finished trials packed in one append-only file, and the one reader of them all.

A trial folder (``OUT/trials``, ``dopt.lab.sweep``) holds its finished trials three ways, each
overriding the one before it for the same key:

1. ``GZIP_PACK_NAME`` (``pack.jsonl.gz``), the earlier packs: one line per trial, sorted by key,
   gzip-compressed. Read only: nothing writes them any more, and they are never rewritten or
   deleted (git keeps every copy anyway).
2. ``PACK_NAME`` (``pack.jsonl``), the pack written now: one line per trial, the JSON record
   its loose file held (strict JSON, so the line is the file's text), uncompressed and
   append-only: ``append_pack`` writes the old bytes and then the new lines (sorted by key),
   never changing a line written before, so that git stores a re-pack as a delta of the new
   lines (a compressed pack differs everywhere and costs its full size in history each time).
   A key may recur: a later line replaces an earlier one (a trial recomputed since), and the
   earlier line stays where it was.
3. loose, one file per trial, ``<key>.json`` (what a running sweep writes).

``stored_trials`` lists a folder's trials all three ways, as ``StoredTrial`` (read like a file:
``name``, ``stem``, ``parent``, ``read_text()``), and ``read_trial_text`` reads one by its loose
file's path, packed or not; every reader of trial records (``dopt.lab.sweep``,
``experiments/report*.py``, ``experiments/resummarize.py``, ``dopt-view``) goes through them.
``dopt.lab.sweep.pack_trials`` (``python -m dopt.lab.sweep pack OUT``) appends the loose files
to the
pack.

A pack that cannot be read (not gzip, not UTF-8, a line that is not a JSON object with a valid
"key", a key twice in a gzip pack) is a ``PackError`` (a ValueError) naming the pack and the
line, never skipped: its trials are committed results, and recomputing thousands of them
silently is worse than stopping. A ``pack.jsonl`` whose last line has no newline (a copy or a
write that stopped midway: ``append_pack`` itself writes atomically) is a ``CutPackError``
that says how to repair it (``repair_pack``: the whole lines before it are kept).

Standard library only (``experiments/report.py`` reads trials through it).
"""

from __future__ import annotations

import gzip
import json
import zlib
from dataclasses import dataclass
from pathlib import Path

from dopt.lab.jsonio import replace_atomic

#: the pack written now, inside a trial folder: uncompressed, append-only
PACK_NAME = "pack.jsonl"
#: the earlier packs' name (gzip): read, never written
GZIP_PACK_NAME = "pack.jsonl.gz"
#: every pack's name, lowest precedence first (a loose file overrides them all)
PACK_NAMES = (GZIP_PACK_NAME, PACK_NAME)

#: {pack path: ((mtime_ns, size, inode), {key: StoredTrial})}: a pack is read once per change
_CACHE: dict[str, tuple[tuple, dict]] = {}


class PackError(ValueError):
    """A pack that cannot be read; the message names the pack (and the line)."""


class CutPackError(PackError):
    """A ``pack.jsonl`` whose last line has no newline (a write or a copy that stopped
    midway). ``path``: the pack; ``whole``: the bytes of its whole lines (kept by
    ``repair_pack``); ``line``: the cut line's number (1-based)."""

    def __init__(self, path: Path | str, whole: int, line: int):
        self.path, self.whole, self.line = Path(path), whole, line
        super().__init__(
            f"trial pack {path} line {line} is cut short (no newline ends it: a write or a "
            f"copy stopped midway); the {line - 1} lines before it are whole. Run "
            f"`python -m dopt.lab.sweep pack --repair OUT` to keep them and move the cut line to "
            f"trials/corrupt/, or restore the pack from git (git checkout -- {path})")


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
    """The pack ``append_pack`` writes in the trial folder ``folder`` (``<folder>/pack.jsonl``;
    it need not exist)."""
    return Path(folder) / PACK_NAME


def _key_problem(key) -> str | None:
    if not isinstance(key, str) or not key:
        return f"its key {key!r} is not a non-empty string"
    if any(ch in key for ch in "/\\\0") or key.startswith("."):
        return f"its key {key!r} is not a valid file name"
    return None


def _decode(data: bytes, where: Path | str) -> str:
    """The text of a pack's bytes (gunzipped when ``where`` names a gzip pack)."""
    try:
        if Path(where).name.endswith(".gz"):
            data = gzip.decompress(data)
        return data.decode("utf-8")
    except (OSError, EOFError, zlib.error, UnicodeDecodeError) as e:
        raise PackError(f"trial pack {where} cannot be read ({type(e).__name__}: {e}); "
                        f"restore it from git (git checkout -- {where})") from None


def parse_pack(data: bytes, where: Path | str) -> dict[str, tuple[int, str]]:
    """{key: (line number, line text)} of a pack's bytes ``data``, ordered by line. ``where``
    names the pack in errors and gives its format: a name ending in ``.gz`` is a gzip pack
    (each key once), any other an append-only ``pack.jsonl`` (a key's last line counts).

    Raises:
        CutPackError: a ``pack.jsonl`` whose last line has no newline.
        PackError: not gzip, truncated gzip, not UTF-8, a line that is not a JSON object with
            a valid "key", or a key twice in a gzip pack.
    """
    appended = not Path(where).name.endswith(".gz")
    if appended and data and not data.endswith(b"\n"):
        whole = data.rfind(b"\n") + 1
        raise CutPackError(where, whole, data.count(b"\n", 0, whole) + 1)
    out: dict[str, tuple[int, str]] = {}
    for n, line in enumerate(_decode(data, where).split("\n"), 1):
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
        if rec["key"] in out and not appended:
            raise PackError(f"trial pack {where} line {n}: key {rec['key']!r} is packed "
                            f"twice (first on line {out[rec['key']][0]})")
        out.pop(rec["key"], None)                   # an appended line replaces an earlier one
        out[rec["key"]] = (n, line)
    return out


def _read_one(path: Path) -> dict[str, StoredTrial]:
    """{key: StoredTrial} of one pack file ({} when there is none), read once per change."""
    try:
        st = path.stat()
    except (FileNotFoundError, NotADirectoryError):
        return {}
    stamp = (st.st_mtime_ns, st.st_size, st.st_ino)
    cached = _CACHE.get(str(path))
    if cached is not None and cached[0] == stamp:
        return cached[1]
    lines = parse_pack(path.read_bytes(), path)
    trials = {k: StoredTrial(path.parent / f"{k}.json", text, path, n)
              for k, (n, text) in lines.items()}
    _CACHE[str(path)] = (stamp, trials)
    return trials


def read_pack(folder: Path | str, names=PACK_NAMES) -> dict[str, StoredTrial]:
    """{key: StoredTrial} of the records packed in the trial folder ``folder``: those of its
    packs ``names`` (default: both, ``PACK_NAMES``), a ``pack.jsonl`` record overriding the
    ``pack.jsonl.gz`` one of its key; {} when it has none.

    Raises:
        PackError: a pack cannot be read (``parse_pack``; CutPackError: a cut last line).
    """
    merged: dict[str, StoredTrial] = {}
    for name in PACK_NAMES:
        if name in names:
            merged.update(_read_one(Path(folder) / name))
    return merged


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
    name order. Nothing is checked beyond the packs' lines (``read_pack``).

    Raises:
        PackError: a pack cannot be read.
    """
    packed = read_pack(folder)
    loose = {k: StoredTrial(p) for k, p in loose_files(folder).items()}
    merged = {**{k: t for k, t in packed.items() if k not in loose}, **loose}
    return [merged[k] for k in sorted(merged, key=lambda k: f"{k}.json")]


def read_trial_text(path: Path | str) -> str:
    """The JSON text of the trial whose loose file is ``path`` (``<folder>/<key>.json``): the
    file when it exists, else the record packed under that key in the folder's packs.

    Raises:
        FileNotFoundError: neither exists. PackError: a pack cannot be read.
    """
    path = Path(path)
    if path.is_file():
        return path.read_text()
    found = read_pack(path.parent).get(path.stem) if path.suffix == ".json" else None
    if found is None:
        raise FileNotFoundError(f"{path}: no such trial file, nor packed in "
                                f"{path.parent}/{{{','.join(PACK_NAMES)}}}")
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
    """The lines ``append_pack`` adds for {key: record's JSON text on one line}: sorted by key,
    each ended by a newline, UTF-8 (the same records give the same bytes)."""
    for k, line in lines.items():
        if "\n" in line or "\r" in line:
            raise ValueError(f"the record of {k!r} is not one line")
    return "".join(lines[k] + "\n" for k in sorted(lines)).encode("utf-8")


def append_pack(folder: Path | str, lines: dict[str, str]) -> Path | None:
    """Append to the trial folder's ``pack.jsonl`` the records of {key: JSON text} that its
    packs do not hold as they are (new keys, and new texts of packed keys, which then replace
    the old lines: those stay), sorted by key, and read it back. The file is written whole and
    atomically (its old bytes, then the new lines: a temporary file renamed over it), and left
    as it is when there is nothing to add. Returns the pack (None: there is none).

    Raises:
        PackError: a pack cannot be read (nothing is written).
        RuntimeError: the pack does not read back as the old bytes followed by the new
            records (the old pack is put back).
    """
    path = pack_path(folder)
    held = {k: t.text for k, t in read_pack(folder).items()}
    new = {k: text for k, text in lines.items() if held.get(k) != text}
    if not new:
        return path if path.is_file() else None
    old = path.read_bytes() if path.is_file() else None
    data = (old or b"") + pack_bytes(new)
    replace_atomic(path, data, fsync=True)
    back = {k: t.text for k, t in read_pack(folder).items()}
    if back != {**held, **new} or not path.read_bytes().startswith(old or b""):
        if old is not None:
            replace_atomic(path, old, fsync=True)
        else:
            path.unlink()
        raise RuntimeError(f"trial pack {path} does not read back as written")
    return path


def repair_pack(folder: Path | str, keep_dir: Path | str) -> Path | None:
    """Repair a ``pack.jsonl`` whose last line has no newline (``CutPackError``), atomically.
    A last line that is a whole record (only its newline missing) gets its newline; any other
    is written to a free name ``pack.jsonl.cut[.N]`` in ``keep_dir`` (never deleted) and the
    pack cut back to its whole lines. Returns the pack when a newline was added, where the
    cut line went when it was cut, None when the pack was whole (or absent).

    Raises:
        PackError: the pack cannot be read for another reason (it is left as it is).
    """
    path = pack_path(folder)
    if not path.is_file():
        return None
    data = path.read_bytes()
    try:
        parse_pack(data, path)
        return None
    except CutPackError as e:
        whole = e.whole
    parse_pack(data[:whole], path)                  # the whole lines must read: else refused
    try:
        parse_pack(data + b"\n", path)
    except PackError:
        pass
    else:
        replace_atomic(path, data + b"\n", fsync=True)
        return path
    keep_dir = Path(keep_dir)
    dest, n = keep_dir / f"{PACK_NAME}.cut", 0
    while dest.exists():
        n += 1
        dest = keep_dir / f"{PACK_NAME}.cut.{n}"
    replace_atomic(dest, data[whole:], fsync=True)
    replace_atomic(path, data[:whole], fsync=True)
    return dest


__all__ = ["GZIP_PACK_NAME", "PACK_NAME", "PACK_NAMES", "CutPackError", "PackError",
           "StoredTrial", "append_pack", "is_stored_trial", "loose_files", "pack_bytes",
           "pack_path", "parse_pack", "read_pack", "read_trial_text", "repair_pack",
           "stored_trials"]
