"""The `swarm` command: parses arguments, calls the library, prints. Bad input: one line, exit 2."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import multiprocessing
import os
import signal
import sys
import tempfile
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NoReturn

from swarm import __version__
from swarm.errors import InputError, SwarmError

EXIT_BAD_INPUT = 2
#: The finest `model validate --fixed-step` (s): a twentieth of calibration's 5 ms, and ten million
#: steps for a quarter-hour run (a finer step only costs memory and time: 1e-12 s asked for 189 TiB).
MIN_FIXED_STEP_S = 1e-4


class _Parser(argparse.ArgumentParser):
    """argparse with its errors as the rest of the command's: one line, exit 2 (argparse prints
    its usage block first; `swarm CMD --help` still shows it). Subcommands inherit the class."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="swarm",
        description="Plan and simulate swarms of small skid-steered robots in the surf zone.",
    )
    parser.add_argument("--version", action="version", version=f"surf-swarm {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    model = commands.add_parser("model", help="robot motion models: validate against runs, calibrate")
    model_cmds = model.add_subparsers(dest="model_command", required=True, metavar="ACTION")

    def run_inputs(p: argparse.ArgumentParser, many: bool) -> None:
        action = "append" if many else "store"
        p.add_argument(
            "--robot", required=True, type=_path, help="robot YAML (mass, geometry, encoder ticks)"
        )
        p.add_argument(
            "--encoders", action=action, type=_path, help="encoder log: time_ms left_ticks right_ticks"
        )
        p.add_argument("--truth", action=action, type=_path, help="pose reference: t X Y heading")
        p.add_argument(
            "--ssv", action=action, type=_path, help="simulation export (.ssv) instead of encoders+truth"
        )
        p.add_argument("--counter-bits", type=int, help="encoder counter width, to unwrap counter overflow")
        p.add_argument(
            "--truth-offset",
            metavar="S|auto",
            help="when each --truth's first sample was taken on its encoder log's clock (s; negative: "
            "before the log began), or auto to estimate it from the motion; default: the logs start "
            "together, with a warning where the motion says otherwise",
        )
        p.add_argument("--model", choices=("skid", "kinematic", "lagrangian"), default="skid")
        p.add_argument("--terrain", type=_path, help="terrain-mode YAML overriding or adding to the defaults")
        p.add_argument(
            "--mode",
            help="terrain mode the runs were on (default: the only mode in --terrain, else concrete)",
        )

    validate = model_cmds.add_parser(
        "validate", help="run a model from the encoders and score it against truth"
    )
    run_inputs(validate, many=True)
    validate.add_argument("--compare", action="store_true", help="also score the other two models")
    validate.add_argument(
        "--fixed-step",
        type=float,
        metavar="DT_S",
        help="skid model: integration step (s); default 0.005, the step calibration uses",
    )
    validate.add_argument(
        "--adaptive",
        action="store_true",
        help="skid model: adaptive LSODA, its step bounded by --fixed-step, instead of fixed steps",
    )
    validate.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    validate.add_argument(
        "--plot", type=_path, metavar="FIG.png", help="write the thesis-style overlay figure"
    )
    validate.add_argument(
        "--out",
        type=_path,
        metavar="DIR",
        help="write validation.json, validation.npz and the report (report.html, .md, .json) here",
    )
    validate.set_defaults(handler=_cmd_validate)

    calibrate = model_cmds.add_parser(
        "calibrate", help="fit a model's terrain coefficients to one or more runs"
    )
    run_inputs(calibrate, many=True)
    calibrate.add_argument("--name", help="name of the fitted mode in the output (default: --mode)")
    calibrate.add_argument("--free", help="comma-separated parameters to fit (default: all the model has)")
    calibrate.add_argument(
        "--max-evaluations", type=int, default=60, help="least-squares budget (default 60)"
    )
    calibrate.add_argument("--json", action="store_true", help="print the result as JSON")
    calibrate.add_argument("--out", required=True, type=_path, help="terrain-mode YAML to write")
    calibrate.set_defaults(handler=_cmd_calibrate)
    _add_map_commands(commands)
    _add_path_command(commands)
    _add_plan_command(commands)
    _add_simulate_command(commands)
    _add_study_command(commands)
    _add_report_command(commands)
    schema = commands.add_parser("schema", help="print the mission file JSON Schema (for editors)")
    schema.set_defaults(handler=_cmd_schema)
    return parser


def _add_map_commands(commands) -> None:
    """`swarm map info|show|generate|import-dem`: beach maps (swarm/world)."""
    beach = commands.add_parser("map", help="beach maps: describe, draw, generate, import a DEM")
    map_cmds = beach.add_subparsers(dest="map_command", required=True, metavar="ACTION")
    terrain_help = "terrain-mode YAML adding modes the map's classes name (default: the bundled modes)"

    info = map_cmds.add_parser("info", help="size, cell, terrain fractions, elevation, slope, regions")
    info.add_argument("map", type=_path, metavar="MAP.yaml")
    info.add_argument("--terrain", type=_path, help=terrain_help)
    info.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    info.set_defaults(handler=_cmd_map_info)

    show = map_cmds.add_parser("show", help="draw the map: terrain, elevation contours, regions")
    show.add_argument("map", type=_path, metavar="MAP.yaml")
    show.add_argument("--terrain", type=_path, help=terrain_help)
    show.add_argument("-o", "--out", required=True, type=_path, metavar="FIG.png", help="figure to write")
    show.set_defaults(handler=_cmd_map_show)

    generate = map_cmds.add_parser("generate", help="a procedural beach (swarm.world.generate)")
    generate.add_argument("--seed", type=int, help="random seed (same seed, same beach)")
    generate.add_argument("--length-m", type=float, help="alongshore length (m)")
    generate.add_argument("--width-m", type=float, help="cross-shore width (m)")
    generate.add_argument("--d50-mm", type=float, help="median sand grain size (mm)")
    generate.add_argument("--breaker-height-m", type=float, help="breaking wave height (m)")
    generate.add_argument("--cell-m", type=float, help="grid cell size (m)")
    generate.add_argument("--wave-period-s", type=float, help="swell period (s), for the run-up (default 8)")
    generate.add_argument(
        "--tide-range-m", type=float, help="tidal range (m) widening the wet band (default 1)"
    )
    generate.add_argument(
        "--rock-outcrops",
        type=float,
        help="rock outcrops ringed by boulders: about 1 for a rock platform every 300 m, 0..5 (default 0)",
    )
    generate.add_argument("--river-mouth", action="store_true", help="a river through the dunes into the sea")
    generate.add_argument("--name", help="map name (default: the output file's stem)")
    generate.add_argument(
        "-o", "--out", required=True, type=_path, metavar="maps/NAME.yaml", help="map YAML to write (+ .npz)"
    )
    generate.set_defaults(handler=_cmd_map_generate)

    dem = map_cmds.add_parser(
        "import-dem", help="a map from an ESRI ASCII DEM (.asc), terrain classified by elevation"
    )
    dem.add_argument(
        "dem", type=_path, metavar="DEM.asc", help="elevation grid, metres, projected x east y north"
    )
    dem.add_argument("--name", help="map name (default: the output file's stem)")
    dem.add_argument("--fill", type=float, metavar="M", help="elevation (m) for NODATA cells")
    dem.add_argument(
        "-o", "--out", required=True, type=_path, metavar="maps/NAME.yaml", help="map YAML to write (+ .npz)"
    )
    dem.set_defaults(handler=_cmd_map_import_dem)


def _check_output(path: Path | None, option: str, suffixes: tuple[str, ...]) -> None:
    """Refuse an output we could not write before doing any work for it."""
    if path is None:
        return
    if path.suffix.lower() not in suffixes:
        raise InputError("command line", option, str(path), f"a file name ending in {', '.join(suffixes)}")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(
            "command line", option, str(path), f"a file in an existing folder ({parent} is not one)"
        )
    try:  # a trial file, not os.access: root passes os.access on /proc, and a calibration's fit
        # would run its minute before the write failed
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as exc:
        raise InputError(
            "command line", option, str(path), f"a file in a folder this user may write ({exc.strerror})"
        ) from None


def _check_replaces(path: Path | None, option: str, key: str, what: str) -> None:
    """Refuse to write over an existing file that is not a `what` (a YAML mapping with `key`):
    `--out missions/recon.yaml` on `map generate` or `model calibrate` would destroy the mission."""
    if path is None or not path.exists():
        return
    import yaml

    try:
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        doc = None
    if not isinstance(doc, dict) or key not in doc:
        raise InputError(
            "command line", option, str(path), f"a new file or {what} to replace (this is not one)"
        )


FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


def _check_folder(path: Path | None, option: str) -> None:
    """Refuse an output folder that is a file, or whose parent does not exist, before any work."""
    if path is None:
        return
    if path.exists() and not path.is_dir():
        raise InputError("command line", option, str(path), "a folder (this is a file)")
    parent = path.parent if str(path.parent) else Path(".")
    if not path.exists() and not parent.is_dir():
        raise InputError(
            "command line", option, str(path), f"a folder in an existing folder ({parent} is not one)"
        )


#: Seeds are unsigned 64-bit integers: numpy's `SeedSequence` takes any, a study's table holds these.
SEED_LIMIT = 2**64


def _check_seed(option: str, value: int | None) -> None:
    """Refuse a seed a run's table could not hold, the same range for every command."""
    if value is not None and not 0 <= value < SEED_LIMIT:
        raise InputError("command line", option, value, "a seed from 0 to 2**64 - 1")


#: A progress bar is drawn once its work has run this long (s): input refused at the start of the
#: work (a study's resume check, a map no robot can drive on) leaves only its one line on stderr.
BAR_DELAY_S = 1.0


def _bar(**kwargs):
    """The commands' progress bar on stderr (tqdm), drawn after `BAR_DELAY_S`, whether it moves by
    `update` or by setting its count and calling `refresh` (which tqdm draws at once)."""
    from tqdm import tqdm

    class Delayed(tqdm):
        def refresh(self, *args, **kw):
            start = getattr(self, "start_t", None)  # None: tqdm's own first draw (no delay)
            if start is None or self._time() >= start + self.delay:
                return super().refresh(*args, **kw)
            return None

    return Delayed(file=sys.stderr, delay=BAR_DELAY_S, **kwargs)


def _count_runs(bar, done: float, total: int) -> None:
    """Move a bar of runs to `done` of `total`: never back (a batch's share is taken back when its
    runs finish, a moment before they are counted), a share of a run to one decimal."""
    done = round(float(done), 1)
    bar.total = total
    if done > bar.n:
        bar.n = int(done) if done.is_integer() else done
        bar.refresh()


def _print_json(value: object, indent: int | None = None) -> None:
    """One JSON document on stdout, NaN and infinities as null (bare NaN is not JSON)."""
    from swarm.report.document import jsonable

    print(json.dumps(jsonable(value), indent=indent, allow_nan=False))


def _path(text: str) -> Path:
    """A path argument; an empty one is refused (Path("") is the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("found an empty path, expected a file or folder name")
    return Path(text)


def _output_folder(folder: Path, args: argparse.Namespace, kind: str | None = None):
    """The lock on an output folder while this command writes it (`swarm.files.folder_lock`): a
    second swarm process writing the same folder stops with one line naming the holder. With
    `kind` (the command's own), a folder holding another command's output is refused: a study
    written into a plan's folder would overwrite its report and leave neither readable."""
    from swarm.files import folder_lock
    from swarm.report.load import output_kind

    held = output_kind(folder) if kind is not None else None
    if held not in (None, kind):
        expected = f"a new folder or a {kind} folder (this one holds a {held}'s output)"
        raise InputError("command line", "--out", str(folder), expected)
    return folder_lock(folder, getattr(args, "command_line", None))


def _choose_mode(args: argparse.Namespace):
    from swarm.files import read_yaml
    from swarm.robot.terrain import default_library, library_from_dict

    library = default_library()
    name = args.mode
    if args.terrain is not None:
        own = library_from_dict(read_yaml(args.terrain, "terrain YAML file"), args.terrain, library)
        library = library.merged(own)
        if name is None:
            if len(own) != 1:
                raise InputError(args.terrain, "modes", sorted(own), "one mode, or --mode NAME to choose")
            name = next(iter(own))
    name = name or "concrete"
    if name not in library:
        raise InputError(args.terrain or "command line", "--mode", name, f"one of {sorted(library)}")
    return library[name]


def _runs(args: argparse.Namespace, robot) -> list:
    from swarm.robot.runs import load_encoder_run, load_ssv_run

    def listed(value):
        return [] if value is None else value if isinstance(value, list) else [value]

    encoders, truths, ssvs = listed(args.encoders), listed(args.truth), listed(args.ssv)
    if ssvs and (encoders or truths):
        raise InputError("command line", "--ssv", "--ssv with --encoders/--truth", "one or the other")
    if len(encoders) != len(truths):
        raise InputError(
            "command line",
            "--encoders/--truth",
            f"{len(encoders)} logs and {len(truths)} truths",
            "one --truth for each --encoders, in the same order",
        )
    if not encoders and not ssvs:
        raise InputError(
            "command line", "--encoders", "nothing", "--encoders E.txt --truth T.txt, or --ssv S.ssv"
        )
    offset = _truth_offset(args.truth_offset)
    runs = []
    for e, t in zip(encoders, truths, strict=True):
        run = load_encoder_run(robot, e, t, args.counter_bits)
        runs.append(_offset_run(run, offset, robot, t, e))
    return runs + [load_ssv_run(s) for s in ssvs]


def _truth_offset(text: str | None) -> float | str | None:
    """--truth-offset: seconds, "auto", or None (not given)."""
    if text is None or text == "auto":
        return text
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise InputError("command line", "--truth-offset", text, "seconds (a number) or auto")
    return value


def _offset_run(run, offset: float | str | None, robot, truth: Path, encoders: Path):
    """`run` on one clock: its reference shifted by the offset given, the estimated one with
    "auto", and as it is without one (a warning where the motion puts the reference's start
    `runs.TRUTH_OFFSET_WARN_S` or more off the encoder log's)."""
    from swarm.robot.runs import TRUTH_OFFSET_WARN_S, truth_offset_s, with_truth_offset

    if isinstance(offset, float):
        return with_truth_offset(run, offset)
    estimate = truth_offset_s(run, robot)
    if offset == "auto":
        said = (
            f"taken as starting {estimate:+.2f} s into {encoders}"
            if estimate
            else f"no shift explains the motion clearly better: taken to start with {encoders}"
        )
        print(f"note: {truth}: {said} (--truth-offset auto)", file=sys.stderr)
        return with_truth_offset(run, estimate)
    if abs(estimate) >= TRUTH_OFFSET_WARN_S:
        print(
            f"warning: {truth}: its motion matches {encoders}'s best with its first sample {estimate:+.2f} s "
            "into the log, but the logs are taken to start together (--truth-offset S or auto if they "
            "did not)",
            file=sys.stderr,
        )
    return run


def _table(rows: Sequence[Sequence[str]]) -> str:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    lines = [
        "  ".join(c.rjust(w) if j else c.ljust(w) for j, (c, w) in enumerate(zip(r, widths, strict=True)))
        for r in rows
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _score_rows(scores) -> list[list[str]]:
    """The score table; a run that travelled no distance has no RMSE share ("n/a", not "nan")."""
    rows = [["model", "run", "distance m", "final err m", "path RMSE m", "RMSE % dist", "heading RMSE deg"]]
    for s in scores:
        rows.append(
            [
                s.model,
                s.run,
                f"{s.distance_m:.2f}",
                f"{s.final_error_m:.3f}",
                f"{s.path_rmse_m:.3f}",
                f"{s.path_rmse_pct:.2f}" if math.isfinite(s.path_rmse_pct) else "n/a",
                f"{s.heading_rmse_deg:.2f}",
            ]
        )
    return rows


def _no_distance_notes(scores) -> list[str]:
    """One line per run that travelled no distance, saying why its RMSE % is n/a (as the
    validation report's NO VERDICT does)."""
    runs = dict.fromkeys(s.run for s in scores if not math.isfinite(s.path_rmse_pct))
    return [
        f"{run}: no verdict (RMSE % dist n/a): the run travelled no distance to share the error by"
        for run in runs
    ]


def _cmd_validate(args: argparse.Namespace) -> int:
    from swarm.robot.params import load_robot
    from swarm.robot.validate import validate

    _check_output(args.plot, "--plot", FIGURE_SUFFIXES)
    _check_folder(args.out, "--out")
    robot = load_robot(args.robot)
    mode = _choose_mode(args)
    runs = _runs(args, robot)
    for key, given, what in (("--plot", args.plot, "figure"), ("--out", args.out, "report")):
        if given is not None and len(runs) > 1:
            raise InputError("command line", key, f"{len(runs)} runs", f"one run for its {what}")
    models = [args.model] + (
        [m for m in ("skid", "kinematic", "lagrangian") if m != args.model] if args.compare else []
    )
    for key, given in (("--fixed-step", args.fixed_step is not None), ("--adaptive", args.adaptive)):
        if given and "skid" not in models:
            raise InputError("command line", key, f"--model {args.model}", f"{key} with the skid model")
    if args.fixed_step is not None and not MIN_FIXED_STEP_S <= args.fixed_step <= 0.1:
        raise InputError(
            "command line", "--fixed-step", args.fixed_step, f"a step in [{MIN_FIXED_STEP_S:g}, 0.1] seconds"
        )
    opts = {"adaptive": args.adaptive, **({} if args.fixed_step is None else {"dt_s": args.fixed_step})}
    each = [
        {m: validate(run, robot, mode, m, **(opts if m == "skid" else {})) for m in models} for run in runs
    ]
    run, results = runs[0], each[0]
    scores = {m: r[0] for m, r in results.items()}
    if args.plot is not None:
        from swarm.report.validation import plot_validation

        plot_validation(run, {m: r[1] for m, r in results.items()}, scores, args.plot)
    written: dict[str, Path] = {}
    if args.out is not None:
        from swarm.report.document import today
        from swarm.report.validation_report import Validation, validation_report, write_validation

        v = Validation(
            run=run.name,
            distance_m=run.distance_m,
            truth=run.truth,
            trajectories={m: r[1] for m, r in results.items()},
            scores=scores,
            model=args.model,
            terrain=mode.name,
            robot=str(args.robot),
        )
        with _output_folder(args.out, args, "validation"):
            written = {
                **write_validation(args.out, v),
                **validation_report(v, date=today()).write_all(args.out),
            }
    if args.json:
        objects = []
        for by_model in each:
            out = by_model[args.model][0].as_dict()
            if args.compare:
                out["compare"] = [by_model[m][0].as_dict() for m in models[1:]]
            objects.append(out)
        out = objects[0] if len(objects) == 1 else {"runs": objects}
        if args.plot is not None:
            out["plot"] = str(args.plot)
        if args.out is not None:
            out["out"] = str(args.out)
        _print_json(out, indent=2)
    else:
        print(f"terrain mode: {mode.name}")
        validated = [r[0] for by_model in each for r in by_model.values()]
        print(_table(_score_rows(validated)))
        for line in _no_distance_notes(validated):
            print(line)
        if args.plot is not None:
            print(f"figure: {args.plot}")
        if written:
            print(f"wrote {', '.join(sorted(written))} in {args.out}")
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    from swarm.robot.calibrate import COM_PARAMS, MODEL_BOUNDS, calibrate, write_calibration
    from swarm.robot.params import load_robot

    _check_output(args.out, "--out", (".yaml", ".yml"))
    _check_replaces(args.out, "--out", "modes", "a terrain YAML")
    robot = load_robot(args.robot)
    base = _choose_mode(args)
    if args.mode is not None:
        chosen = f"mode '{base.name}' (--mode)"
    elif args.terrain is not None:
        chosen = f"mode '{base.name}' (the only mode in {args.terrain})"
    else:
        chosen = f"mode '{base.name}' (the default: no --mode given; say --mode soft_sand for a sand run)"
    runs = _runs(args, robot)
    free = None
    if args.free is not None:
        free = [f.strip() for f in args.free.split(",") if f.strip()]
        if not free:
            raise InputError("command line", "--free", args.free, "a comma-separated list of parameters")
        allowed = [*MODEL_BOUNDS[args.model], *(COM_PARAMS if args.model == "skid" else ())]
        for f in free:
            if f not in allowed:
                raise InputError(
                    "command line", "--free", f, f"parameters of the {args.model} model: {', '.join(allowed)}"
                )
    if args.max_evaluations < 1:
        raise InputError("command line", "--max-evaluations", args.max_evaluations, "a positive integer")
    if args.name is not None and not args.name.strip():
        raise InputError("command line", "--name", args.name, "a non-empty terrain mode name")
    if not args.json:
        print(f"fitting {args.model} coefficients, starting from terrain {chosen}", file=sys.stderr)
    with _bar(desc=f"calibrating {args.model}", unit="sim", disable=args.json) as bar:
        result = calibrate(
            runs,
            robot,
            base,
            args.model,
            free=free,
            name=args.name,
            max_evaluations=args.max_evaluations,
            progress=bar.update,
        )
    write_calibration(args.out, result, robot, runs)
    if args.json:
        _print_json(
            {
                "model": result.model,
                "mode": result.mode.name,
                "fitted_from": base.name,
                "fitted_from_why": chosen,
                "out": str(args.out),
                "parameters": result.parameters,
                "std_errors": result.std_errors,
                "priors": result.priors,
                "resolution": result.resolution,
                "held_by_prior": result.held_by_prior,
                "warnings": result.warnings,
                "before": [s.as_dict() for s in result.before],
                "after": [s.as_dict() for s in result.after],
            },
            indent=2,
        )
        return 0
    rows = [["parameter", "fitted", "std error", "prior", "set by"]]
    for k, v in result.parameters.items():
        prior, sigma = result.priors.get(k, (float("nan"), float("nan")))
        by = "prior (runs say little)" if k in result.held_by_prior else "the runs"
        rows.append([k, f"{v:.4g}", f"{result.std_errors[k]:.2g}", f"{prior:.3g} +- {sigma:.2g}", by])
    print(_table(rows))
    for line in result.warnings:
        print(f"warning: {line}", file=sys.stderr)
    print()
    before, after = _score_rows(result.before), _score_rows(result.after)
    rows = [before[0]] + [[f"{r[0]} (start)", *r[1:]] for r in before[1:]]
    rows += [[f"{r[0]} (fitted)", *r[1:]] for r in after[1:]]
    print(_table(rows))
    for line in _no_distance_notes(result.before):
        print(line)
    print(f"wrote terrain mode '{result.mode.name}' to {args.out}, fitted from terrain {chosen}")
    return 0


MAP_SUFFIXES = (".yaml", ".yml")


def _load_map_arg(args: argparse.Namespace):
    from swarm.robot.terrain import load_library
    from swarm.world.io import load_map

    library = load_library(args.terrain)
    return load_map(args.map, library), library


def _fraction(value: float) -> str:
    return "<0.1%" if 0 < value < 0.0005 else f"{value:.1%}"


def _cmd_map_info(args: argparse.Namespace) -> int:
    beach_map, library = _load_map_arg(args)
    info = {"file": str(args.map), **beach_map.summary(library)}
    if args.json:
        _print_json(info, indent=2)
        return 0
    print(f"map {info['name']} ({args.map})")
    print(
        f"size       {info['cols']} x {info['rows']} cells (cols x rows) = "
        f"{info['width_m']:g} m east-west x {info['height_m']:g} m north-south"
    )
    x0, y0, x1, y1 = info["bounds_m"]
    print(
        f"cell       {info['cell_m']:g} m; origin ({x0:g}, {y0:g}) m; x {x0:g}..{x1:g} m, y {y0:g}..{y1:g} m"
    )
    if "crs" in info:
        e, n = info["crs_origin_m"]
        print(f"crs        {info['crs']}; origin at easting {e:.2f} m, northing {n:.2f} m")
    print(
        f"elevation  {info['elevation_min_m']:.2f} .. {info['elevation_max_m']:.2f} m; "
        f"max slope {info['max_slope_deg']:.1f} deg; impassable {_fraction(info['impassable_fraction'])}"
    )
    print()
    rows = [["terrain class", "cells", "fraction"]]
    rows += [
        [c, str(info["terrain_cells"][c]), _fraction(info["terrain_fractions"][c])]
        for c in info["terrain_classes"]
    ]
    print(_table(rows))
    if info["regions"]:
        print()
        rows = [["region", "kind", "geometry", "area m2", "length m", "position m"]]
        rows += [
            [
                r["name"],
                r["kind"],
                r["geometry"],
                f"{r['area_m2']:.1f}",
                f"{r['length_m']:.1f}",
                f"({r['position_m'][0]:.1f}, {r['position_m'][1]:.1f})",
            ]
            for r in info["regions"]
        ]
        print(_table(rows))
    else:
        print("no regions")
    return 0


def _cmd_map_show(args: argparse.Namespace) -> int:
    _check_output(args.out, "--out", FIGURE_SUFFIXES)
    beach_map, _ = _load_map_arg(args)
    from swarm.report.map_figure import plot_map

    plot_map(beach_map, args.out)
    print(f"figure: {args.out}")
    return 0


def _map_name(args: argparse.Namespace) -> str:
    name = args.name if args.name is not None else args.out.stem
    if not name.strip():
        raise InputError("command line", "--name", name, "a non-empty map name")
    return name


def _cmd_map_generate(args: argparse.Namespace) -> int:
    _check_output(args.out, "--out", MAP_SUFFIXES)
    _check_replaces(args.out, "--out", "grid", "a map YAML")
    given = {
        "length_m": args.length_m,
        "width_m": args.width_m,
        "d50_mm": args.d50_mm,
        "breaker_height_m": args.breaker_height_m,
        "cell_m": args.cell_m,
    }
    for key, value in given.items():
        if value is not None and not (value > 0 and value < float("inf")):
            raise InputError("command line", "--" + key.replace("_", "-"), value, "a positive number")
    if args.wave_period_s is not None and not 0 < args.wave_period_s < float("inf"):
        raise InputError("command line", "--wave-period-s", args.wave_period_s, "a positive number")
    for key in ("tide_range_m", "rock_outcrops"):
        value = getattr(args, key)
        if value is not None and not 0 <= value < float("inf"):
            raise InputError("command line", "--" + key.replace("_", "-"), value, "a number >= 0")
    _check_seed("--seed", args.seed)
    from swarm.world.generate import generate_beach
    from swarm.world.io import save_map

    extra = {
        "wave_period_s": args.wave_period_s,
        "tide_range_m": args.tide_range_m,
        "rock_outcrops": args.rock_outcrops,
        "river_mouth": True if args.river_mouth else None,
    }
    options = {k: v for k, v in {"seed": args.seed, **given, **extra}.items() if v is not None}
    try:
        beach_map = generate_beach(name=_map_name(args), **options)
    except InputError as exc:  # its ranges, as the flag that gave the value
        if exc.where not in options:
            raise
        raise InputError(
            "command line", "--" + exc.where.replace("_", "-"), exc.found, exc.expected
        ) from None
    save_map(beach_map, args.out)
    rows, cols = beach_map.shape
    print(
        f"wrote {args.out} and {args.out.with_suffix('.npz')}: {beach_map.name}, "
        f"{beach_map.width_m:g} m x {beach_map.height_m:g} m, {cols} x {rows} cells of {beach_map.cell_m:g} m"
    )
    return 0


def _cmd_map_import_dem(args: argparse.Namespace) -> int:
    from swarm.world.io import MAX_ELEVATION_M, map_from_dem, save_map

    _check_output(args.out, "--out", MAP_SUFFIXES)
    if args.fill is not None and not abs(args.fill) <= MAX_ELEVATION_M:
        raise InputError(
            "command line", "--fill", args.fill, f"an elevation (m) within +-{MAX_ELEVATION_M:g} m"
        )
    _check_replaces(args.out, "--out", "grid", "a map YAML")
    beach_map = map_from_dem(args.dem, _map_name(args), fill=args.fill)
    save_map(beach_map, args.out)
    rows, cols = beach_map.shape
    print(
        f"wrote {args.out} and {args.out.with_suffix('.npz')}: {beach_map.name}, "
        f"{cols} x {rows} cells of {beach_map.cell_m:g} m from {args.dem}"
    )
    return 0


# --- swarm path: OMPL path planning (swarm/planning) -------------------------------------------
#: Runs per profile of `swarm path --benchmark` unless --runs says otherwise.
BENCHMARK_RUNS = 10


def _add_path_command(commands) -> None:
    """`swarm path MAP --from X,Y --to X,Y`, or `--benchmark P1.yaml,P2.yaml -o bench.log`."""
    path = commands.add_parser(
        "path",
        help="plan a path on a map with OMPL, or export OMPL's benchmark log for planner profiles",
    )
    path.add_argument("map", type=_path, metavar="MAP.yaml")
    path.add_argument("--from", dest="start", metavar="X,Y", help="start, world metres")
    path.add_argument("--to", dest="goal", metavar="X,Y", help="goal, world metres")
    path.add_argument(
        "--profile", type=_path, metavar="P.yaml", help="planner profile (default: the built-in 'fast')"
    )
    path.add_argument("--seed", type=int, default=0, help="random seed: same seed and profile, same path")
    path.add_argument("--robot", type=_path, help="robot YAML (default: the bundled skid4)")
    path.add_argument(
        "--terrain", type=_path, help="terrain-mode YAML overriding or adding to the bundled modes"
    )
    path.add_argument("--json", action="store_true", help="print one JSON object")
    bench = path.add_argument_group("benchmark export (OMPL's Benchmark tool)")
    bench.add_argument(
        "--benchmark", metavar="P1.yaml,P2.yaml", help="comma-separated profiles to benchmark on the map"
    )
    bench.add_argument("--runs", type=int, help=f"runs per profile (default {BENCHMARK_RUNS})")
    bench.add_argument(
        "--time", type=float, metavar="S", help="seconds per run (default: the profiles' time_s, else 1)"
    )
    bench.add_argument(
        "--objective", choices=("length", "terrain_cost"), help="the experiment's one objective"
    )
    bench.add_argument("-o", "--out", type=_path, metavar="bench.log", help="benchmark log to write")
    path.set_defaults(handler=_cmd_path)


# --- swarm plan: a mission plan (swarm/mission/plan.py) ---------------------------------------------
def _add_plan_command(commands) -> None:
    """`swarm plan MISSION.yaml [--seed N] [--out DIR] [--set KEY=VALUE ...] [--evaluate N]`."""
    plan = commands.add_parser(
        "plan", help="allocate a mission's tasks, plan every robot's route, write plan and report"
    )
    plan.add_argument("mission", type=_path, metavar="MISSION.yaml")
    plan.add_argument(
        "--seed",
        type=int,
        help="random seed (default: the mission's seed): same seed, byte-identical plan.json",
    )
    plan.add_argument(
        "--out",
        type=_path,
        metavar="DIR",
        help="output folder (default: reports/<mission>-<YYYYmmdd-HHMMSS>/)",
    )
    _add_set_option(plan)
    plan.add_argument("--workers", type=int, help="planning processes (default: the CPU count)")
    plan.add_argument(
        "--evaluate",
        type=int,
        default=0,
        metavar="N",
        help="also simulate the plan N times (all cores) and add P(success), detection and losses to "
        "the report; when the target is missed, a quick sweep suggests a swarm size (default: off)",
    )
    plan.add_argument(
        "--target", type=float, default=0.9, help="P(success) the evaluation checks for (default 0.9)"
    )
    plan.set_defaults(handler=_cmd_plan)


def _cmd_plan(args: argparse.Namespace) -> int:
    import time

    from swarm.mission import load_mission
    from swarm.mission.plan import plan_mission, write_plan
    from swarm.report.document import today
    from swarm.report.plan_report import (
        against_plan,
        plan_report,
        robots_range,
        summary_rows,
        verdict_brief,
    )
    from swarm.sim.memory import check_fits
    from swarm.studies.stats import agreement
    from swarm.studies.sweep import check_study_size

    _check_seed("--seed", args.seed)
    if args.workers is not None and args.workers < 1:
        raise InputError("command line", "--workers", args.workers, "at least 1")
    if args.evaluate < 0:
        raise InputError("command line", "--evaluate", args.evaluate, "a number of runs >= 0")
    check_study_size("--evaluate", args.evaluate, [])
    if not 0.0 < args.target < 1.0:
        raise InputError("command line", "--target", args.target, "a probability strictly between 0 and 1")
    overrides = _overrides(args.overrides)
    if not args.mission.is_file():
        raise InputError("command line", "MISSION.yaml", str(args.mission), "an existing mission YAML file")
    mission = load_mission(args.mission, overrides, overrides_source="--set")
    check_fits(mission, simulate=bool(args.evaluate), at_once=1)
    out = args.out or Path("reports") / f"{mission.name}-{time.strftime('%Y%m%d-%H%M%S')}"
    if out.exists() and not out.is_dir():
        raise InputError("command line", "--out", str(out), "a folder (this is a file)")
    with _output_folder(out, args, "plan"):
        with _bar(desc="planning routes", unit="route", leave=False) as bar:

            def progress(done: int, total: int) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            seed = mission.seed if args.seed is None else args.seed
            plan = plan_mission(mission, seed=seed, progress=progress, workers=args.workers)
        from swarm.studies.evaluate import discard_stale, plan_spec

        again = None  # the evaluation this plan gets, if any: an earlier plan's is not this one's
        if args.evaluate:
            again = plan_spec(args.mission, args.evaluate, overrides, args.seed, args.target)
        discard_stale(out, again)
        paths = write_plan(plan, out)
        evaluation = None
        if args.evaluate:
            from swarm.studies.evaluate import EVALUATION_FILE, evaluate_plan

            with _bar(desc="evaluating", unit="run", leave=False) as bar:

                def run_progress(done: float, total: int) -> None:
                    _count_runs(bar, done, total)

                evaluation = evaluate_plan(
                    args.mission,
                    out,
                    runs=args.evaluate,
                    count=mission.swarm.count,
                    overrides=overrides,
                    plan_seed=args.seed,
                    target=args.target,
                    workers=args.workers,
                    progress=run_progress,
                )
            paths[EVALUATION_FILE] = out / EVALUATION_FILE
        report = plan_report(plan, date=today(), evaluation=evaluation)
        paths.update(report.write_all(out))
        print(f"plan for {plan.mission} on {plan.map}, seed {plan.seed}")
        rows = summary_rows(plan)
        width = max(len(k) for k, _ in rows)
        for key, value in rows:
            print(f"  {key.ljust(width)}  {value}")
        if evaluation is not None:
            chance = evaluation.get("planned_success")
            wilson = (evaluation["wilson_low"], evaluation["wilson_high"])
            said = [
                f"P(success) {evaluation['success_rate']:.2f} over {evaluation['runs']} runs "
                f"({wilson[0]:.2f} to {wilson[1]:.2f}"
                + (
                    ""
                    if chance is None
                    else f"; plan {chance:.2f}: {agreement(chance, wilson, more_is_better=True)}"
                )
                + f"), target {evaluation['target']:g}"
            ]
            found, planned = (evaluation.get("detection") or {}).get("mean"), plan.expected_detection
            confidence = evaluation["confidence"]
            if found is not None and planned is not None:
                said.append(
                    f"detection {found:.1%} a run"
                    + against_plan(
                        planned, evaluation.get("detection_interval"), ".1%", confidence, more_is_better=True
                    )
                )
            if plan.expected_lost is not None:
                said.append(
                    f"{evaluation['lost']['mean']:.1f} robots lost a run"
                    + against_plan(
                        plan.expected_lost,
                        evaluation.get("lost_interval"),
                        ".1f",
                        confidence,
                        more_is_better=False,
                    )
                )
            if evaluation.get("recovered") and plan.expected_recovered is not None:
                back = robots_range(plan.expected_recovered)
                said.append(f"{evaluation['recovered']['mean']:.1f} back at sea (plan {back})")
            if evaluation.get("suggested_count"):
                said.append(f"suggested size {evaluation['suggested_count']}")
            if evaluation.get("runs_needed"):
                said.append(f"about {evaluation['runs_needed']} runs would show it")
            print(f"  {'in simulation'.ljust(width)}  " + "; ".join(said))
        print(f"  {'verdict'.ljust(width)}  {verdict_brief(report.verdict)}")
        print(f"wrote {', '.join(p.name for p in paths.values())} in {out}")
        return 0


# --- swarm simulate: one mission run (swarm/sim) --------------------------------------------------------
def _add_simulate_command(commands) -> None:
    """`swarm simulate MISSION.yaml [--seed N] [--out DIR] [--animate FILE] [--set KEY=VALUE ...]`."""
    sim = commands.add_parser(
        "simulate", help="plan a mission and run it once in the simulator; write the log and a report"
    )
    sim.add_argument("mission", type=_path, metavar="MISSION.yaml")
    sim.add_argument(
        "--seed",
        type=int,
        help="random seed of the run: mines, waves, hazards, sensing (default: the mission's seed); "
        "a study row's seed replays that run",
    )
    sim.add_argument(
        "--plan-seed",
        type=int,
        help="random seed of the plan (default: the mission's seed, as swarm plan and swarm study plan it)",
    )
    sim.add_argument(
        "--out",
        type=_path,
        metavar="DIR",
        help="output folder (default: reports/<mission>-sim-<YYYYmmdd-HHMMSS>/)",
    )
    sim.add_argument(
        "--animate",
        type=_path,
        metavar="FILE.gif|FILE.mp4",
        help="also write an animation (.mp4 needs ffmpeg)",
    )
    _add_set_option(sim)
    sim.add_argument("--workers", type=int, help="planning processes (default: the CPU count)")
    sim.set_defaults(handler=_cmd_simulate)


def _add_set_option(parser: argparse.ArgumentParser) -> None:
    """The one `--set KEY=VALUE` of every command that reads a mission (plan, simulate, study)."""
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a mission key by its dotted path, e.g. --set swarm.count=20 or "
        "--set hazards.enabled=false (repeatable)",
    )


def _overrides(pairs: Sequence[str]) -> dict[str, object]:
    """--set KEY=VALUE pairs; values are read as YAML scalars (20, 1.5, true, [1, 2], text)."""
    from swarm.files import parse_yaml

    out: dict[str, object] = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        if not sep or not key.strip():
            raise InputError(
                "command line", "--set", pair, "KEY=VALUE with a dotted key, e.g. swarm.count=20"
            )
        out[key.strip()] = parse_yaml(text, f"--set {key.strip()}")
    return out


def _cmd_simulate(args: argparse.Namespace) -> int:
    import time

    from swarm.mission import load_mission
    from swarm.mission.plan import plan_mission, write_plan
    from swarm.report.document import today
    from swarm.report.sim_report import criteria_rows, end_state_rows, loss_rows, verdict, write_sim_report
    from swarm.sim.memory import check_fits
    from swarm.sim.render import Animator, check_animation_path
    from swarm.sim.run import simulate, write_log

    _check_seed("--seed", args.seed)
    _check_seed("--plan-seed", args.plan_seed)
    if args.workers is not None and args.workers < 1:
        raise InputError("command line", "--workers", args.workers, "at least 1")
    if args.animate is not None:
        check_animation_path(args.animate, will_create=args.out)
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        raise InputError("command line", "--out", str(args.out), "a folder (this is a file)")
    overrides = _overrides(args.overrides)
    if not args.mission.is_file():
        raise InputError("command line", "MISSION.yaml", str(args.mission), "an existing mission YAML file")
    mission = load_mission(args.mission, overrides, overrides_source="--set")
    check_fits(mission)  # before planning, which needs most of it
    out = args.out or Path("reports") / f"{mission.name}-sim-{time.strftime('%Y%m%d-%H%M%S')}"
    if out.exists() and not out.is_dir():
        raise InputError("command line", "--out", str(out), "a folder (this is a file)")
    with _output_folder(out, args, "simulation"):
        seed = mission.seed if args.seed is None else args.seed

        with _bar(desc="planning routes", unit="route", leave=False) as bar:

            def plan_progress(done: int, total: int) -> None:
                bar.total = total
                bar.n = done
                bar.refresh()

            plan_seed = mission.seed if args.plan_seed is None else args.plan_seed
            plan = plan_mission(mission, seed=plan_seed, progress=plan_progress, workers=args.workers)

        with _bar(desc="simulating", unit="s", leave=False) as bar:

            def sim_progress(t_s: float, limit_s: float) -> None:
                if bar.total is None:
                    bar.total = round(limit_s)
                bar.update(round(t_s) - bar.n)

            if args.animate is None:
                log = simulate(mission, seed, plan=plan, progress=sim_progress)
            else:
                args.animate.parent.mkdir(parents=True, exist_ok=True)  # may be the output folder
                with Animator(args.animate) as anim:
                    log = simulate(mission, seed, plan=plan, progress=sim_progress, on_step=anim.on_step)

        paths = {**write_plan(plan, out), **write_log(log, out), **write_sim_report(log, out, date=today())}
        s = log.summary()
        print(
            f"simulated {log.mission} on {log.map}, seed {log.seed}: {s['robots']} robots, "
            f"{s['duration_s']:.0f} s of mission time"
        )
        print()
        print(_table([r[:1] + r[2:] for r in criteria_rows(log.outcome)]))
        print()
        if log.losses:
            print(_table(loss_rows(log)))
        else:
            print("no robots lost")
        print()
        print(_table(end_state_rows(log)))
        if s["mines"] or s["false_alarms"]:
            print(
                f"mines: {s['mines_detected']} of {s['mines']} detected, {s['mines_cleared']} cleared, "
                f"{s['false_alarms']} false alarms"
            )
        print()
        print(verdict(log.outcome))
        print(f"wrote {', '.join(sorted(p.name for p in paths.values()))} in {out}")
        if args.animate is not None:
            print(f"animation: {args.animate} ({anim.frames} frames at {anim.fps:g} fps)")
        return 0


def _xy_arg(option: str, value: str | None) -> tuple[float, float] | None:
    import math

    if value is None:
        return None
    parts = value.split(",")
    try:
        x, y = (float(p) for p in parts)
    except ValueError:
        raise InputError("command line", option, value, "X,Y in metres, e.g. 12.5,40") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise InputError("command line", option, value, "finite X,Y in metres")
    return x, y


def _cmd_path(args: argparse.Namespace) -> int:
    from importlib.resources import files

    from swarm.planning.costmap import build_costmap
    from swarm.planning.profiles import DEFAULT_PROFILE, load_profile
    from swarm.robot.params import load_robot
    from swarm.robot.terrain import load_library
    from swarm.world.io import load_map

    start, goal = _xy_arg("--from", args.start), _xy_arg("--to", args.goal)
    if args.benchmark is None:
        benchmark_only = (("--out", args.out), ("--runs", args.runs), ("--time", args.time))
        for option, value in (*benchmark_only, ("--objective", args.objective)):
            if value is not None:
                raise InputError("command line", option, str(value), "--benchmark P1.yaml,P2.yaml with it")
        if start is None or goal is None:
            missing = "--from" if start is None else "--to"
            raise InputError("command line", missing, "nothing", "--from X,Y --to X,Y (world metres)")
    else:
        if args.profile is not None:
            raise InputError(
                "command line", "--profile", str(args.profile), "the profiles in --benchmark only"
            )
        if args.out is None:
            raise InputError(
                "command line", "-o/--out", "nothing", "the benchmark log to write, e.g. -o bench.log"
            )
        _check_output(args.out, "--out", (".log",))
        if (start is None) != (goal is None):
            raise InputError(
                "command line", "--from/--to", "one of them", "both, or neither (a default query)"
            )
        args.runs = BENCHMARK_RUNS if args.runs is None else args.runs
        if args.runs < 1:
            raise InputError("command line", "--runs", args.runs, "a positive number of runs")
        if args.time is not None and not args.time > 0:
            raise InputError("command line", "--time", args.time, "a positive number of seconds")
        benchmark_profiles = [load_profile(p.strip()) for p in args.benchmark.split(",") if p.strip()]
        if not benchmark_profiles:
            raise InputError("command line", "--benchmark", args.benchmark, "P1.yaml,P2.yaml")

    profile = load_profile(args.profile) if args.profile is not None else DEFAULT_PROFILE
    library = load_library(args.terrain)
    robot = load_robot(args.robot or Path(str(files("swarm") / "data" / "robots" / "skid4.yaml")))
    beach_map = load_map(args.map, library)
    cm = build_costmap(beach_map, robot, library)

    if args.benchmark is not None:
        return _path_benchmark(args, cm, benchmark_profiles, start, goal)

    from swarm.planning.paths import plan_path

    result = plan_path(cm, start, goal, profile, seed=args.seed)
    if args.json:
        out = {"map": str(args.map), "from": list(start), "to": list(goal), "seed": args.seed}
        out.update(result.as_dict())
        out["robot_half_width_m"] = cm.half_width_m
        out["cost_reference"] = {"mode": cm.speeds.reference_mode, "speed_mps": cm.speeds.reference_speed_mps}
        _print_json(out)
        return 0
    print(
        f"path: {result.length_m:.1f} m in {len(result.waypoints_m)} waypoints, cost {result.cost:.1f} "
        f"(1.0 a metre on {cm.speeds.reference_mode}), about {result.time_s:.0f} s of driving"
    )
    print(
        f"planner: profile '{result.profile}' ({result.planner}, objective {result.objective}, seed "
        f"{args.seed}): solved in {result.solve_ms:.1f} ms, simplified in {result.simplify_ms:.1f} ms"
    )
    xy = result.waypoints_m
    print(
        f"from ({xy[0, 0]:.2f}, {xy[0, 1]:.2f}) to ({xy[-1, 0]:.2f}, {xy[-1, 1]:.2f}); "
        "--json lists every waypoint"
    )
    return 0


def _path_benchmark(args: argparse.Namespace, cm, profiles, start, goal) -> int:
    from swarm.planning.benchmark import export_benchmark

    export = export_benchmark(
        cm,
        profiles,
        args.out,
        start=start,
        goal=goal,
        runs=args.runs,
        time_s=args.time,
        objective=args.objective,
        seed=args.seed,
    )
    if args.json:
        _print_json(export.as_dict())
        return 0
    s, g = export.start, export.goal
    print(
        f"OMPL benchmark: ({s[0]:.2f}, {s[1]:.2f}) -> ({g[0]:.2f}, {g[1]:.2f}), "
        f"objective {export.objective}, {export.runs} runs x {export.time_s:g} s per planner"
    )
    rows = [["planner", "solved", "mean time s", "mean length m", "mean best cost"]]
    for p in export.planners:
        rows.append(
            [
                p.name,
                f"{p.solved}/{p.runs}",
                f"{p.mean_time_s:.3f}",
                "-" if p.mean_length_m is None else f"{p.mean_length_m:.1f}",
                "-" if p.mean_cost is None else f"{p.mean_cost:.1f}",
            ]
        )
    print(_table(rows))
    print(f"wrote {export.path}: ompl_benchmark_statistics.py {export.path} -d bench.db (then Planner Arena)")
    return 0


# --- swarm study: Monte Carlo over seeds and parameter grids (swarm/studies) ----------------------------
def _add_study_command(commands) -> None:
    """`swarm study MISSION.yaml --runs N [--sweep KEY=VALUES ...] [--set KEY=VALUE ...] [--seed S]
    [--workers K] [--backend local|ray] [--address ADDR] [--batch B] [--out DIR]`."""
    st = commands.add_parser(
        "study", help="run a mission many times over seeds and a parameter grid; success with intervals"
    )
    st.add_argument("mission", type=_path, metavar="MISSION.yaml")
    st.add_argument("--runs", type=int, required=True, help="runs per parameter point")
    st.add_argument(
        "--sweep",
        action="append",
        default=[],
        metavar="KEY=VALUES",
        help="a mission key and its values: swarm.count=10:60:10 (start:stop:step) or "
        "hazards.surf.wave_height_m=0.5,1,2 (repeatable: the study is their product)",
    )
    _add_set_option(st)
    st.add_argument("--seed", type=int, default=0, help="study seed: run seeds come from it (default 0)")
    st.add_argument(
        "--workers", type=int, help="processes (local) or CPUs of a local Ray (default: all cores)"
    )
    st.add_argument("--backend", choices=("local", "ray"), default="local", help="where runs execute")
    st.add_argument("--address", help="Ray cluster address (e.g. auto, ray://host:10001); --backend ray")
    st.add_argument(
        "--batch",
        type=int,
        metavar="B",
        help="runs of a point each worker steps together on the batched simulator (default: "
        "automatic, up to 64; 1: one at a time); the table is the same whatever B",
    )
    st.add_argument("--target", type=float, default=0.95, help="success probability to reach (default 0.95)")
    st.add_argument(
        "--confidence", type=float, default=0.95, help="confidence of the intervals (default 0.95)"
    )
    st.add_argument(
        "--out",
        type=_path,
        metavar="DIR",
        help="study folder (default: reports/<mission>-study/); run again with the same arguments to resume",
    )
    st.set_defaults(handler=_cmd_study)


def _cmd_study(args: argparse.Namespace) -> int:

    from swarm.report.study_report import (
        answer,
        cause_rows,
        causes_note,
        points_note,
        study_rows,
        write_study_report,
    )
    from swarm.studies.backends import default_workers
    from swarm.studies.study import StudySpec, run_study
    from swarm.studies.sweep import Sweep, check_points, check_study_size, parse_sweeps

    if args.runs < 1:
        raise InputError("command line", "--runs", args.runs, "at least 1 run per point")
    _check_seed("--seed", args.seed)
    if args.workers is not None and args.workers < 1:
        raise InputError("command line", "--workers", args.workers, "at least 1")
    if args.batch is not None and args.batch < 1:
        raise InputError("command line", "--batch", args.batch, "at least 1 run per batch")
    if args.address is not None and args.backend != "ray":
        raise InputError("command line", "--address", args.address, "--backend ray with it")
    for option, value in (("--target", args.target), ("--confidence", args.confidence)):
        if not 0.0 < value < 1.0:
            raise InputError("command line", option, value, "a probability strictly between 0 and 1")
    if not args.mission.is_file():
        raise InputError("command line", "MISSION.yaml", str(args.mission), "an existing mission YAML file")
    sweeps = parse_sweeps(args.sweep)
    swept = {s.key for s in sweeps}
    fixed = _overrides(args.overrides)
    if fixed:  # the --set keys first, with the same errors as plan and simulate
        from swarm.mission.load import load_mission

        load_mission(args.mission, fixed, overrides_source="--set")
    both = sorted(swept & set(fixed))
    if both:
        raise InputError("command line", "--set", both[0], "a key given once: by --set or by --sweep")
    sweeps = sweeps + [Sweep(k, (v,)) for k, v in fixed.items()]  # a --set is a sweep of one value
    check_study_size("--runs", args.runs, sweeps)
    out = args.out or Path("reports") / f"{args.mission.stem}-study"
    if out.exists() and not out.is_dir():
        raise InputError("command line", "--out", str(out), "a folder (this is a file)")
    with _output_folder(out, args, "study"):
        spec = StudySpec(str(args.mission), args.runs, sweeps, args.seed, args.target, args.confidence)
        # every point valid, and fitting in memory, before anything starts
        local = args.backend == "local"  # Ray's workers have their own machines' memory
        check_points(spec.mission_path, sweeps, at_once=(args.workers or default_workers()) if local else 1)

        with _bar(desc="study", unit="run", dynamic_ncols=True) as bar:

            def progress(done: float, total: int) -> None:
                if bar.total is None:  # the runs found from before: not in the rate
                    bar.initial = bar.n = int(done)
                _count_runs(bar, done, total)

            table, summary = run_study(
                spec,
                out,
                backend=args.backend,
                workers=args.workers,
                address=args.address,
                progress=progress,
                batch=args.batch,
            )
        from swarm.mission.load import load_mission

        beach = load_mission(args.mission).beach_map
        paths = write_study_report(out, table, summary, beach)
        print(answer(summary))
        print()
        print(_table(study_rows(summary)))
        print(points_note(summary))
        causes = cause_rows(summary)
        if causes:
            print()
            print(_table(causes))
            print(causes_note(summary))
        elif summary["losses_by_cause"]:
            print()
            print("losses: " + ", ".join(f"{c} {n}" for c, n in summary["losses_by_cause"].items()))
        names = ["results.parquet", "summary.json", *(p.name for p in paths.values())]
        print(f"wrote {', '.join(names)} in {out}")
        return 0


# --- swarm report: a report from a plan, a simulation log, a study or a validation (swarm/report) -----------
def _add_report_command(commands) -> None:
    """`swarm report PATH [--format html|md|json] [-o FILE]`."""
    rep = commands.add_parser(
        "report",
        help="write the report of a plan, simulation log, study or model validation folder",
    )
    rep.add_argument(
        "path",
        type=_path,
        metavar="PATH",
        help="a folder written by swarm plan, simulate, study or model validate --out (or a file in it)",
    )
    rep.add_argument(
        "--format",
        dest="fmt",
        metavar="html|md|json",
        help="report format (default: by the -o suffix, else html)",
    )
    rep.add_argument(
        "-o",
        "--out",
        metavar="FILE",
        help="file to write (default: PATH/report.html, .md or .json); - writes to stdout",
    )
    rep.set_defaults(handler=_cmd_report)


def _cmd_report(args: argparse.Namespace) -> int:
    import os

    from swarm.report.document import FORMATS, format_for, today
    from swarm.report.load import detect, report_for

    fmt = args.fmt
    if fmt is not None and fmt not in FORMATS:
        raise InputError("command line", "--format", fmt, f"one of {', '.join(FORMATS)}")
    to_stdout = args.out == "-"
    out = None if args.out is None or to_stdout else Path(args.out)
    if out is not None:
        if out.is_dir():
            raise InputError("command line", "-o", str(out), "a file name (this is a folder)")
        by_suffix = format_for(out)
        if by_suffix is None:
            raise InputError(
                "command line", "-o", str(out), "a file name ending in .html, .htm, .md, .markdown or .json"
            )
        if fmt is None:
            fmt = by_suffix
        elif by_suffix != fmt:
            raise InputError(
                "command line", "-o", str(out), f"a file name for --format {fmt} (a {FORMATS[fmt]} file)"
            )
        parent = out.parent if str(out.parent) else Path(".")
        if not parent.is_dir():
            raise InputError(
                "command line", "-o", str(out), f"a file in an existing folder ({parent} is not one)"
            )
        if not os.access(parent, os.W_OK) or (out.exists() and not os.access(out, os.W_OK)):
            raise InputError("command line", "-o", str(out), "a file this user may write")
    fmt = fmt or "html"
    _, folder = detect(args.path)
    if out is None and not to_stdout:
        out = folder / f"report{FORMATS[fmt]}"
        if not os.access(folder, os.W_OK):
            raise InputError(
                "command line", "PATH", str(folder), "a folder this user may write the report in (or -o)"
            )
    into_folder = out is not None and out.resolve().parent == folder.resolve()
    if into_folder and out.exists() and fmt == "json" and out.name != "report.json":
        # the folder's other JSON files (plan.json, outcome.json, summary.json) are the report's inputs
        raise InputError(
            "command line", "-o", str(out), f"a new file or report.json, not the folder's {out.name}"
        )
    with _output_folder(folder, args) if into_folder else contextlib.nullcontext():
        report = report_for(args.path, date=today())
        if to_stdout:
            sys.stdout.write(report.render(fmt))
            return 0
        try:
            report.write(out, fmt)
        except OSError as exc:
            raise InputError("command line", "-o", str(out), f"a writable file ({exc.strerror})") from None
    print(out)
    return 0


def _cmd_schema(_args: argparse.Namespace) -> int:
    from swarm.mission.schema import mission_json_schema

    print(json.dumps(mission_json_schema(), indent=2))
    return 0


#: Options whose value is a point "X,Y": a negative X ("-1,40") would read as an option.
POINT_OPTIONS = ("--from", "--to")


def _points_joined(argv: Sequence[str]) -> list[str]:
    """`--from -1,40` as `--from=-1,40`: argparse takes a value starting with '-' that is not a
    plain negative number for an option, and says "expected one argument"."""
    out: list[str] = []
    it = iter(argv)
    for token in it:
        if token in POINT_OPTIONS:
            value = next(it, None)
            if value is not None and value.startswith("-") and value[1:2] in tuple(".0123456789"):
                out.append(f"{token}={value}")
                continue
            out.append(token)
            if value is not None:
                out.append(value)
            continue
        out.append(token)
    return out


class Terminated(KeyboardInterrupt):
    """SIGTERM (`kill`, `timeout`, a batch scheduler's stop), raised in the main thread so it
    unwinds as Ctrl-C does: worker pools shut down, no worker left running."""


def _terminated(signum: int, frame: object) -> NoReturn:
    raise Terminated


@contextlib.contextmanager
def _sigterm_unwinds() -> Iterator[None]:
    """SIGTERM raises `Terminated` while a command runs (the main thread only; the handler before
    is put back). Its default ends this process alone: a study's or an evaluation's workers, in
    a pool under a forkserver, went on at full load with nobody to read their rows."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGTERM, _terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


def _stop_workers() -> None:
    """End the worker processes this process started (pools' workers, under the forkserver too):
    a pool shut down without waiting leaves them on their current task; Ctrl-C reaches them
    through the terminal's process group, SIGTERM does not."""
    for child in multiprocessing.active_children():
        child.terminate()
    for child in multiprocessing.active_children():
        child.join(timeout=5)


def main(argv: Sequence[str] | None = None) -> int:
    given = list(sys.argv[1:] if argv is None else argv)
    args = _parser().parse_args(_points_joined(given))
    args.command_line = " ".join(["swarm", *given])
    try:
        with _sigterm_unwinds():
            return args.handler(args)
    except SwarmError as exc:
        print(f"swarm: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        _stop_workers()
        print(f"swarm: {'terminated' if isinstance(exc, Terminated) else 'interrupted'}", file=sys.stderr)
        return 143 if isinstance(exc, Terminated) else 130
    except BrokenPipeError:  # `swarm ... | head`: the reader has gone, nothing to say to it
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # Python's own recipe
        return 1


if __name__ == "__main__":
    sys.exit(main())
