"""The long reliability runs, one subcommand each, writing their figures as JSON.

    python reliability/run.py fuzz --inputs 1000000            # random + mutated inputs
    python reliability/run.py fuzz --engine atheris --inputs 1000000
    python reliability/run.py matrix                           # every cell of the fault matrix
    python reliability/run.py soak --exchanges 1000000         # loopback TCP, own sim process
    python reliability/run.py history --ops 100000 --seeds 1 2 3   # consumers through serve
    python reliability/run.py table                            # the matrix as markdown
    python reliability/run.py properties --examples 10000      # the link's property tests

Results go to ``reliability/results/<name>.json`` (``--out`` to change). The exit status is 1
when a run found a violation or an error, so a CI job can call it. docs/reliability.md shows the
figures of the last full runs.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

RESULTS = ROOT / "reliability" / "results"


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _write(out: Path, name: str, data: dict[str, Any]) -> None:
    data = {
        "run": name,
        "date": time.strftime("%Y-%m-%d %H:%M:%S"),
        "python": platform.python_version(),
        "machine": f"{platform.system()} {platform.machine()}",
        **data,
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    _say(f"wrote {out}")


# -- fuzz ------------------------------------------------------------------------------------
def _fuzz_random(args: argparse.Namespace) -> tuple[dict[str, Any], bool]:
    from reliability.fuzzing import TARGETS, run_fuzz

    targets = args.target or list(TARGETS)
    report = run_fuzz(
        args.inputs,
        seed=args.seed,
        targets=targets,
        progress=lambda n: _say(f"fuzz: {n} inputs") if n % 100_000 == 0 else None,
    )
    data = {"engine": "random", **report.as_json()}
    return data, bool(report.violations)


_ATHERIS_DONE = re.compile(r"Done (\d+) (?:runs )?in (\d+) second")
_ATHERIS_COV = re.compile(r"cov: (\d+) ft: (\d+) corp: (\d+)")


def _fuzz_atheris(args: argparse.Namespace) -> tuple[dict[str, Any], bool]:
    corpus = RESULTS / "atheris-corpus"
    corpus.mkdir(parents=True, exist_ok=True)
    argv = [
        sys.executable,
        str(ROOT / "reliability" / "atheris_fuzz.py"),
        f"-atheris_runs={args.inputs}",
        f"-seed={args.seed or 1}",
        f"-artifact_prefix={RESULTS}/atheris-crash-",
        str(corpus),
    ]
    start = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True, cwd=ROOT)
    seconds = time.perf_counter() - start
    log = proc.stderr
    done = _ATHERIS_DONE.findall(log)
    cov = _ATHERIS_COV.findall(log)
    crashed = proc.returncode != 0
    known = re.findall(r"known issue hits: (\{.*\})", log)
    data: dict[str, Any] = {
        "engine": "atheris (libFuzzer, coverage-guided)",
        "targets": ["frame decoder", "frame resync", "answer decoders", "request decoder"],
        "inputs": int(done[-1][0]) if done else None,
        "seconds": round(seconds, 1),
        "coverage_edges": int(cov[-1][0]) if cov else None,
        "features": int(cov[-1][1]) if cov else None,
        "corpus_size": int(cov[-1][2]) if cov else None,
        "violations": 1 if crashed else 0,
        "known_issue_hits": json.loads(known[-1]) if known else None,
        "exit_status": proc.returncode,
    }
    if crashed:
        data["log_tail"] = log[-4000:]
    return data, crashed


def cmd_fuzz(args: argparse.Namespace) -> int:
    run = _fuzz_atheris if args.engine == "atheris" else _fuzz_random
    data, bad = run(args)
    _write(args.out or RESULTS / f"fuzz-{args.engine}.json", "fuzz", data)
    _say(f"fuzz: {data['inputs']} inputs, {data['violations']} violations")
    return 1 if bad else 0


# -- matrix ----------------------------------------------------------------------------------
def cmd_matrix(args: argparse.Namespace) -> int:
    from reliability.matrix import CI_STRIDE, MatrixConfig, run_matrix, summarise

    config = MatrixConfig(timeout=args.timeout, ack_timeout=args.ack_timeout)
    results, wall = run_matrix(
        config,
        strides=CI_STRIDE if args.ci_slice else None,
        progress=lambda n: _say(f"matrix: {n} cells"),
    )
    data = {
        "config": config.__dict__,
        "slice": "ci" if args.ci_slice else "full",
        **summarise(results, wall),
    }
    _write(args.out or RESULTS / "matrix.json", "matrix", data)
    _say(f"matrix: {data['cells']} cells, {data['violations']} violations")
    return 1 if data["violations"] else 0


# -- soak ------------------------------------------------------------------------------------
def cmd_soak(args: argparse.Namespace) -> int:
    from reliability.soak import run_soak, sim_process

    with sim_process() as (proc, url):
        report = run_soak(
            url,
            args.exchanges,
            sim_pid=proc.pid,
            progress=lambda n: _say(f"soak: {n} exchanges"),
        )
    data = {"transport": "loopback TCP, simulator in its own process", **report.as_json()}
    _write(args.out or RESULTS / "soak.json", "soak", data)
    _say(f"soak: {report.exchanges} exchanges, {data['errors']} errors, {report.wrong} wrong")
    return 1 if data["errors"] or report.wrong else 0


# -- properties --------------------------------------------------------------------------------
_PROPERTY_TESTS = "tests/protocol/test_link_properties.py"
_PASSING = re.compile(r"^(tests/\S+::\S+):$|(\d+) passing, (\d+) failing", re.MULTILINE)


def cmd_properties(args: argparse.Namespace) -> int:
    """The link's property tests (tests/protocol/test_link_properties.py) with ``--examples``
    examples each, randomized (not CI's derandomized profile): a fresh search every run."""
    env = {
        **os.environ,
        "ROBOSTAR_PROPERTY_EXAMPLES": str(args.examples),
        "HYPOTHESIS_PROFILE": "dev",
    }
    env.pop("CI", None)
    argv = [
        sys.executable,
        "-m",
        "pytest",
        _PROPERTY_TESTS,
        "-q",
        "-p",
        "no:cacheprovider",
        "--hypothesis-show-statistics",
        "--timeout=0",  # the suite's per-test limit is for 300 examples, not thousands
        "--hypothesis-seed",
        str(args.seed) if args.seed else str(int(time.time())),
    ]
    start = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True, cwd=ROOT, env=env)
    seconds = time.perf_counter() - start
    tests: dict[str, dict[str, int]] = {}
    name = ""
    for match in _PASSING.finditer(proc.stdout):
        if match.group(1):
            name = match.group(1).split("::")[-1]
        elif name:
            counts = tests.setdefault(name, {"passing": 0, "failing": 0})
            counts["passing"] += int(match.group(2))
            counts["failing"] += int(match.group(3))
    failed = proc.returncode != 0
    data: dict[str, Any] = {
        "tests": tests,
        "examples_per_test": args.examples,
        "examples": sum(c["passing"] + c["failing"] for c in tests.values()),
        "failures": sum(c["failing"] for c in tests.values()) + (1 if failed else 0),
        "seed": argv[-1],
        "seconds": round(seconds, 1),
        "exit_status": proc.returncode,
    }
    if failed:
        data["log_tail"] = proc.stdout[-4000:]
    _write(args.out or RESULTS / "properties.json", "properties", data)
    _say(f"properties: {data['examples']} examples, {data['failures']} failures")
    return 1 if failed else 0


