"""``h2h-racing evaluate`` over a folder of routes, end to end: this checkout against an older
commit, in the same run; asserts nothing.

    python benchmarks/bench_routes.py --old 5838405                 # 3 repeats, --jobs 1 and 2
    python benchmarks/bench_routes.py --old 5838405 --old-one-thread --repeats 3
    python benchmarks/bench_routes.py --old 5838405 --quick         # a smoke run (4 routes)
    python benchmarks/bench_routes.py --old 5838405 --old-one-thread --no-old-default \
        --also 9b23472                # one torch thread only, and the commit before a change

What is timed: the whole command, as a user runs it (``python -m h2h_racing.cli.command
evaluate --policy P --track FOLDER --episodes 10 --jobs J --json ...``), process start to exit:
imports, loading the routes, the policy's and ``racing_line``'s one-lap attempts, the
reference laps, the table. Per run the bench takes the wall time and the CPU time of the
command and its worker processes (``wait4``: on a shared machine the CPU time says more).

- *new*: this checkout (the installed ``h2h_racing`` must be an editable install of it; the
  bench checks);
- *old*: the commit ``--old`` (``git archive`` into a temporary folder, its package folders
  linked as the wheel installs them, run with ``PYTHONPATH``), as it runs by default;
- *old, one torch thread* (``--old-one-thread``): the same with ``OMP_NUM_THREADS=1``, as its
  worker processes ran torch on a 2-core machine; by default its ``--jobs 1`` ran torch on every
  core, which costs a batch of 10 copies many times more on a loaded machine, and gave
  figures different from ``--jobs 2``'s in the last digits.

Each repeat runs every variant once per ``--jobs``, in an order that alternates between
repeats, so all see the same machine load; a first run of each on one route warms numba's
cache (discarded). At the end the ``--json`` figures of the runs are compared with the new
run's (wall time and ``jobs`` left out): identical, or how many route fields differ and by how
much (a tree acting with torch differs from the numpy actor in the last digits; 5838405 drives
the ``ppo_generalist`` before issue 36's retraining).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
ROUTES = ROOT / ".." / "shared" / "data" / "deepracer_tracks"
LINKS = {"policies": "policies", "training": "training", "league": "league",
         "examples": "examples", "catalogue": "tracks"}
"""The package folders the wheel installs inside ``h2h_racing`` (pyproject's package-dir)."""


def old_tree(ref: str, into: Path) -> Path:
    """Commit ``ref`` of this repository as an importable tree: ``into/h2h_racing`` with its
    package folders linked in (``LINKS``)."""
    into.mkdir(parents=True)
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    for name, folder in LINKS.items():
        link = into / "h2h_racing" / name
        if not link.exists():
            link.symlink_to(Path("..") / folder)
    return into


def run(variant: dict[str, Any], routes: Path, jobs: int, args: argparse.Namespace,
        out: Path) -> dict[str, Any]:
    """One command run: its wall time, CPU time (with its workers') and ``--json`` figures."""
    cmd = [sys.executable, "-m", "h2h_racing.cli.command", "evaluate", "--policy", args.policy,
           "--track", str(routes), "--episodes", str(args.episodes), "--jobs", str(jobs),
           "--json", str(out), "--no-progress"]
    env = {**os.environ, **variant["env"]}
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=tempfile.gettempdir(), env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    # wait4 gives the CPU time of the command and of its waited-for children (the workers).
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    stdout, stderr = proc.stdout.read(), proc.stderr.read()  # type: ignore[union-attr]
    code = os.waitstatus_to_exitcode(status)
    if code not in (0, 1):
        raise RuntimeError(f"{variant['name']} --jobs {jobs} exited {code}:\n{stdout}\n{stderr}")
    figures = json.loads(out.read_text())
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "figures": figures,
            "inner": figures.get("wall_s")}


def comparable(figures: dict[str, Any]) -> dict[str, Any]:
    """The figures without what may differ between equal runs (times, worker count)."""
    out = dict(figures)
    out.pop("wall_s", None)
    out["settings"] = {k: v for k, v in out["settings"].items() if k != "jobs"}
    return out


