"""``--version`` on both commands (app/version.py): the installed package's version."""

from __future__ import annotations

from importlib import metadata

import pytest

from app.version import DISTRIBUTION, version_text
from tests.support import cli


@pytest.mark.parametrize("command", ["mclc", "mcl"])
def test_both_commands_print_the_installed_version(command: str) -> None:
    result = cli(command, "--version")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == f"{command} {metadata.version(DISTRIBUTION)} ({DISTRIBUTION})"


def test_a_tree_that_is_not_installed_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    def missing(name: str) -> str:
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(metadata, "version", missing)
    assert "not installed" in version_text("mclc")
