"""A full disk never cuts a result file short (#92): rerunning a finished folder with no room
left (a file-size limit of 4 kB here, RLIMIT_FSIZE, which fails a write as a full disk does)
leaves the old summary.json and figure copy whole, and the error names the file. (Before,
summary.json became 4,096 bytes of invalid JSON, with only "OSError: [Errno 27] File too
large".) The slices' own files: tests/planners/*/experiments/test_full_disk.py."""

import pytest

from dopt.lab.record import record_figure, write_summary
from tests.dopt.lab.run_files import rewrite_on_a_full_disk
from tests.dopt.lab.test_atomic_write import BIG


def summary(out, big: bool):
    write_summary(dict(BIG) if big else {"old": True}, out, None, "experiments/x.py", [])


def figure_copy(out, big: bool):
    """The figure a --record run copies beside its record (both sources written first, with
    room: only the copy runs under the limit)."""
    run = out / "run"
    if not run.exists():
        run.mkdir()
        (run / "small.png").write_bytes(bytes(range(256)))
        (run / "big.png").write_bytes(bytes(range(256)) * 100)
    record_figure(run / ("big.png" if big else "small.png"), out / "results" / "rec.json")


@pytest.mark.parametrize("write, name", [(summary, "summary.json"),
                                         (figure_copy, "images/rec.png")])
def test_a_rewrite_on_a_full_disk_keeps_the_old_file_and_names_it(tmp_path, monkeypatch, write,
                                                                  name):
    rewrite_on_a_full_disk(tmp_path, monkeypatch, write, name)