# -- history ---------------------------------------------------------------------------------
def cmd_history(args: argparse.Namespace) -> int:
    from reliability.history import HistoryConfig, run_history

    runs = []
    bad = False
    for seed in args.seeds:
        config = HistoryConfig(
            ops=args.ops,
            seed=seed,
            max_age=args.max_age,
            faults=not args.no_faults,
        )
        report = run_history(config, progress=lambda n: _say(f"history: {n} ops"))
        data = report.as_json()
        for example in data["examples"]:
            _say(example)
        _say(
            f"history seed {seed}: {data['ops']} ops, {data['checked_reads']} reads and "
            f"{data['checked_writes']} writes checked, {data['violations']} violations"
        )
        runs.append(data)
        bad = bad or bool(data["violations"] or data["crashes"])
    total = {
        "ops": sum(r["ops"] for r in runs),
        "checked": sum(r["checked_reads"] + r["checked_writes"] for r in runs),
        "violations": sum(r["violations"] for r in runs),
    }
    _write(args.out or RESULTS / "history.json", "history", {"total": total, "runs": runs})
    return 1 if bad else 0


# -- table -----------------------------------------------------------------------------------
def matrix_table(data: dict[str, Any]) -> str:
    """The matrix JSON as a markdown table: one row per exchange and direction, one column per
    fault; each cell is completed / typed error / violation counts over the byte positions."""
    from reliability.matrix import FAULTS

    faults = [f.name for f in FAULTS]
    lines = [
        "| exchange | direction | " + " | ".join(faults) + " |",
        "|---|---|" + "---|" * len(faults),
    ]
    errors: dict[str, Counter[str]] = {}
    for case, row in data["table"].items():
        for direction in ("to_controller", "to_host"):
            cells = []
            for fault in faults:
                counts = row.get(fault, {}).get(direction)
                if not counts:
                    cells.append("-")
                    continue
                ok = counts.get("ok", 0)
                bad = sum(n for k, n in counts.items() if k.startswith("VIOLATION"))
                err = sum(counts.values()) - ok - bad
                for key, n in counts.items():
                    if key.startswith("error:"):
                        errors.setdefault(case, Counter())[key[6:]] += n
                cells.append(f"{ok}/{err}/**{bad}**" if bad else f"{ok}/{err}/0")
            arrow = "host → ctrl" if direction == "to_controller" else "ctrl → host"
            lines.append(f"| {case} | {arrow} | " + " | ".join(cells) + " |")
    lines += ["", "| exchange | typed errors raised (cells) |", "|---|---|"]
    for case, counter in errors.items():
        shown = ", ".join(f"{name} {n}" for name, n in counter.most_common())
        lines.append(f"| {case} | {shown} |")
    return "\n".join(lines)