def describe_differences(a: dict[str, Any], b: dict[str, Any]) -> str:
    """``identical``, or how many route fields differ and the largest relative difference."""
    a, b = comparable(a), comparable(b)
    if a == b:
        return "identical"
    fields, worst = 0, 0.0
    for ra, rb in zip(a["routes"], b["routes"]):
        for key in ra:
            if ra[key] != rb[key]:
                fields += 1
                if isinstance(ra[key], float) and isinstance(rb[key], float) and ra[key]:
                    worst = max(worst, abs(ra[key] - rb[key]) / abs(ra[key]))
    return f"{fields} route fields differ (largest relative difference {worst:.1e})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", required=True,
                        help="the commit to compare with (e.g. 5838405, before issue 40's "
                             "route evaluation)")
    parser.add_argument("--routes", type=Path, default=ROUTES,
                        help=f"the folder of routes (default: {ROUTES})")
    parser.add_argument("--policy", default="ppo_generalist",
                        help="the policy evaluated (default: ppo_generalist)")
    parser.add_argument("--episodes", type=int, default=10,
                        help="one-lap attempts per route (default: 10)")
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2],
                        help="--jobs values to time (default: 1 2)")
    parser.add_argument("--repeats", type=int, default=3,
                        help="runs of every variant per --jobs (default: 3)")
    parser.add_argument("--old-one-thread", action="store_true",
                        help="also time the old commit with OMP_NUM_THREADS=1 (default: off)")
    parser.add_argument("--no-old-default", action="store_true",
                        help="leave out the old commit as it runs by default (its --jobs 1 runs "
                             "torch on every core: minutes on a loaded machine; default: off)")
    parser.add_argument("--also", action="append", default=[], metavar="REF",
                        help="another commit to time as it runs, e.g. the one before a change "
                             "(repeatable; default: none)")
    parser.add_argument("--quick", action="store_true",
                        help="a smoke run: 4 routes, one repeat, --jobs 1 (default: off)")
    args = parser.parse_args()
    import h2h_racing

    if Path(h2h_racing.__file__).resolve().parents[1] != ROOT:
        sys.exit(f"the installed h2h_racing is {h2h_racing.__file__}, not this checkout's; "
                 f"install it editable (pip install -e {ROOT})")
    with tempfile.TemporaryDirectory(prefix="bench_routes_") as tmp_name:
        tmp = Path(tmp_name)
        routes = args.routes.resolve()
        if args.quick:
            routes = tmp / "routes"
            routes.mkdir()
            for path in sorted(args.routes.resolve().iterdir())[:4]:
                (routes / path.name).symlink_to(path)
            args.repeats, args.jobs = 1, [1]
        old = old_tree(args.old, tmp / "old")
        variants = [{"name": "new", "env": {}}]
        if not args.no_old_default:
            variants.append({"name": f"old ({args.old})", "env": {"PYTHONPATH": str(old)}})
        for number, ref in enumerate(args.also):
            tree = old_tree(ref, tmp / f"also{number}")
            variants.append({"name": f"also ({ref})", "env": {"PYTHONPATH": str(tree)}})
        if args.old_one_thread:
            variants.append({"name": f"old ({args.old}), one torch thread",
                             "env": {"PYTHONPATH": str(old), "OMP_NUM_THREADS": "1"}})
        print(f"{platform.machine()}, {os.cpu_count()} CPUs, CPython {platform.python_version()}"
              f"; {args.policy}, {args.episodes} attempts on each of "
              f"{sum(1 for _ in routes.iterdir())} routes ({routes}); load average "
              f"{os.getloadavg()[0]:.1f} at the start", flush=True)
        warm = tmp / "warm"
        warm.mkdir()
        first = sorted(routes.iterdir())[0]
        (warm / first.name).symlink_to(first.resolve())
        for variant in variants:  # numba compiles the old tree's kernels on its first run
            run(variant, warm, 1, args, tmp / "warm.json")
        results: dict[tuple[str, int], list[dict[str, Any]]] = {}
        for repeat in range(args.repeats):
            for jobs in args.jobs:
                order = variants if repeat % 2 == 0 else variants[::-1]
                for variant in order:
                    got = run(variant, routes, jobs, args, tmp / "out.json")
                    results.setdefault((variant["name"], jobs), []).append(got)
                    print(f"repeat {repeat + 1}, --jobs {jobs}, {variant['name']}: "
                          f"{got['wall']:.1f} s wall, {got['cpu']:.1f} s CPU (the command's "
                          f"own wall time {got['inner']} s), load average "
                          f"{os.getloadavg()[0]:.1f}", flush=True)
        print(f"\nmedians over {args.repeats} repeats (min-max), end to end")
        print(f"{'variant':<40} {'jobs':>4} {'wall s':>18} {'CPU s':>18} {'new is x faster':>16}")
        for jobs in args.jobs:
            new = results[("new", jobs)]
            for variant in variants:
                runs = results[(variant["name"], jobs)]
                walls = [r["wall"] for r in runs]
                cpus = [r["cpu"] for r in runs]
                # Paired: each repeat's old run against the same repeat's new run.
                ratio = statistics.median(r["wall"] / n["wall"] for r, n in zip(runs, new))
                print(f"{variant['name']:<40} {jobs:>4} "
                      f"{statistics.median(walls):>6.1f} ({min(walls):.1f}-{max(walls):.1f})"
                      f"{statistics.median(cpus):>8.1f} ({min(cpus):.1f}-{max(cpus):.1f})"
                      f"{'' if variant['name'] == 'new' else f'{ratio:>10.2f}'}")
        print("\nfigures (--json, without wall time and jobs):")
        reference = results[("new", args.jobs[0])][0]["figures"]
        for (name, jobs), runs in results.items():
            texts = {describe_differences(reference, r["figures"]) for r in runs}
            print(f"  {name}, --jobs {jobs} against new, --jobs {args.jobs[0]}: "
                  f"{'; '.join(sorted(texts))}")
        print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
