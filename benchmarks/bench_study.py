"""Runs per second of a Monte Carlo study (`swarm.studies.run_study`) on 1 and 2 workers, on the local
process pool and on Ray, and how well 2 workers scale over 1; and (`--batched`) one worker's runs
per second one run at a time against its runs in batches on the batched simulator.

    python benchmarks/bench_study.py [--mission missions/mine_clear.yaml] [--runs 8] [--seed 0]
                                     [--backends local ray] [--quiet-wait 60]
    python benchmarks/bench_study.py --batched [--runs 64] [--today-runs 8] [--batch B] [--repeat 2]
                                     [--today-ref REF] [--table-ref REF]

Batched (issue 13's target: at least 20 times today's runs/s on one worker, the same table): the
same study on one local worker, today's way and batched, alternately `--repeat` times (the machine
is shared: alternating spreads other programs' load over both). Today's way is this code with
`--batch 1` (each run alone, through the PettingZoo adapter), or, with `--today-ref REF`, the code
of git commit REF (`git archive` into a temporary folder, run in a fresh Python process with that
folder first on its path). Batched is `run_study(..., batch=B)` (B automatic by default: each
point's runs in batches of up to 64). Both plan the point once (each in its own fresh state) and
write every file; the rate is runs / wall time of the `run_study` call, the ratio batched / today.
Check: the two results tables are identical apart from runtime_s (with `--table-ref REF`, batched's
against the code of commit REF's instead: a behaviour change made after today's commit on purpose,
such as issue 12's fix 84e3d4d, changes a run's row without being a speed-up's doing).

Study size: a study's runs go in batches of up to 64, so its rate depends on how many runs it has
(16: about 1.6 runs/s here, 64: about 2.2), while today's way, each run alone, has the same rate
at any size. `--today-runs N` times today's way on the study's first N runs only (the same runs:
a run's seed depends on its number, not on the study's size) and compares their rows with the
batched table's first N: `--runs 64 --today-runs 8` measures a 64-run study in about 5 minutes,
where today's way would take 11 on all 64.

The study: the mission as written (no sweeps: one parameter point), `--runs` runs, seed `--seed`.
The default mission is the shipped `missions/mine_clear.yaml` (24 robots, about 10-15 s per run
here); `--mission missions/landing.yaml` is a quick check that everything works.

Method: for each backend and for 1 and 2 workers, `run_study(spec, out, backend=..., workers=K)`
into a fresh `tempfile.TemporaryDirectory` (so nothing resumes), timed with the wall clock from the
call to its return. That time is everything a user waits for: the local backend with 1 worker runs
in this process; with 2 it starts a forkserver pool (its workers import swarm); the Ray backend
starts a local Ray instance with K CPUs (`ray.init(num_cpus=K)`), its workers, and shuts it down;
all of them write the Parquet parts, results.parquet and summary.json. A rate is runs / wall time;
the speedup is the 2-worker rate over the 1-worker rate of the same backend, the scaling
efficiency the speedup / 2. The table also gives the seconds the workers were busy (the sum of the
table's `runtime_s`) and the rest ("overhead": start-up, Ray's init and shutdown, the wait for the
last run while the other worker idles, writing results), wall - busy / K.

Planning: a worker loads the mission and plans its routes (`plan_mission`) once per point, at its
first run, and keeps the plan (`swarm.studies.runner._prepared_at`). So with 2 workers the same plan is
made twice, once in each, at the same time; that cost cannot be taken out of a run_study call by
warming up, since the workers are fresh processes each time. It is measured separately instead, in
a fresh Python process (as a worker has it: the imports done, then `load_mission` and a first
`plan_mission(mission, seed=mission.seed, workers=1)`), and the table reports, beside the raw
figures, rates and speedups with it excluded: runs / (wall - preparation), one preparation per
configuration, since each worker makes its own and K workers make theirs in parallel. Only that
preparation is taken out; the other start-up costs stay in. The verdicts are on the raw figures.
Here planning mine_clear takes about 2-2.5 s (about a fifth of one run; 2 workers spend it twice,
side by side), landing about 0.07 s; a fresh worker's imports take a further ~0.9 s.

Target: for each backend, 2 workers give at least 1.8 times the runs/s of 1 worker (scaling
efficiency >= 0.9). The machine this was written on has 2 cores, so the 2-worker runs share them
with this process and, on Ray, with Ray's own processes (GCS, raylet). Other programs running at
the same time take cores from the workers and spoil the figures, whichever configuration they hit
(a slowed 1-worker configuration inflates a speedup). So the table gives, per configuration, the
CPU seconds used meanwhile by this benchmark (its own process and every descendant: pool workers,
Ray's daemons and workers) and by every other process, sampled from Linux's /proc every second,
and says when the others' share is large enough to matter. Before each configuration the
benchmark waits (up to `--quiet-wait` seconds) for a 3-second window in which other programs use
less than 5% of a core.

Check: the results tables (results.parquet) of every configuration are identical apart from the
wall-clock column `runtime_s` (the seeds are in the tasks: workers, backend and order make no
difference); compared with pyarrow after dropping that column.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

import swarm.sim.run  # noqa: F401  (imported here so the in-process 1-worker run does not time imports)
from swarm.studies import runner
from swarm.studies.study import StudySpec, run_study
from swarm.studies.table import VOLATILE

ROOT = Path(__file__).resolve().parents[1]
MISSION = ROOT / "missions" / "mine_clear.yaml"
WORKERS = (1, 2)
#: The target: runs/s with 2 workers over runs/s with 1, per backend.
TARGET_SPEEDUP = 1.8
#: Issue 13's target: one worker's runs/s batched over one run at a time.
TARGET_BATCHED = 20.0
#: Other programs' CPU, as a share of one core over a configuration, above which the output warns.
NOISY_SHARE = 0.05

#: What a fresh worker does before its first run, timed (run in a new Python process).
PROBE = """
import json, sys, time
t0 = time.perf_counter()
import swarm.sim.run
import swarm.studies.runner
from swarm.mission.load import load_mission
from swarm.mission.plan import plan_mission
t1 = time.perf_counter()
mission = load_mission(sys.argv[1])
t2 = time.perf_counter()
plan_mission(mission, seed=mission.seed, workers=1)
t3 = time.perf_counter()
plan_mission(mission, seed=mission.seed, workers=1)
t4 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "load_s": t2 - t1, "plan_s": t3 - t2, "plan_again_s": t4 - t3}))
"""


@dataclass
class Result:
    backend: str
    workers: int
    runs: int
    wall_s: float
    busy_s: float  # sum of runtime_s: worker seconds spent in runs (planning included)
    own_cpu_s: float  # CPU seconds this process and its descendants used (nan off Linux)
    others_cpu_s: float  # CPU seconds other programs used meanwhile (nan off Linux)
    table: pa.Table  # results.parquet without the volatile columns

    @property
    def rate(self) -> float:
        return self.runs / self.wall_s

    @property
    def overhead_s(self) -> float:
        return self.wall_s - self.busy_s / self.workers

    def rate_excluding(self, prep_s: float) -> float:
        return self.runs / (self.wall_s - prep_s) if self.wall_s > prep_s else float("nan")


class CpuMeter:
    """CPU seconds used while the `with` block runs, by this process and its descendants (`ours`:
    pool workers, Ray's daemons and workers) and by every other process (`others`), from
    /proc/<pid>/stat sampled every `period_s` on a thread; nan where there is no /proc. What a
    process uses after the last sample that sees it is missed (at most a period's worth); one
    started during the block counts from zero."""

    def __init__(self, period_s: float = 1.0) -> None:
        self.period_s = period_s
        self.available = Path("/proc/self/stat").exists()
        self._hz = os.sysconf("SC_CLK_TCK") if self.available else 100
        self._ours: set[int] = set()
        self._first: dict[int, float] = {}  # pid -> CPU s at the start (0 if started later)
        self._last: dict[int, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._since = 0.0

    def _sample(self) -> None:
        procs: dict[int, tuple[int, float, float]] = {}  # pid -> (ppid, CPU s, start s after boot)
        for entry in os.scandir("/proc"):
            if not entry.name.isdigit():
                continue
            try:
                text = Path(entry.path, "stat").read_text()
            except OSError:  # gone meanwhile
                continue
            f = text[text.rindex(")") + 2 :].split()  # fields from the 3rd (state) on
            procs[int(entry.name)] = (int(f[1]), (int(f[11]) + int(f[12])) / self._hz, int(f[19]) / self._hz)
        children: dict[int, list[int]] = {}
        for pid, (ppid, _, _) in procs.items():
            children.setdefault(ppid, []).append(pid)
        todo = [os.getpid()]
        while todo:
            pid = todo.pop()
            self._ours.add(pid)
            todo.extend(children.get(pid, []))
        for pid, (_, cpu, start) in procs.items():
            self._first.setdefault(pid, 0.0 if start > self._since else cpu)
            self._last[pid] = cpu

    def _loop(self) -> None:
        while not self._stop.wait(self.period_s):
            self._sample()

    def __enter__(self) -> CpuMeter:
        if self.available:
            self._since = float(Path("/proc/uptime").read_text().split()[0])
            self._sample()
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self.available:
            self._stop.set()
            self._thread.join()
            self._sample()

    def _sum(self, ours: bool) -> float:
        if not self.available:
            return float("nan")
        return sum(self._last[p] - self._first[p] for p in self._last if (p in self._ours) == ours)

    @property
    def ours(self) -> float:
        return self._sum(True)

    @property
    def others(self) -> float:
        return self._sum(False)


def wait_quiet(limit_s: float, window_s: float = 3.0) -> tuple[float, float]:
    """Wait until other programs use less than NOISY_SHARE of a core over `window_s`, at most
    `limit_s`; return (seconds waited, their share of a core in the last window)."""
    t0 = time.monotonic()
    while True:
        with CpuMeter() as cpu:
            time.sleep(window_s)
        share = cpu.others / window_s
        if not share > NOISY_SHARE or time.monotonic() - t0 + window_s > limit_s:
            return time.monotonic() - t0, share


def measure_preparation(mission: Path) -> dict[str, float]:
    """Import, load and plan times of a fresh process (what each worker pays once per point)."""
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(mission)], capture_output=True, text=True, check=True, cwd=ROOT
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure_study(spec: StudySpec, backend: str, workers: int) -> Result:
    """Time one run_study into a fresh folder; read back its results table."""
    runner._prepared_at.cache_clear()  # the in-process 1-worker run must plan like a fresh worker
    with tempfile.TemporaryDirectory(prefix=f"bench_study-{backend}{workers}-") as out:
        with CpuMeter() as cpu:
            t0 = time.perf_counter()
            table, _summary = run_study(spec, out, backend=backend, workers=workers)
            wall = time.perf_counter() - t0
        stored = pq.read_table(Path(out) / "results.parquet")
    busy = float(sum(table.column("runtime_s").to_pylist()))
    return Result(
        backend,
        workers,
        table.num_rows,
        wall,
        busy,
        cpu.ours,
        cpu.others,
        stored.drop_columns(list(VOLATILE)),
    )


TODAY = """
import json, sys, time
from pathlib import Path
import pyarrow.parquet as pq
from swarm.studies.study import StudySpec, run_study
mission, runs, seed, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
spec = StudySpec(mission, runs=runs, seed=seed)
t0 = time.perf_counter()
run_study(spec, out, workers=1)
print(json.dumps({"wall_s": time.perf_counter() - t0}))
"""


def measure_today(spec: StudySpec, ref: str, src: Path, out: Path) -> tuple[float, pa.Table]:
    """`run_study` on one worker with the code of git commit `ref` (exported to `src`)."""
    env = dict(os.environ, PYTHONPATH=str(src))
    res = subprocess.run(
        [sys.executable, "-c", TODAY, spec.mission_path, str(spec.runs), str(spec.seed), str(out)],
        capture_output=True, text=True, check=True, cwd=src, env=env,
    )  # fmt: skip
    wall = json.loads(res.stdout.strip().splitlines()[-1])["wall_s"]
    return wall, pq.read_table(out / "results.parquet").drop_columns(list(VOLATILE))


def measure_batched(spec: StudySpec, batch: int | None, out: Path) -> tuple[float, pa.Table]:
    """`run_study` on one worker in this process, batches of `batch` runs (None: automatic)."""
    runner._prepared_at.cache_clear()  # plan like a fresh worker
    runner._setup_at.cache_clear()
    t0 = time.perf_counter()
    run_study(spec, out, workers=1, batch=batch)
    wall = time.perf_counter() - t0
    return wall, pq.read_table(out / "results.parquet").drop_columns(list(VOLATILE))


def batched_main(args: argparse.Namespace) -> None:
    mission = args.mission.resolve()
    spec = StudySpec(str(mission), runs=args.runs, seed=args.seed)
    shown = mission.relative_to(ROOT) if mission.is_relative_to(ROOT) else mission
    today_name = f"git {args.today_ref}" if args.today_ref else "this code, --batch 1"
    batch_name = f"--batch {args.batch}" if args.batch else "--batch auto"
    print(
        f"python {platform.python_version()}, {os.cpu_count()} cpus; mission {shown}; {args.runs} runs, "
        f"seed {args.seed}, one local worker; today: {today_name}; batched: {batch_name}"
    )
    today_runs = min(args.today_runs or args.runs, args.runs)
    today_spec = StudySpec(str(mission), runs=today_runs, seed=args.seed)
    if today_runs < args.runs:
        print(f"today's way on the study's first {today_runs} runs (the same runs as the batched study's)")
    runs_of = {"today": today_runs, "batched": args.runs}
    with tempfile.TemporaryDirectory(prefix="bench_study-batched-") as tmp:
        tmp_path = Path(tmp)
        src = tmp_path / "today-src"
        if args.today_ref:
            _unpack(args.today_ref, src)
        rows = []
        tables: dict[str, pa.Table] = {}
        for k in range(args.repeat):
            for which in ("today", "batched"):
                waited, _ = wait_quiet(args.quiet_wait) if args.quiet_wait > 0 else (0.0, float("nan"))
                out = tmp_path / f"{which}-{k}"
                with CpuMeter() as cpu:
                    if which == "batched":
                        wall, table = measure_batched(spec, args.batch, out)
                    elif args.today_ref:
                        wall, table = measure_today(today_spec, args.today_ref, src, out)
                    else:
                        wall, table = measure_batched(today_spec, 1, out)
                tables.setdefault(which, table)
                rows.append((which, k, wall, cpu.others))
                n = runs_of[which]
                print(
                    f"  {which:<7} #{k + 1}: {n} runs in {wall:7.1f} s = "
                    f"{n / wall:.3f} runs/s (others used {cpu.others / wall:.0%} of a core "
                    f"meanwhile; waited {waited:.0f} s)",
                    flush=True,
                )
        if args.table_ref:
            _unpack(args.table_ref, tmp_path / "table-src")
            _, tables["reference"] = measure_today(
                today_spec, args.table_ref, tmp_path / "table-src", tmp_path / "reference"
            )
    print()
    best = {
        w: max(runs_of[w] / wall for which, _, wall, _ in rows if which == w) for w in ("today", "batched")
    }
    mean = {
        w: runs_of[w] / (sum(wall for which, _, wall, _ in rows if which == w) / args.repeat)
        for w in ("today", "batched")
    }
    print(f"{'':<8} {'runs/s (best)':>13} {'runs/s (mean)':>13}")
    for w in ("today", "batched"):
        print(f"{w:<8} {best[w]:>13.3f} {mean[w]:>13.3f}")
    ratio, ratio_mean = best["batched"] / best["today"], mean["batched"] / mean["today"]
    print(f"{'ratio':<8} {ratio:>12.1f}x {ratio_mean:>12.1f}x")
    verdict = "PASS" if ratio >= TARGET_BATCHED else "FAIL"
    print(f"{verdict}  batched {ratio:.1f}x today's runs/s on one worker (target >= {TARGET_BATCHED:g}x)")
    against = f"git {args.table_ref}" if args.table_ref else "today"
    reference = tables["reference" if args.table_ref else "today"]
    batched = tables["batched"]
    if today_runs < args.runs:  # the runs both made
        batched = batched.filter(pc.less(batched.column("run"), today_runs))
    diff = _differences(reference, batched)
    if diff:
        runs = _differing_runs(reference, batched)
        print(f"FAIL  results.parquet differ from {against}'s apart from runtime_s: {', '.join(diff)}")
        print(f"      in runs {runs}")
    else:
        rows = reference.num_rows
        print(f"PASS  results.parquet identical to {against}'s apart from runtime_s ({rows} rows)")


def _unpack(ref: str, dest: Path) -> None:
    """The code of git commit `ref` into `dest` (`git archive`)."""
    dest.mkdir()
    archive = subprocess.run(["git", "archive", ref], cwd=ROOT, capture_output=True, check=True)
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive.stdout, check=True)


def _differing_runs(a: pa.Table, b: pa.Table) -> list[int]:
    """The `run` numbers of the rows in which two tables of the same runs differ (in the columns
    both have)."""
    shared = [name for name in a.column_names if name in b.column_names]
    rows_a = {r["run"]: r for r in a.select(shared).to_pylist()}
    return sorted(r["run"] for r in b.select(shared).to_pylist() if rows_a.get(r["run"]) != r)


def _differences(a: pa.Table, b: pa.Table) -> list[str]:
    """Columns in which two tables differ: values in the columns both have (an older commit's table
    lacks the columns added since: named as such), or the row count."""
    if a.num_rows != b.num_rows:
        return ["(row count)"]
    shared = [name for name in a.column_names if name in b.column_names]
    only = [f"{name} (one table only)" for name in (*a.column_names, *b.column_names) if name not in shared]
    return [name for name in shared if not a.column(name).equals(b.column(name))] + only


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mission", type=Path, default=MISSION, help="mission YAML (default: mine_clear)")
    ap.add_argument("--runs", type=int, default=8, help="runs per configuration")
    ap.add_argument("--seed", type=int, default=0, help="the study's seed")
    ap.add_argument("--backends", nargs="+", choices=("local", "ray"), default=["local", "ray"])
    ap.add_argument(
        "--quiet-wait",
        type=float,
        default=60.0,
        help="before each configuration, wait up to this many seconds for other programs to go quiet",
    )
    ap.add_argument("--batched", action="store_true", help="one worker: one run at a time against batches")
    ap.add_argument("--batch", type=int, help="--batched: runs per batch (default: automatic)")
    ap.add_argument(
        "--today-runs",
        type=int,
        help="--batched: time today's way on the study's first N runs only (default: all --runs)",
    )
    ap.add_argument("--repeat", type=int, default=2, help="--batched: alternations of today and batched")
    ap.add_argument(
        "--today-ref", help="--batched: today is the code of this git commit (default: --batch 1)"
    )
    ap.add_argument(
        "--table-ref",
        help="--batched: compare the results table with this commit's instead of today's (a "
        "behaviour change since today, such as issue 12's fix 84e3d4d, is not a speed-up's)",
    )
    args = ap.parse_args(argv)
    if args.batched:
        batched_main(args)
        return
    mission = args.mission.resolve()
    spec = StudySpec(str(mission), runs=args.runs, seed=args.seed)

    try:
        import ray

        ray_version = ray.__version__
    except ImportError:
        ray_version = "not installed"
    shown = mission.relative_to(ROOT) if mission.is_relative_to(ROOT) else mission
    print(
        f"python {platform.python_version()}, pyarrow {pa.__version__}, ray {ray_version}, "
        f"{os.cpu_count()} cpus; mission {shown}; {args.runs} runs per configuration, seed {args.seed}"
    )
    prep = measure_preparation(mission)
    prep_s = prep["load_s"] + prep["plan_s"]
    print(
        f"preparing a point in a fresh process: imports {prep['import_s']:.2f} s, load_mission "
        f"{prep['load_s']:.2f} s, plan_mission {prep['plan_s']:.2f} s (again in the same process: "
        f"{prep['plan_again_s']:.2f} s)"
    )
    print(
        f"each worker prepares the point once, at its first run: 1 worker plans once, 2 workers plan twice "
        f"(in parallel); 'excl. plan' figures take {prep_s:.2f} s (load + plan) off each wall time"
    )
    print()

    results: list[Result] = []
    for backend in args.backends:
        for k in WORKERS:
            waited, share = wait_quiet(args.quiet_wait) if args.quiet_wait > 0 else (0.0, float("nan"))
            r = measure_study(spec, backend, k)
            results.append(r)
            print(
                f"  {backend}, {k} worker{'s' if k > 1 else ''}: {r.runs} runs in {r.wall_s:.1f} s "
                f"(waited {waited:.0f} s for a quiet machine; others then used {share:.0%} of a core)",
                flush=True,
            )
    print()

    header = (
        f"{'backend':<7} {'workers':>7} {'runs':>5} | {'wall s':>7} {'busy s':>7} {'overhead s':>10} | "
        f"{'own cpu s':>9} {'others cpu s':>12} | {'runs/s':>7} {'runs/s excl. plan':>17}"
    )
    print(header)
    print("-" * len(header))
    for r in results:
        print(
            f"{r.backend:<7} {r.workers:>7} {r.runs:>5} | {r.wall_s:>7.1f} {r.busy_s:>7.1f} "
            f"{r.overhead_s:>10.1f} | {r.own_cpu_s:>9.1f} {r.others_cpu_s:>12.1f} | "
            f"{r.rate:>7.4f} {r.rate_excluding(prep_s):>17.4f}"
        )
    print()
    header = (
        f"{'backend':<7} | {'speedup 2/1':>11} {'efficiency':>10} | "
        f"{'excl. plan:':>11} {'speedup':>7} {'efficiency':>10}"
    )
    print(header)
    print("-" * len(header))
    verdicts = []
    for backend in args.backends:
        one, two = (next(r for r in results if r.backend == backend and r.workers == k) for k in WORKERS)
        speedup = two.rate / one.rate
        corrected = two.rate_excluding(prep_s) / one.rate_excluding(prep_s)
        print(
            f"{backend:<7} | {speedup:>10.2f}x {speedup / 2:>10.2f} | "
            f"{'':>11} {corrected:>6.2f}x {corrected / 2:>10.2f}"
        )
        verdict = "PASS" if speedup >= TARGET_SPEEDUP else "FAIL"
        verdicts.append(
            f"{verdict}  {backend}: 2 workers {speedup:.2f}x the runs/s of 1 worker (target >= "
            f"{TARGET_SPEEDUP:g}x); {corrected:.2f}x with planning excluded"
        )
    print()
    print("busy s: the sum of the table's runtime_s (worker seconds in runs; each worker's first run plans)")
    print(
        "overhead s: wall - busy / workers (start-up, Ray's init and shutdown, the last run's tail, writing)"
    )
    print("own cpu s: CPU seconds of this process and its descendants (workers, Ray's daemons), from /proc")
    print("others cpu s: CPU seconds used meanwhile by every other program on the machine")
    print("excl. plan: runs / (wall - one preparation); see above")
    print()
    busy = [r for r in results if r.others_cpu_s > NOISY_SHARE * r.wall_s]
    if busy:
        names = ", ".join(
            f"{r.backend} {r.workers} ({r.others_cpu_s / r.wall_s:.0%} of a core)" for r in busy
        )
        print(f"NOTE  other programs took CPU during {names}:")
        print("      they slow whichever configuration they hit, so the rates and speedups above are not")
        print("      the machine's (a slowed 1-worker run inflates a speedup); run again on a quiet machine")
    for line in verdicts:
        print(line)

    ref = results[0]
    mismatches = []
    for r in results[1:]:
        diff = _differences(ref.table, r.table)
        if diff:
            mismatches.append(f"{r.backend} {r.workers} vs {ref.backend} {ref.workers}: {', '.join(diff)}")
    names = ", ".join(f"{r.backend} {r.workers}" for r in results)
    if mismatches:
        print(f"FAIL  results.parquet differ apart from runtime_s: {'; '.join(mismatches)}")
    else:
        print(
            f"PASS  results.parquet identical apart from runtime_s across {names} ({ref.table.num_rows} rows)"
        )


if __name__ == "__main__":  # the local backend's forkserver workers import __main__
    main()