def cmd_table(args: argparse.Namespace) -> int:
    data = json.loads((args.source or RESULTS / "matrix.json").read_text(encoding="utf-8"))
    print(matrix_table(data))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="reliability/run.py", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    fuzz = sub.add_parser("fuzz", help="fuzz the decoders, the link machines and the simulator")
    fuzz.add_argument("--inputs", type=int, default=1_000_000)
    fuzz.add_argument("--seed", type=int, default=0)
    fuzz.add_argument("--engine", choices=("random", "atheris"), default="random")
    fuzz.add_argument("--target", action="append", help="random engine: one target (repeatable)")
    fuzz.add_argument("--out", type=Path)
    fuzz.set_defaults(run=cmd_fuzz)

    matrix = sub.add_parser("matrix", help="the full fault matrix")
    matrix.add_argument("--ci-slice", action="store_true", help="only the CI slice")
    matrix.add_argument("--timeout", type=float, default=1.0, help="client reply timeout (s)")
    matrix.add_argument("--ack-timeout", type=float, default=0.3, help="sim ACK timeout (s)")
    matrix.add_argument("--out", type=Path)
    matrix.set_defaults(run=cmd_matrix)

    soak = sub.add_parser("soak", help="exchanges over loopback TCP against the simulator")
    soak.add_argument("--exchanges", type=int, default=1_000_000)
    soak.add_argument("--out", type=Path)
    soak.set_defaults(run=cmd_soak)

    history = sub.add_parser("history", help="consumers through robostar serve, judged")
    history.add_argument("--ops", type=int, default=100_000, help="operations per seed")
    history.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    history.add_argument(
        "--max-age", type=float, default=None, help="the line's max_age (default: the server's)"
    )
    history.add_argument("--no-faults", action="store_true", help="no faults on the line")
    history.add_argument("--out", type=Path)
    history.set_defaults(run=cmd_history)

    table = sub.add_parser("table", help="print the matrix results as a markdown table")
    table.add_argument("--source", type=Path, help="a matrix JSON (default: the last run's)")
    table.set_defaults(run=cmd_table)

    props = sub.add_parser("properties", help="the link's property tests, many examples")
    props.add_argument("--examples", type=int, default=10_000, help="examples per test")
    props.add_argument("--seed", type=int, default=0, help="hypothesis seed (0: the time)")
    props.add_argument("--out", type=Path)
    props.set_defaults(run=cmd_properties)

    args = parser.parse_args(argv)
    code: int = args.run(args)
    return code


if __name__ == "__main__":
    sys.exit(main())
