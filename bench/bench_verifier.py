"""Benchmark of the state-space engine on the Model Checking Contest nets (not a test).

For each model in ../shared/mcc/models it prints, measured in this one run on the same nets:

* ours: markings per second of :func:`petri.verification.reachability.explore` (median of 3, in this
  process, after a warm-up run so that numba's compilation is not counted), or the seconds of
  the symbolic search for the nets too large to enumerate;
* pm4py: markings per second of ``construct_reachability_graph``;
* SNAKES: markings per second of ``StateGraph.build()``;

and the ratio ours/peer. Peers run in a subprocess with a time limit, and only on models of at
most PEER_MAX_MARKINGS markings (their searches keep a Python object per marking). Then it
times whole processes, ``mclc MODEL/model.pnml`` as a user runs it: its wall-clock and CPU
time (user + system) and peak resident memory, medians of ``--runs``; on the models of
AGAINST_C, run in alternation with the C peer (bench/peers/bfs.c, a plain single-core
breadth-first search built here with ``cc -O2``) so that the load of a shared machine hits
both alike, with the ratios ours / C and issue 27's targets (time at most the C's, memory
within twice its).

    .venv/bin/python bench/bench_verifier.py [--models NAME ...] [--peer-timeout S] [--runs N]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MCC = REPO.parent / "shared" / "mcc"
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from peers import c_explorer
from petri.verification import reachability as rg
from petri.verification import symbolic
from petri.net import Net
from petri.formats.pnml import read_pnml

RUNS = 3
EXPLICIT_MAX_MARKINGS = 5_000_000  # beyond this, ours is timed symbolically
PEER_MAX_MARKINGS = 25_000
WHOLE_PROCESS = ["Kanban-PT-00005", "Philosophers-PT-000020"]
AGAINST_C = {"Kanban-PT-00005"}  # the C peer enumerates these in seconds

# The peers, run as `python -c PEER_SCRIPT kind model.pnml runs`; they print JSON
# {"markings": n, "seconds": [t1, t2, ...]}.
PEER_SCRIPT = r'''
import json, sys, time, warnings
warnings.filterwarnings("ignore")
kind, path, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
sys.path.insert(0, sys.argv[4])
from petri.formats.pnml import read_pnml
net = read_pnml(path)
times, count = [], 0
if kind == "pm4py":
    import pm4py
    from pm4py.objects.petri_net.utils.reachability_graph import construct_reachability_graph
    pn, initial, _ = pm4py.read_pnml(path)
    for _ in range(runs):
        t = time.perf_counter()
        graph = construct_reachability_graph(pn, initial)
        times.append(time.perf_counter() - t)
        count = len(graph.states)
else:
    from snakes.nets import MultiArc, PetriNet, Place, StateGraph, Transition, Value, dot
    def arc(weight):
        return Value(dot) if weight == 1 else MultiArc([Value(dot)] * weight)
    sn = PetriNet(net.name)
    for p, place in enumerate(net.places):
        sn.add_place(Place(f"p{p}", [dot] * net.initial.get(p, 0)))
    for t, transition in enumerate(net.transitions):
        sn.add_transition(Transition(f"t{t}"))
        for p, w in transition.inputs:
            sn.add_input(f"p{p}", f"t{t}", arc(w))
        for p, w in transition.outputs:
            sn.add_output(f"p{p}", f"t{t}", arc(w))
    for _ in range(runs):
        t = time.perf_counter()
        graph = StateGraph(sn)
        graph.build()
        times.append(time.perf_counter() - t)
        count = len(graph)
print(json.dumps({"markings": count, "seconds": times}))
'''


def extract(model: str, workdir: Path) -> Path:
    with tarfile.open(MCC / "models" / f"{model}.tgz") as archive:
        archive.extractall(workdir, filter="data")
    return workdir / model / "model.pnml"


def time_ours(net: Net) -> dict[str, object]:
    probe = rg.explore(net, max_markings=EXPLICIT_MAX_MARKINGS)  # also the numba warm-up
    if not probe.complete and symbolic.available() and symbolic.is_candidate(net):
        times = []
        for _ in range(RUNS):
            result = symbolic.explore(net)
            times.append(result.seconds)
        return {"method": "symbolic", "markings": result.markings,
                "seconds": statistics.median(times)}
    times = []
    for _ in range(RUNS):
        start = time.perf_counter()
        ss = rg.explore(net, max_markings=EXPLICIT_MAX_MARKINGS)
        times.append(time.perf_counter() - start)
    return {"method": "explicit" if ss.complete else "explicit (limit)",
            "markings": ss.n_markings, "arcs": ss.n_arcs, "seconds": statistics.median(times)}


def time_peer(kind: str, pnml: Path, timeout: float) -> dict[str, object]:
    try:
        proc = subprocess.run([sys.executable, "-c", PEER_SCRIPT, kind, str(pnml), str(RUNS),
                               str(REPO)], check=False, capture_output=True, text=True,
                              timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"> {timeout:.0f} s"}
    if proc.returncode != 0:
        return {"error": (proc.stderr.strip().splitlines() or ["failed"])[-1][:40]}
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    return {"markings": out["markings"], "seconds": statistics.median(out["seconds"])}


# Whole processes are started by a small Python of their own: a child's peak resident memory
# (ru_maxrss) counts its parent's as it was at the fork, and this process holds a graph by then.
LAUNCHER = r'''
import json, os, subprocess, sys, time
out = []
for argv in json.loads(sys.argv[1]):
    start = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=sys.argv[2], stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    text = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    out.append([time.perf_counter() - start, usage.ru_utime + usage.ru_stime,
                usage.ru_maxrss / 1024, os.waitstatus_to_exitcode(status), text])
print(json.dumps(out))
'''


def run_all(argvs: list[list[str]]) -> list[tuple[float, float, float, str]]:
    """(wall seconds, CPU seconds, peak RSS in MB, output) of each process, one after the
    other, started by :data:`LAUNCHER`."""
    proc = subprocess.run([sys.executable, "-c", LAUNCHER, json.dumps(argvs), str(REPO)],
                          capture_output=True, text=True, check=True)
    results = []
    for argv, (seconds, cpu, megabytes, status, out) in zip(argvs,
                                                            json.loads(proc.stdout)):
        if status not in (0, 4):  # 4: undecided (a limit)
            raise RuntimeError(f"{argv[-1]}: exit {status}")
        results.append((seconds, cpu, megabytes, out))
    return results


def whole_process(pnml: Path, runs: int, peer: list[str] | None) -> list[str]:
    """The lines of ``mclc MODEL.pnml`` (and the C peer, in alternation) measured whole."""
    mclc = [sys.executable, "-m", "app.mclc", str(pnml), "--json"]
    results = run_all([argv for _ in range(runs) for argv in ([mclc] + ([peer] if peer else []))])
    step = 2 if peer else 1
    ours, theirs = results[::step], results[1::step] if peer else []
    report = json.loads(ours[-1][3])
    what = f"{report['method']}, {report['markings']:,} markings, {report['arcs']:,} arcs"
    rows = [("mclc", ours)] + ([("C BFS (cc -O2, 1 core)", theirs)] if theirs else [])
    lines = [f"    {name:<24} {statistics.median(r[0] for r in results):7.2f} s "
             f"(CPU {statistics.median(r[1] for r in results):6.2f} s) "
             f"{statistics.median(r[2] for r in results):6.0f} MB" for name, results in rows]
    lines[0] += f"  ({what})"
    if theirs:
        ratio = [statistics.median(r[0] for r in ours) / statistics.median(r[0] for r in theirs),
                 statistics.median(r[1] for r in ours) / statistics.median(r[1] for r in theirs),
                 statistics.median(r[2] for r in ours) / statistics.median(r[2] for r in theirs)]
        lines.append(f"    ours / C: time {ratio[0]:.2f}x ({verdict(ratio[0], 1.0)}: <= 1), "
                     f"CPU {ratio[1]:.2f}x, peak memory {ratio[2]:.2f}x "
                     f"({verdict(ratio[2], 2.0)}: <= 2)")
    return lines


def verdict(value: float, target: float) -> str:
    return "met" if value <= target else "SHORT"


def c_peer(pnml: Path, workdir: Path) -> tuple[list[str] | None, str]:
    """The C explorer's command line for ``pnml`` (built once), or None and why not."""
    binary = workdir / "bfs"
    if not binary.exists():
        built, why = c_explorer.build(workdir)
        if built is None:
            return None, why
    dump = pnml.with_suffix(".txt")
    c_explorer.write_dump(read_pnml(pnml), dump)
    return [str(binary), str(dump)], ""


