"""The C peer of the explicit search (bench/peers/bfs.c): the net dump it reads, and its build.

Used by bench/bench_scale.py; not part of the toolkit.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from petri.net import Net

SOURCE = Path(__file__).with_name("bfs.c")


def write_dump(net: Net, path: Path) -> None:
    """Write ``net`` in the text form bfs.c reads: sizes, the initial marking, then each
    transition's input and output arcs as (place, weight) pairs."""
    lines = [f"places {len(net.places)} transitions {len(net.transitions)}",
             "initial " + " ".join(str(net.initial.get(p, 0)) for p in range(len(net.places)))]
    for tr in net.transitions:
        arcs = [str(len(tr.inputs))] + [f"{p} {w}" for p, w in tr.inputs]
        arcs += [str(len(tr.outputs))] + [f"{p} {w}" for p, w in tr.outputs]
        lines.append(" ".join(arcs))
    path.write_text("\n".join(lines) + "\n", "ascii")


def build(workdir: Path) -> tuple[Path | None, str]:
    """(the compiled explorer, "") or (None, why it could not be built)."""
    compiler = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if compiler is None:
        return None, "no C compiler (cc, gcc or clang) on PATH"
    binary = workdir / "bfs"
    proc = subprocess.run([compiler, "-O2", "-o", str(binary), str(SOURCE)],
                          capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        return None, f"{compiler} -O2 failed: {(proc.stderr.strip().splitlines() or ['?'])[0]}"
    return binary, ""
