"""A Model Checking Contest archive (``MODEL.tgz``): a gzipped tar of one folder that holds the
model as ``FOLDER/model.pnml``.

The archive is read, never extracted: every entry is checked first, and the archive is refused
with a one-line :class:`petri.formats.pnml.PnmlError` naming the first entry that is not a
plain file or folder inside the archive's folder (a name with ``..`` or an absolute one, a
symbolic or hard link, a device, a FIFO), or when it holds more than :data:`MAX_ENTRIES`
entries; then ``model.pnml`` is parsed straight from the archive's bytes, at most
:data:`MAX_MODEL_BYTES` of them. Nothing is written to disk, so nothing can land outside a
folder.
"""

from __future__ import annotations

import tarfile
import zlib
from pathlib import Path, PurePosixPath

from petri.formats.pnml import PnmlError, read_pnml_stream
from petri.net import Net

MAX_ENTRIES = 10_000  # a contest archive holds a dozen files
MAX_MODEL_BYTES = 1 << 30  # the largest contest model.pnml is a few hundred MB


def read_archive(path: str | Path) -> Net:
    """The net in the ``*/model.pnml`` of the contest archive at ``path``."""
    where = str(path)
    try:
        with tarfile.open(where, "r:gz") as archive:
            model = _model_entry(archive, where)
            stream = archive.extractfile(model)
            assert stream is not None  # a regular file (checked) always has a stream
            return read_pnml_stream(stream, f"{where}:{model.name}")
    except FileNotFoundError:
        raise PnmlError("no such file", where) from None
    except IsADirectoryError:
        raise PnmlError("is a directory, not an archive", where) from None
    except PermissionError:
        raise PnmlError("permission denied", where) from None
    except (tarfile.TarError, EOFError, zlib.error, OSError) as exc:
        raise PnmlError(f"not a gzipped tar archive ({exc})", where) from None


def _model_entry(archive: tarfile.TarFile, where: str) -> tarfile.TarInfo:
    """Every entry checked (:func:`refusal`); the one that is the model."""
    model: tarfile.TarInfo | None = None
    for count, entry in enumerate(archive, start=1):
        if count > MAX_ENTRIES:
            raise PnmlError(f"more than {MAX_ENTRIES:,} entries: not a contest archive",
                            where)
        why = refusal(entry)
        if why:
            raise PnmlError(f"entry {entry.name!r} refused: {why}", where)
        if model is None and entry.isfile() and PurePosixPath(entry.name).name == "model.pnml" \
                and len(PurePosixPath(entry.name).parts) > 1:
            model = entry
    if model is None:
        raise PnmlError("the archive holds no */model.pnml", where)
    if model.size > MAX_MODEL_BYTES:
        raise PnmlError(f"entry {model.name!r} refused: {model.size:,} bytes, more than the "
                        f"{MAX_MODEL_BYTES:,} a model may have", where)
    return model


def refusal(entry: tarfile.TarInfo) -> str:
    """Why ``entry`` may not be in a contest archive ("" when it may): only plain files and
    folders, under a relative name that stays inside the archive's folder."""
    name = PurePosixPath(entry.name)
    if entry.name.startswith(("/", "\\")) or name.is_absolute() or ":" in name.parts[0]:
        return "an absolute name"
    if ".." in name.parts or ".." in entry.name.split("\\"):
        return "a name with '..' leads outside the archive's folder"
    if entry.issym():
        return f"a symbolic link (to {entry.linkname!r})"
    if entry.islnk():
        return f"a hard link (to {entry.linkname!r})"
    if entry.isfifo():
        return "a FIFO"
    if entry.ischr() or entry.isblk():
        return "a device"
    if not (entry.isfile() or entry.isdir()):
        return "not a plain file or folder"
    return ""
