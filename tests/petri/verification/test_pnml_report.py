"""Model Checking Contest archives (petri/verification/pnml_report.load_net) and ``mclc X.tgz``.

The README says mclc takes a contest ``.tgz``; ``mclc X.tgz`` answered "is a binary file"
(issue 22). ``load_net`` read archives already, for ``python -m app.pnml_report``, but a junk
archive was an internal error and a FIFO hung it; an archive is now read only for its regular
``*/model.pnml`` entry, copied by content, never by name.
"""

from __future__ import annotations

import io
import os
import tarfile
from pathlib import Path

import pytest

from petri.formats.pnml import PnmlError, write_pnml
from petri.net import Net
from petri.verification.pnml_report import load_net
from tests.support import cli

ARCHIVE = "Small-PT-001.tgz"


def model_bytes(tmp_path: Path, places: int = 3) -> bytes:
    """A cycle of ``places`` places with one token: ``places`` reachable markings."""
    net = Net("cycle")
    ps = [net.add_place(f"p{i}") for i in range(places)]
    net.initial = {ps[0]: 1}
    for i in range(places):
        net.add_transition(f"t{i}", [ps[i]], [ps[(i + 1) % places]])
    path = tmp_path / "model-source.pnml"
    write_pnml(net, path)
    return path.read_bytes()


def archive(tmp_path: Path, entries: list[tarfile.TarInfo | tuple[str, bytes]],
            name: str = ARCHIVE) -> Path:
    """A gzip'd tar with the given entries: (name, content) for a file, or a TarInfo."""
    path = tmp_path / name
    with tarfile.open(path, "w:gz") as tar:
        for entry in entries:
            if isinstance(entry, tarfile.TarInfo):
                tar.addfile(entry)
            else:
                info = tarfile.TarInfo(entry[0])
                info.size = len(entry[1])
                tar.addfile(info, io.BytesIO(entry[1]))
    return path


def link(name: str, target: str, kind: bytes = tarfile.SYMTYPE) -> tarfile.TarInfo:
    info = tarfile.TarInfo(name)
    info.type, info.linkname = kind, target
    return info


def test_the_model_in_a_contest_archive_is_read(tmp_path: Path) -> None:
    path = archive(tmp_path, [("Small-PT-001/iscolored", b"FALSE\n"),
                              ("Small-PT-001/model.pnml", model_bytes(tmp_path, 4))])
    net = load_net(path)
    assert (len(net.places), len(net.transitions)) == (4, 4)


@pytest.mark.parametrize("entry,says", [
    (link("Small-PT-001/model.pnml", "/etc/passwd"), "refused: a symbolic link"),
    (link("Small-PT-001/model.pnml", "../../etc/passwd", tarfile.LNKTYPE), "refused: a hard link"),
    (link("Small-PT-001/model.pnml", "", tarfile.FIFOTYPE), "refused: a FIFO"),
    (link("Small-PT-001/model.pnml", "", tarfile.CHRTYPE), "refused: a device"),
    (("Small-PT-001/other.pnml", b"<pnml/>"), "holds no */model.pnml"),
])
def test_an_archive_without_a_plain_model_is_refused(tmp_path: Path,
                                                     entry: tarfile.TarInfo | tuple[str, bytes],
                                                     says: str) -> None:
    path = archive(tmp_path, [entry])
    with pytest.raises(PnmlError) as caught:
        load_net(path)
    assert says in caught.value.message and caught.value.path == str(path)


def test_an_entry_named_outside_is_refused_and_nothing_is_written(tmp_path: Path) -> None:
    """``../model.pnml`` names a file outside the archive's folder: the archive is refused by
    that entry (petri/formats/mcc_archive.py), and nothing is written anywhere."""
    path = archive(tmp_path, [("../../model.pnml", model_bytes(tmp_path, 2))])
    before = set(os.listdir(tmp_path)) | set(os.listdir(tmp_path.parent))
    with pytest.raises(PnmlError) as caught:
        load_net(path)
    assert "../../model.pnml" in caught.value.message
    assert set(os.listdir(tmp_path)) | set(os.listdir(tmp_path.parent)) == before


def test_what_is_not_an_archive_is_refused_in_one_line(tmp_path: Path) -> None:
    junk = tmp_path / "junk.tgz"
    junk.write_bytes(b"not a tar file at all\n" * 10)
    with pytest.raises(PnmlError) as caught:
        load_net(junk)
    assert "not a gzipped tar archive" in caught.value.message
    fifo = tmp_path / "fifo.tgz"
    os.mkfifo(fifo)
    for path in (fifo, tmp_path / "fifo.pnml"):
        if not path.exists():
            os.mkfifo(path)
        with pytest.raises(PnmlError) as caught:
            load_net(path)  # not opened: a FIFO would block for ever
        assert "not a regular file" in caught.value.message


def test_a_mistake_in_the_archived_model_names_the_archive(tmp_path: Path) -> None:
    path = archive(tmp_path, [("M/model.pnml", b"<pnml><net>\n<place id='p'>\n</pnml>")])
    with pytest.raises(PnmlError) as caught:
        load_net(path)
    assert caught.value.path == f"{path}:M/model.pnml" and caught.value.line is not None


def test_mclc_takes_a_contest_archive_as_the_readme_says(tmp_path: Path) -> None:
    path = archive(tmp_path, [("Small-PT-001/model.pnml", model_bytes(tmp_path, 5))])
    proc = cli("mclc", str(path))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "binary file" not in proc.stderr
    assert proc.stdout.startswith(f"{path}:\n")
    assert "markings" in proc.stdout and " 5" in proc.stdout
    junk = tmp_path / "junk.tgz"
    junk.write_bytes(b"\x00\x01junk")
    proc = cli("mclc", str(junk))
    assert proc.returncode == 2 and proc.stderr.startswith(f"{junk}: error: not a gzipped tar")
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr
