"""One error hierarchy for everything a user gives us.

Every user-facing problem is a :class:`Diagnostic`: ``file:line:col: error: message``, the
source line, a caret under the column, and a hint saying what to do. An :class:`MclError`
carries one or more diagnostics; the command-line tools print them and exit 2 instead of
showing a traceback (which only ``--debug`` shows).
"""

from __future__ import annotations

import errno
import os
import select
import stat
from dataclasses import dataclass, field
from typing import IO


@dataclass(frozen=True)
class Span:
    """A place in a source file: 1-based line and column, inclusive start, exclusive end."""

    file: str
    line: int
    col: int
    end_line: int = 0
    end_col: int = 0

    def __str__(self) -> str:
        if self.line <= 0:  # the file as a whole (missing, unreadable, empty)
            return self.file
        return f"{self.file}:{self.line}:{self.col}"

    @classmethod
    def of_file(cls, file: str) -> Span:
        """The file as a whole: no line to point at (prints as just ``file``)."""
        return cls(file, 0, 0)


UNPRINTABLE = {c: "\N{REPLACEMENT CHARACTER}" for c in (*range(0x20), 0x7F, *range(0x80, 0xA0),
                                                     0x2028, 0x2029, *range(0x202A, 0x202F),
                                                     *range(0x2066, 0x206A)) if c != 0x09}


def printable(line: str) -> str:
    """A line of a user's file as a message may quote it: each control character, line or
    paragraph separator and bidirectional override (which a terminal would act on: a new
    line, an escape sequence, text shown reversed) one replacement character, so that the
    quote stays one line and its caret stays under the same column."""
    return line.translate(UNPRINTABLE)


@dataclass(frozen=True)
class Diagnostic:
    """One message about a source: its severity, what is wrong, where, and what to do."""

    severity: str  # "error" | "warning" | "note"
    message: str
    span: Span | None = None
    hint: str = ""
    source_line: str = ""
    code: str = ""  # a short stable name for the kind of problem, e.g. "trailing-semicolon"

    def format(self) -> str:
        where = f"{self.span}: " if self.span else ""
        lines = [f"{where}{self.severity}: {self.message}"]
        if self.span and self.source_line:
            shown = printable(self.source_line.rstrip("\n"))
            text = shown.expandtabs(4)
            prefix = shown[: max(self.span.col - 1, 0)].expandtabs(4)
            width = 1
            if self.span.end_line == self.span.line and self.span.end_col > self.span.col:
                width = self.span.end_col - self.span.col
            lines.append(f"    {text}")
            lines.append("    " + " " * len(prefix) + "^" + "~" * (min(width, 60) - 1))
        if self.hint:
            lines.append(f"  hint: {self.hint}")
        return "\n".join(lines)


@dataclass
class Source:
    """The text of one input file, kept to quote lines in messages."""

    name: str
    text: str
    lines: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        # Lines as the parser counts them: only '\n' ends a line (not '\r', '\f', U+2028...).
        self.lines = [line.removesuffix("\r") for line in self.text.split("\n")]

    def line(self, number: int) -> str:
        return self.lines[number - 1] if 0 < number <= len(self.lines) else ""

    def span(self, line: int, col: int, end_line: int = 0, end_col: int = 0) -> Span:
        return Span(self.name, line, col, end_line, end_col)

    def diagnostic(self, severity: str, message: str, span: Span | None, hint: str = "",
                   code: str = "") -> Diagnostic:
        source_line = self.line(span.line) if span and span.file == self.name else ""
        return Diagnostic(severity, message, span, hint, source_line, code)