def rate(entry: dict[str, object]) -> float | None:
    seconds = entry.get("seconds")
    if "error" in entry or not isinstance(seconds, float) or seconds <= 0:
        return None
    return float(entry["markings"]) / seconds  # type: ignore[arg-type]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="*", help="model names (default: all)")
    parser.add_argument("--peer-timeout", type=float, default=120.0)
    parser.add_argument("--runs", type=int, default=5, help="whole-process runs (default 5)")
    args = parser.parse_args()
    if not (MCC / "models").is_dir():
        print(f"{MCC} is absent: nothing to measure", file=sys.stderr)
        return 1
    models = args.models or sorted(p.name.removesuffix(".tgz")
                                   for p in (MCC / "models").glob("*.tgz"))
    engine = rg.default_engine()
    print(f"explicit engine: {engine} (with arcs; without, as mclc NET.pnml: packed words where "
          f"they fit); median of {RUNS} runs; peers on models of at most "
          f"{PEER_MAX_MARKINGS:,} markings, {args.peer_timeout:.0f} s limit\n")
    header = (f"{'model':<30} {'markings':>26} {'ours':>14} {'pm4py':>12} {'ratio':>7} "
              f"{'SNAKES':>12} {'ratio':>7}")
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory() as tmp:
        for model in models:
            pnml = extract(model, Path(tmp))
            ours = time_ours(read_pnml(pnml))
            peers = {}
            for kind in ("pm4py", "snakes"):
                if ours["method"] == "explicit" and \
                        int(ours["markings"]) <= PEER_MAX_MARKINGS:  # type: ignore[call-overload]
                    peers[kind] = time_peer(kind, pnml, args.peer_timeout)
                    if "markings" in peers[kind] and peers[kind]["markings"] != ours["markings"]:
                        peers[kind]["error"] = f"{peers[kind]['markings']} markings?!"
                else:
                    peers[kind] = {"error": "skipped"}
            print(row(model, ours, peers), flush=True)
        print(f"\nwhole process: mclc MODEL/model.pnml --json, median of {args.runs} runs "
              f"(wall clock, CPU time, peak resident memory), load "
              f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        for model in WHOLE_PROCESS:
            if model in models or not args.models:
                pnml = extract(model, Path(tmp))
                peer, why = c_peer(pnml, Path(tmp)) if model in AGAINST_C else (None, "")
                print(f"  {model}" + (f" (the C peer: {why})" if why else ""))
                print("\n".join(whole_process(pnml, args.runs, peer)), flush=True)
    return 0


def row(model: str, ours: dict[str, object], peers: dict[str, dict[str, object]]) -> str:
    our_rate = rate(ours)
    if ours["method"] == "symbolic":
        ours_text = f"{ours['seconds']:.2f} s BDD"
    else:
        ours_text = f"{our_rate / 1e6:.2f} M/s" if our_rate else "?"
    cells = [f"{model:<30} {ours['markings']:>26,} {ours_text:>14}"]
    for kind in ("pm4py", "snakes"):
        peer = peers[kind]
        peer_rate = rate(peer)
        if peer_rate is None or our_rate is None:
            cells.append(f"{peer.get('error', '-')!s:>12} {'':>7}")
        else:
            cells.append(f"{peer_rate / 1e3:>8.1f} k/s {our_rate / peer_rate:>6.0f}x")
    return " ".join(cells)


if __name__ == "__main__":
    sys.exit(main())
