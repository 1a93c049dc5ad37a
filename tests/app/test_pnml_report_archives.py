"""``python -m app.pnml_report ARCHIVE.tgz`` on hostile contest archives (issue 22,
deliverable 5): an entry named with ``..`` or an absolute name, a symbolic or hard link, a
device or a FIFO is refused in one line naming the entry, exit 2, and nothing is written
anywhere (the archive is read in place: petri/formats/mcc_archive.py). Each archive is a real
file and each run a real subprocess."""

from __future__ import annotations

import io
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

from mission.exits import Exit
from petri.formats.pnml import write_pnml
from petri.net import Net
from tests.support import REPO, budget, subprocess_env


def pnml_bytes(tmp_path: Path) -> bytes:
    net = Net("small")
    a, b = net.add_place("a"), net.add_place("b")
    net.initial = {a: 1}
    net.add_transition("t", [a], [b])
    write_pnml(net, tmp_path / "small.pnml")
    return (tmp_path / "small.pnml").read_bytes()


def entry(name: str, kind: bytes = tarfile.REGTYPE, link: str = "",
          data: bytes = b"") -> tuple[tarfile.TarInfo, bytes]:
    info = tarfile.TarInfo(name)
    info.type, info.linkname, info.size = kind, link, len(data)
    return info, data


def archive(path: Path, entries: list[tuple[tarfile.TarInfo, bytes]]) -> Path:
    with tarfile.open(path, "w:gz") as tar:
        for info, data in entries:
            tar.addfile(info, io.BytesIO(data) if info.isfile() else None)
    return path


def report(model: Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "app.pnml_report", str(model), "--method",
                           "explicit"], capture_output=True, text=True, cwd=cwd,
                          timeout=budget(30), env=subprocess_env(PYTHONPATH=str(REPO)),
                          stdin=subprocess.DEVNULL)


# case: (the entries besides or instead of the model, what the one line says about which entry)
HOSTILE = {
    "../ in the model's name": ([("M/../../model.pnml", tarfile.REGTYPE, "")],
                                "entry 'M/../../model.pnml' refused: a name with '..'"),
    "../ in another entry": ([("../../evil.txt", tarfile.REGTYPE, "")],
                             "entry '../../evil.txt' refused: a name with '..'"),
    "an absolute name": ([("/tmp/M/model.pnml", tarfile.REGTYPE, "")],
                         "entry '/tmp/M/model.pnml' refused: an absolute name"),
    "a symbolic link to /etc/passwd": ([("M/model.pnml", tarfile.SYMTYPE, "/etc/passwd")],
                                       "entry 'M/model.pnml' refused: a symbolic link"),
    "a relative symbolic link out": ([("M/x", tarfile.SYMTYPE, "../../../etc/passwd")],
                                     "entry 'M/x' refused: a symbolic link"),
    "a symbolic link inside": ([("M/y", tarfile.SYMTYPE, "model.pnml")],
                               "entry 'M/y' refused: a symbolic link"),
    "a hard link": ([("M/model.pnml", tarfile.LNKTYPE, "/etc/passwd")],
                    "entry 'M/model.pnml' refused: a hard link"),
    "a FIFO": ([("M/model.pnml", tarfile.FIFOTYPE, "")],
               "entry 'M/model.pnml' refused: a FIFO"),
    "a character device": ([("M/zero", tarfile.CHRTYPE, "")], "entry 'M/zero' refused: a device"),
    "a block device": ([("M/disk", tarfile.BLKTYPE, "")], "entry 'M/disk' refused: a device"),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_a_hostile_entry_is_refused_in_one_line(tmp_path: Path, case: str) -> None:
    hostile, says = HOSTILE[case]
    model = pnml_bytes(tmp_path)
    work = tmp_path / "work"
    work.mkdir()
    entries = [entry(name, kind, link, model if kind == tarfile.REGTYPE else b"")
               for name, kind, link in hostile]
    if not any(e.name == "M/model.pnml" for e, _ in entries):
        entries.insert(0, entry("M/model.pnml", data=model))
    path = archive(work / "M.tgz", entries)
    proc = report(path, work)
    assert proc.returncode == Exit.INVALID, proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0].startswith(f"{path}: error: {says}"), lines[0]
    assert proc.stdout == ""
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["M.tgz", "small.pnml", "work"]


def test_a_plain_archive_is_read_in_place(tmp_path: Path) -> None:
    work = tmp_path / "work"
    work.mkdir()
    path = archive(work / "M.tgz", [entry("M", tarfile.DIRTYPE),
                                    entry("M/model.pnml", data=pnml_bytes(tmp_path)),
                                    entry("M/iscolored", data=b"FALSE\n")])
    proc = report(path, work)
    assert proc.returncode == Exit.OK, proc.stderr
    assert "markings            2" in proc.stdout
    assert sorted(p.name for p in work.iterdir()) == ["M.tgz"]  # nothing extracted


@pytest.mark.parametrize("content", [b"not gzip at all\n", b"\x1f\x8b\x08\x00trunc"])
def test_a_file_that_is_no_archive_is_one_line(tmp_path: Path, content: bytes) -> None:
    (tmp_path / "M.tgz").write_bytes(content)
    proc = report(tmp_path / "M.tgz", tmp_path)
    assert proc.returncode == Exit.INVALID, proc.stderr
    assert len(proc.stderr.splitlines()) == 1, proc.stderr
    assert proc.stderr.startswith(f"{tmp_path / 'M.tgz'}: error: not a gzipped tar archive")


def test_a_model_over_its_size_limit_is_refused_unread(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from petri.formats import mcc_archive
    from petri.formats.pnml import PnmlError

    path = archive(tmp_path / "M.tgz", [entry("M/model.pnml", data=pnml_bytes(tmp_path))])
    monkeypatch.setattr(mcc_archive, "MAX_MODEL_BYTES", 100)
    with pytest.raises(PnmlError, match="more than the 100 a model may have"):
        mcc_archive.read_archive(path)