class MclError(Exception):
    """The root of every error a user can cause: invalid input, with its place.

    Holds every diagnostic found (errors and warnings). Either give the diagnostics, or a plain
    message and its place::

        MclError([diagnostic, ...])
        MclError("no such file", span=Span.of_file(path), hint="check the path")

    ``str(exc)`` is :meth:`format` unless ``text`` is given: subclasses whose users compare
    ``str(exc)`` keep their historic one-line text that way, while :meth:`format` prints
    ``file:line:col: error: message``, the source line when known, and the hint.
    """

    def __init__(self, diagnostics: list[Diagnostic] | Diagnostic | str, *,
                 span: Span | None = None, hint: str = "", code: str = "",
                 source_line: str = "", text: str | None = None) -> None:
        if isinstance(diagnostics, str):
            diagnostics = Diagnostic("error", diagnostics, span, hint, source_line, code)
        elif span is not None or hint or code or source_line:
            raise TypeError("span, hint, code and source_line go with a message, "
                            "not with diagnostics")
        self.diagnostics = ([diagnostics] if isinstance(diagnostics, Diagnostic)
                            else list(diagnostics))
        super().__init__(self.format() if text is None else text)

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity == "error"]

    @property
    def span(self) -> Span | None:
        """The place of the first diagnostic (None: the error has no place)."""
        return self.diagnostics[0].span if self.diagnostics else None

    def format(self) -> str:
        return "\n".join(d.format() for d in self.diagnostics)


def error(source: Source, message: str, span: Span | None, hint: str = "",
          code: str = "") -> MclError:
    """The one helper through which every single-error check raises."""
    return MclError(source.diagnostic("error", message, span, hint, code))


def file_error(name: str, message: str, hint: str = "", code: str = "") -> MclError:
    """A problem with a file as a whole (missing, unreadable, binary): no line to show."""
    return MclError(Diagnostic("error", message, Span(name, 1, 1), hint, "", code))


def read_limited(path: str, limit: int, what: str) -> bytes:
    """The bytes of the file at ``path``, read with a size limit (``/dev/zero`` is refused, not
    read for ever): an :class:`MclError` if it is missing, unreadable or larger than ``limit``
    bytes (``what``: what the file should be, for the message)."""
    try:
        with open_input(path) as f:
            data = f.read(limit + 1)
    except FileNotFoundError:
        raise file_error(path, "no such file", f"give the path of {what}",
                         code="missing-file") from None
    except IsADirectoryError:
        raise file_error(path, "is a directory, not a file", f"give the path of {what}",
                         code="directory") from None
    except OSError as exc:
        raise file_error(path, f"cannot be read: {exc.strerror or exc}",
                         "check the file's permissions", code="unreadable") from None
    if len(data) > limit:
        raise file_error(path, f"is larger than {limit:,} bytes: not {what}",
                         f"give the path of {what}", code="too-large")
    return data


FIFO_WAIT = 5.0  # s: the longest wait for a named pipe's first bytes


def open_input(path: str) -> IO[bytes]:
    """``path`` opened to read. A named pipe (``mclc <(make-mission)``, ``/dev/stdin``) is
    waited on for at most :data:`FIFO_WAIT` s for its first bytes: one that nobody writes to
    is refused (TimeoutError, an OSError) instead of hanging the command."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), path)
        if stat.S_ISFIFO(mode) and \
                not select.select([fd], [], [], FIFO_WAIT)[0]:
            raise TimeoutError(errno.ETIMEDOUT, f"a named pipe nobody wrote to within "
                               f"{FIFO_WAIT:g} s")
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_source(path: str) -> Source:
    """Read a text file for parsing, turning every way it can go wrong into an MclError."""
    if not os.path.exists(path):
        raise file_error(path, "no such file", "check the path; missions usually end in .mcl",
                         code="missing-file")
    if os.path.isdir(path):
        raise file_error(path, "is a directory, not a file", "give the path of a file",
                         code="directory")
    try:
        with open_input(path) as f:
            data = f.read(8 * 1024 * 1024 + 1)
    except OSError as exc:
        raise file_error(path, f"cannot be read: {exc.strerror}",
                         "check the file's permissions", code="unreadable") from None
    if len(data) > 8 * 1024 * 1024:
        raise file_error(path, "is larger than 8 MiB: not a mission file",
                         "give the path of a mission (.mcl) file", code="too-large")
    if b"\x00" in data:
        raise file_error(path, "is a binary file, not text",
                         "give the path of a mission written in MCL", code="binary-file")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise file_error(path, f"is not UTF-8 text (byte {exc.start} is 0x{data[exc.start]:02x})",
                         "save the file as UTF-8", code="not-utf8") from None
    return Source(path, text.removeprefix("\ufeff"))
