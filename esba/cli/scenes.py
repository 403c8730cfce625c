"""``esba solve``, ``stiffness``, ``pressure`` and ``validate``: one scene's equilibria, its
sensitivities and uncertainty, and its Monte Carlo (in this process or on Dask)."""

from __future__ import annotations

import argparse
import math
import re
import sys
import time
from pathlib import Path

from esba.infra import checks, outputs

from .arguments import (
    UsageError,
    add_scene_flags,
    count_arg,
    float_arg,
    gravity_direction_arg,
    output_file_arg,
    planar_only_flags,
    refuse,
    scene_figure,
    scene_from_args,
)
from .cluster import add_cluster_flags, chunk_arg, on_cluster, study_stopped
from .results import EXIT_FAILED, EXIT_OK, print_result, warn_findings

#: Where ``esba solve`` writes its figure when no scene file is given and no --plot.
DEFAULT_SOLVE_FIGURE = "esba-solve.png"


#: ``--max-iter``'s bound (``esba.statics.equilibrium.MAX_ITER_LIMIT``, written out so that building the
#: parser does not import CasADi; a test checks they agree).
_MAX_ITER = 100_000


def _section_arg(items: list[str] | None) -> dict[str, float]:
    from esba.statics.spatial import SpatialError, check_section

    section: dict[str, str] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep:
            raise UsageError(f"--section {item!r}: expected NAME=VALUE, e.g. EI_side=4e5 (N*mm^2)")
        section[name.strip()] = value.strip()
    try:
        return check_section(section, complete=False)  # the scene's section fills in what is not given
    except SpatialError as exc:
        raise UsageError(f"--section: {exc}") from None


def _solved3d(scene, section: dict[str, float], down) -> tuple:
    """The 3-D equilibrium of ``scene`` (:func:`esba.statics.spatial.solve_scene3d`), its model, its
    parameter values and the JSON that ``esba solve --3d`` and ``esba stiffness --3d`` share."""
    import numpy as np

    from esba.model.spatial import load_model3d
    from esba.statics.spatial import scene_values3d, solve_scene3d

    result = solve_scene3d(scene, section, gravity_direction=down)
    effects, values = scene_values3d(scene, section, down)
    model = load_model3d(scene.segments, effects, scene.variant)
    data = {
        "scene": scene.describe(),
        "model": model.path.name,
        "converged": result.converged,
        "stable": result.stable,
        "ipopt": result.ipopt_status,
        "theta_deg": np.degrees(result.theta).tolist(),
        "psi_deg": np.degrees(result.psi).tolist(),
        "tau_deg": np.degrees(result.tau).tolist(),
        "tip_mm": result.tip.tolist(),
        "min_eigenvalue": result.min_eigenvalue,
        "section_nmm2": {name: values[name] for name in ("EI_side", "GJ")},
        "section_from": "given" if len(section) == 2 else ("the eccentric section (esba section)" if not section else "given in part, the rest from the eccentric section (esba section)"),
        "notes": result.notes,
    }
    return result, model, values, data


def _cmd_solve3d(args: argparse.Namespace, scene) -> int:
    """``esba solve --3d``: the spatial model (docs/3d.md), its sensitivities and uncertainty (first
    order and Monte Carlo, in this process or on Dask, streamed to a resumable sample file)."""
    import numpy as np

    from esba.statics.spatial import SpatialError, check_section

    refuse(args, ["history"], "with --3d (the 3-D solve has none yet)")
    section = _section_arg(args.section)
    if scene.obstacles:
        refuse(args, ["monte_carlo", "sigma", "sensitivities"], "with obstacles in 3-D (contact has no uncertainty yet)")
    try:
        full_section = check_section(section, scene)
    except SpatialError as exc:
        raise UsageError(f"--section: {exc}") from None
    sigmas, mc_options, chunked = _uncertainty_args(args, scene, full_section)
    down = gravity_direction_arg(args, scene)
    if args.no_plot and args.plot is not None:
        raise UsageError("--plot and --no-plot: give one of the two")
    figure = outputs.figure_file(args.plot, "--plot", "esba-solve3d.png") if args.plot is not None else None  # checked first
    page = outputs.check_file(args.html, "--html", (".html",)) if args.html is not None else None
    if scene.obstacles:  # contact in 3-D (esba/cli/contact3d.py)
        if page is not None:
            raise UsageError("--html: not for a scene with obstacles yet; --plot FILE draws it")
        from .contact3d import cmd_solve_contact3d

        return cmd_solve_contact3d(args, scene, section, down, figure)
    result, model, values, data = _solved3d(scene, section, down)
    if result.stable:
        from esba.analysis.stiffness3d import tip_stiffness3d

        tip = tip_stiffness3d(model, values, result).to_dict()
        data.update({key: tip[key] for key in ("tip_compliance", "tip_stiffness")}, tip_matrices={key: tip[key] for key in ("order", "units")})
    if args.sensitivities:
        from esba.analysis.sensitivity3d import sensitivities3d

        data["sensitivities"] = sensitivities3d(scene, full_section, result, gravity_direction=down).to_dict()
    if sigmas:
        from esba.calibration.sigmas import outside_domain
        from esba.calibration.uncertainty import compare
        from esba.calibration.uncertainty3d import monte_carlo3d, propagate3d

        propagation = propagate3d(scene, full_section, result, sigmas, gravity_direction=down)
        data["uncertainty"] = propagation.to_dict()
        data["uncertainty"]["outside_domain"] = outside_domain(scene, sigmas, three_d=True)
        if mc_options is not None:
            if chunked:
                code = _chunked_or_exit(args, scene, sigmas, mc_options, full_section, down)
                if isinstance(code, int):
                    return code
                mc, info = code
            else:
                mc, info = monte_carlo3d(scene, sigmas, mc_options, section=full_section, gravity_direction=down), None
            data["monte_carlo"] = mc.to_dict()
            if info is not None:
                data["monte_carlo"]["study"] = info
            data["agreement"] = compare(propagation, mc).to_dict()

    def table(d: dict) -> str:
        rows = [f"{'scene':>10}: {d['scene']}", f"{'model':>10}: {d['model']}",
                f"{'section':>10}: EI_side {d['section_nmm2']['EI_side']:.6g} N mm^2, GJ {d['section_nmm2']['GJ']:.6g} N mm^2 ({d['section_from']})"]
        for key in ("theta_deg", "psi_deg", "tau_deg", "tip_mm"):
            rows.append(f"{key:>10}: " + "  ".join(f"{v:.4f}" for v in d[key]))
        rows.append(f"{'state':>10}: {'stable' if d['stable'] else 'UNSTABLE (the softest mode: ' + format(d['min_eigenvalue'], '.3g') + ')'}; IPOPT {d['ipopt']}")
        rows += [f"{'note':>10}: {n}" for n in d["notes"]]
        if "sensitivities" in d:
            from esba.analysis.sensitivity3d import OUTPUTS3D

            sens = d["sensitivities"]
            rows.append(f"{'d/dp':>10}: {sens['status']}" + (f": {sens['message']}" if sens["message"] else "") + " (per unit of each parameter)")
            for name, r in sens["parameters"].items() if sens["status"] == "ok" else ():
                rows.append(f"{name:>10}: " + ", ".join(f"{o} {r[f'd{o}_{u}_per_unit']:.4g} {u}" for o, u in OUTPUTS3D) + f" per {r['unit']}")
        if "uncertainty" in d:
            from esba.calibration.uncertainty3d import uncertainty3d_rows

            rows += [f"{k:>10}: {v}" for k, v in uncertainty3d_rows(d)]
        return "\n".join(rows)

    forces = []
    for p in scene.payloads:
        om, be = math.radians(p.angle_deg), math.radians(p.out_of_plane_deg)
        forces.append((p.force * np.array([math.cos(be) * math.cos(om), -math.cos(be) * math.sin(om), math.sin(be)]), p.at))
    if figure is not None:
        from esba.figures.scenes import save_figure
        from esba.figures.spatial import tube_figure

        written = save_figure(tube_figure(scene.segments, result.q, values, forces, scene.describe()), figure)
        print(f"esba: wrote {written}", file=sys.stderr)
    if page is not None:
        from esba.figures.spatial import tube_html

        page.parent.mkdir(parents=True, exist_ok=True)
        outputs.write_text(page, tube_html(scene.segments, result.q, values, forces, scene.describe()))
        print(f"esba: wrote {page}", file=sys.stderr)
    print_result(args, data, table)
    for line in data.get("uncertainty", {}).get("outside_domain", ()):
        print(f"esba: warning: {line}", file=sys.stderr)
    if "agreement" in data and data["monte_carlo"]["counts"]["ok"] < 2:
        print(f"esba: warning: {data['agreement']['verdict']}", file=sys.stderr)
    return EXIT_OK if result.ok else EXIT_FAILED


def _uncertainty_args(args: argparse.Namespace, scene, section: dict | None = None) -> tuple:
    """The sigmas (3-D ones with ``section``), the Monte Carlo's options (None without
    --monte-carlo) and whether it runs in chunks (--workers, --scheduler, --mc-out, --resume):
    every flag checked before anything is solved."""
    sigmas = _sigmas_for(args, scene, section)  # bad sigmas are usage errors, before any solve
    if args.monte_carlo is not None and not sigmas:
        raise UsageError("--monte-carlo needs uncertain parameters: --sigma NAME=SIGMA or an [uncertainty] table in the scene file")
    chunked = on_cluster(args) or args.mc_out is not None or args.resume
    if chunked and args.monte_carlo is None:
        raise UsageError("--workers, --scheduler, --mc-out and --resume run the Monte Carlo: give --monte-carlo N (and --sigma)")
    if args.resume and args.mc_out is None:
        raise UsageError("--resume continues the Monte Carlo in its sample file: give --mc-out FILE.csv")
    if args.monte_carlo is None:
        refuse(args, ["mc_chunk", "seed"], "without --monte-carlo N (they set its samples)")
    mc_options = None
    if args.monte_carlo is not None:
        from esba.calibration.uncertainty import (
            MonteCarloOptions,
            UncertaintyError,
            check_samples,
            check_samples3d,
        )

        try:
            if section is not None:
                check_samples3d(args.monte_carlo)
            extra = {} if args.mc_chunk is None else {"chunk": args.mc_chunk}
            mc_options = MonteCarloOptions(samples=args.monte_carlo, seed=0 if args.seed is None else args.seed, **extra)
            check_samples(args.monte_carlo, scene.segments * (1 if section is None else 3), len(sigmas))  # before the nominal solve
        except UncertaintyError as exc:
            raise UsageError(f"--monte-carlo: {exc}") from None
    return sigmas, mc_options, chunked


def _chunked_or_exit(args: argparse.Namespace, scene, sigmas, options, section: dict | None = None, down=(1.0, 0.0, 0.0)):
    """The chunked Monte Carlo (:func:`_monte_carlo_in_chunks`) as ``(mc, info)``, or the exit code
    of an interruption (130) or of a study stopped at run time (1)."""
    from esba.studies.chunks import StudyStopped

    try:
        return _monte_carlo_in_chunks(args, scene, sigmas, options, section, down)
    except KeyboardInterrupt:
        where = f": the samples solved so far are in {args.mc_out}; rerun with --resume to go on" if args.mc_out else ""
        print(f"esba: interrupted{where}", file=sys.stderr)
        return 130
    except StudyStopped as exc:  # the scheduler lost, a chunk's workers dying, a full disk: exit 1
        return study_stopped(exc, args.mc_out, "samples")


def _cmd_solve(args: argparse.Namespace) -> int:
    from esba.statics.equilibrium import EquilibriumError, SolverOptions, SolverOptionsError, solve
    from esba.statics.text import solve_table

    scene = scene_from_args(args)
    if args.three_d or scene.needs_3d:
        return _cmd_solve3d(args, scene)
    for flag, given in (("--section", args.section), ("--html", args.html), ("--gravity-direction", args.gravity_direction)):
        if given:
            raise UsageError(f"{flag} is for the 3-D model: give --3d (or a payload out of the plane)")
    figure = scene_figure(args, DEFAULT_SOLVE_FIGURE)
    sigmas, mc_options, chunked = _uncertainty_args(args, scene)
    if args.no_continuation and args.history is not None:
        raise UsageError("--history and --no-continuation: a history is a continuation; give one of the two")
    try:
        options = SolverOptions(
            max_iter=args.max_iter,
            continuation=not args.no_continuation,
            history=args.history or "inflate-then-load",
            multistability=args.multistability,
        )
    except SolverOptionsError as exc:
        raise UsageError(f"--history: {exc}") from None
    try:
        result = solve(scene, options)
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = result.to_dict()
    data["scene"] = scene.describe()
    propagation = mc = None
    if args.sensitivities:
        from esba.analysis.sensitivity import sensitivities

        data["sensitivities"] = sensitivities(result).to_dict()
    if sigmas:
        from esba.calibration.sigmas import outside_domain
        from esba.calibration.uncertainty import compare, monte_carlo, propagate

        propagation = propagate(result, sigmas)
        data["uncertainty"] = propagation.to_dict()
        data["uncertainty"]["outside_domain"] = outside_domain(scene, sigmas)
        if mc_options is not None:
            if chunked:
                code = _chunked_or_exit(args, scene, sigmas, mc_options)
                if isinstance(code, int):
                    return code
                mc, info = code
            else:
                mc, info = monte_carlo(scene, sigmas, mc_options), None
            data["monte_carlo"] = mc.to_dict()
            if info is not None:
                data["monte_carlo"]["study"] = info
            data["agreement"] = compare(propagation, mc).to_dict()
    if figure is not None:
        from esba.figures.scenes import save_figure, solve_figure

        unloaded = solve(scene.replace(payloads=tuple(p.scaled(0.0) for p in scene.payloads), gravity=False), SolverOptions(multistability="never"), pressure=result.pressure)
        cov = propagation.cov_tip if propagation is not None and propagation.has_numbers else None
        tips = mc.tip[mc.ok] if mc is not None else None
        data["figure"] = str(save_figure(solve_figure(result, unloaded, tip_cov=cov, samples=tips), figure).resolve())
    print_result(args, data, solve_table)
    warn_findings(result.validity)
    if result.multistable:
        print(f"esba: warning: {result.multistability.message}", file=sys.stderr)
    for line in data.get("uncertainty", {}).get("outside_domain", ()):
        print(f"esba: warning: {line}", file=sys.stderr)
    if mc is not None and mc.counts["ok"] < 2:
        print(f"esba: warning: {data['agreement']['verdict']}", file=sys.stderr)
    if not result.ok:
        print(f"esba: solve not ok: {result.message or result.status}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _monte_carlo_in_chunks(args: argparse.Namespace, scene, sigmas, options, section: dict | None = None, down=(1.0, 0.0, 0.0)):
    """The Monte Carlo (in 3-D with ``section``) on --workers or --scheduler, or streamed to --mc-out (esba.studies.monte_carlo)."""
    from esba.studies.chunks import StudyError
    from esba.studies.distributed import DistributedError, open_runner
    from esba.studies.monte_carlo import monte_carlo, monte_carlo3d, monte_carlo_study

    progress = sys.stderr.isatty()
    space = {} if section is None else {"section": section, "gravity_direction": down}
    try:
        with open_runner(args.workers, args.scheduler, args.connect_timeout) as runner:
            if args.mc_out is None:
                t0 = time.perf_counter()
                mc = (monte_carlo if section is None else monte_carlo3d)(scene, sigmas, options, runner=runner, progress=progress, **space)
                return mc, {"runner": runner.description, "workers": runner.workers, "seconds": time.perf_counter() - t0}
            return monte_carlo_study(scene, sigmas, options, runner=runner, out=args.mc_out, resume=args.resume, progress=progress,
                                     three_d=section is not None, **space)
    except (DistributedError, StudyError) as exc:
        raise UsageError(str(exc)) from None


def _sigmas_for(args: argparse.Namespace, scene, section: dict | None = None) -> tuple:
    """The scene file's [uncertainty] table, then --sigma flags (a flag replaces the file's entry);
    with ``section``, the 3-D scene's parameters (Beta1, EI_side, GJ too)."""
    from esba.calibration.uncertainty import (
        UncertaintyError,
        load_sigmas,
        parse_sigma,
        resolve_sigmas,
    )

    try:
        specs = list(load_sigmas(args.scene)) if args.scene else []
        specs += [parse_sigma(text) for text in args.sigma or ()]
        return resolve_sigmas(scene, specs, section) if specs else ()
    except UncertaintyError as exc:
        raise UsageError(str(exc)) from None


def _sample_count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 10:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number of samples >= 10")
    return value


def _seed(text: str) -> int:
    value = int(text) if re.fullmatch(r"\s*\d+\s*", text) else -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a whole number >= 0")
    return value


def _history_arg(text: str):
    """``--history``: a name, or steps ``P:L,P:L,...`` of pressure and load fractions."""
    text = text.strip()
    if not text:
        raise argparse.ArgumentTypeError("--history '': expected a name (inflate-then-load, load-then-inflate, together) or steps P:L,P:L,...")
    if ":" not in text:
        return text  # a name: SolverOptions says which are allowed
    steps = []
    for part in text.split(","):
        bits = part.split(":")
        if len(bits) != 2:
            raise argparse.ArgumentTypeError(f"--history {text!r}: each step is P:L (pressure and load fractions, 0 to 1), e.g. 0:1,1:1")
        try:
            steps.append((checks.number("--history", bits[0]), checks.number("--history", bits[1])))
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return tuple(steps)


def add_solve(sub) -> None:
    p = sub.add_parser("solve", help="solve a scene's equilibrium (no arguments: the paper's Table 2 case, n = 3)")
    add_scene_flags(p)
    p.add_argument("--plot", metavar="FILE|DIR", help=f"write the deformed and unloaded shapes (default ./{DEFAULT_SOLVE_FIGURE} when no scene file is given; a folder gets {DEFAULT_SOLVE_FIGURE} inside it; no suffix: .png)")
    p.add_argument("--no-plot", action="store_true", help="write no figure")
    p.add_argument("--max-iter", type=count_arg("max_iter", 1, _MAX_ITER, "an equilibrium takes tens of iterations"), default=200, metavar="N", help="IPOPT iterations per solve (default 200, at most 100000)")
    p.add_argument("--no-continuation", action="store_true", help="one solve at the full load, no load ramp")
    p.add_argument("--3d", dest="three_d", action="store_true", help="solve with the 3-D model (chosen by itself when a payload points out of the plane; docs/3d.md)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="3-D section stiffness: EI_side=..., GJ=... (N*mm^2; repeatable)")
    p.add_argument("--gravity-direction", metavar="X,Y,Z", help="with --3d and --gravity: the direction of gravity in the base frame (overrides the scene file's gravity_direction; default 1,0,0: down, the paper's)")
    p.add_argument("--html", metavar="FILE.html", help="with --3d: also write a view of the deformed actuator that turns with the mouse (one offline HTML file)")
    p.add_argument(
        "--history",
        type=_history_arg,
        metavar="HISTORY",
        help="the load history: inflate-then-load (default), load-then-inflate, together, or steps of (pressure, load) "
        "fractions P:L,P:L,... ending at 1:1 (e.g. 0.5:0,0.5:1,1:1); where the scene is multistable it decides the state",
    )
    p.add_argument(
        "--multistability",
        choices=("auto", "always", "never"),
        default="auto",
        help="look for other stable states (auto: when n <= 8, where it costs about a solve)",
    )
    p.add_argument("--sensitivities", action="store_true", help="d(angles, tip)/d(parameter) for every scene parameter (exact, implicit function theorem)")
    p.add_argument("--sigma", action="append", metavar="NAME=SIGMA", help="uncertain parameter: E=0.05 (in its unit), E=10%%, r2=±0.1 (a tolerance); repeatable; propagated to first order")
    p.add_argument("--monte-carlo", type=_sample_count, metavar="N", help="check the first-order uncertainty with N Monte Carlo samples on the batch path (e.g. 10000)")
    p.add_argument("--seed", type=_seed, default=None, help="seed of the Monte Carlo samples (default 0)")
    add_cluster_flags(p, "the Monte Carlo")
    p.add_argument("--mc-chunk", type=chunk_arg, metavar="K", help="Monte Carlo samples per chunk (default 2500)")
    p.add_argument("--mc-out", type=output_file_arg(".csv"), metavar="FILE.csv", help="stream every Monte Carlo sample to FILE.csv, chunk by chunk")
    p.add_argument("--resume", action="store_true", help="continue the Monte Carlo in --mc-out FILE.csv from the samples it holds")
    p.set_defaults(func=_cmd_solve)


def _cmd_stiffness3d(args: argparse.Namespace, scene) -> int:
    """``esba stiffness --3d``: the tip's 6 x 6 stiffness and compliance at the 3-D state the scene's
    loads reach (:mod:`esba.analysis.stiffness3d`)."""
    from esba.analysis.stiffness3d import stiffness3d_table, tip_stiffness3d
    from esba.model.scene import Payload

    if scene.obstacles:
        raise UsageError(f"{args.scene}: a scene with obstacles has no free tip stiffness; esba stiffness --3d is for a free actuator")
    if args.payload is not None:
        if len(args.payload) > 1:
            raise UsageError(f"--payload given {len(args.payload)} times: with --3d it is the one tip payload of the state (N); put several in a scene file")
        scene = scene.replace(payloads=(Payload(args.payload[0], 90.0 if args.payload_angle is None else args.payload_angle),))
    elif args.payload_angle is not None:
        raise UsageError("--payload-angle with --3d turns the tip payload of --payload N: give --payload too (or set angle_deg in the scene file)")
    section = _section_arg(args.section)
    down = gravity_direction_arg(args, scene)
    result, model, values, data = _solved3d(scene, section, down)
    data.update(tip_stiffness3d(model, values, result).to_dict())
    print_result(args, data, stiffness3d_table)
    if not data["stable"] or not result.converged:
        print(f"esba: stiffness not ok: {data['reason'] or 'the 3-D solve did not converge'}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _cmd_stiffness(args: argparse.Namespace) -> int:
    from esba.analysis.stiffness import PAPER_FORCES, secant_stiffness, stiffness_table
    from esba.model.scene import SceneError
    from esba.statics.equilibrium import EquilibriumError

    scene = scene_from_args(args, payloads=False)
    if args.three_d or scene.needs_3d:
        return _cmd_stiffness3d(args, scene)
    planar_only_flags(args, scene, "esba stiffness")
    forces = tuple(args.payload) if args.payload else PAPER_FORCES
    try:
        result = secant_stiffness(scene, forces, angle_deg=90.0 if args.payload_angle is None else args.payload_angle)
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    data = result.to_dict()
    print_result(args, data, stiffness_table)
    warn_findings(data.get("validity", []))
    if not result.ok:
        print("esba: stiffness not ok: a solve failed or was not stable", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_stiffness(sub) -> None:
    p = sub.add_parser("stiffness", help="secant stiffness of the tip (Section 4.4.3) and its tangent matrix; with --3d the tip's 6 x 6 stiffness and compliance")
    add_scene_flags(p, payloads=False)
    p.add_argument("--payload", type=float_arg, action="append", metavar="N",
                   help="tip payload in N (repeatable; default 0.5, 1, 2); with --3d once: the tip payload of the state (replaces the scene's)")
    p.add_argument("--payload-angle", type=float_arg, default=None, metavar="DEG", help="direction Omega of the payload (default 90, horizontal)")
    p.add_argument("--3d", dest="three_d", action="store_true",
                   help="the 3-D model's 6 x 6 tip stiffness and compliance at the state the scene's loads reach (chosen by itself for a scene that needs it; docs/3d.md)")
    p.add_argument("--section", action="append", metavar="NAME=VALUE", help="with --3d: section stiffness EI_side=..., GJ=... (N*mm^2; repeatable; default the eccentric section's)")
    p.add_argument("--gravity-direction", metavar="X,Y,Z", help="with --3d and --gravity: the direction of gravity in the base frame (overrides the scene file's gravity_direction; default 1,0,0: down, the paper's)")
    p.set_defaults(func=_cmd_stiffness)


def _fmt(values, digits: int = 3) -> str:
    return ", ".join(f"{v:.{digits}f}" for v in values)


def _target_sentence(d: dict) -> str:
    """What the pressure was found for, as a sentence."""
    t = d["target"]
    if "target_angle_deg" in t:
        return f"bends the unloaded actuator to {t['target_angle_deg']:g} deg in total (n = {d['segments']}, {d['variant']})"
    if "total_angle_deg" in t:
        return f"bends the loaded actuator to {t['total_angle_deg']:g} deg in total (n = {d['segments']}, {d['variant']})"
    parts = [f"{axis} = {v:g} mm" for axis, v in zip(("x", "y"), t["tip_mm"]) if v is not None]
    return f"puts the loaded actuator's tip at {' and '.join(parts)} (n = {d['segments']}, {d['variant']})"


def _pressure_table(d: dict) -> str:
    rows = [("pressure", f"{d['pressure_mpa']:.7f} MPa"), ("target", f"the pressure that {_target_sentence(d)}"), ("method", d["method"])]
    if "residual" in d:
        rows.append(("residual", f"{d['residual']:.3g}"))
        rows.append(("theta", f"({_fmt(d['equilibrium']['theta_deg'], 2)}) deg"))
        rows.append(("tip x, y", f"{_fmt(d['equilibrium']['tip_mm'])} mm"))
    if d.get("message"):
        rows.append(("note" if d.get("ok", True) else "NOT OK", d["message"]))
    return "\n".join(f"{k:>10}: {v}" for k, v in rows)


def _cmd_pressure(args: argparse.Namespace) -> int:
    from esba.analysis.stiffness import pressure_for_target
    from esba.model.scene import SceneError
    from esba.statics.equilibrium import EquilibriumError, pressure_for_angle

    chosen = [a for a in ("target_angle", "total_angle", "tip_x", "tip_y") if getattr(args, a) is not None]
    if args.target_angle is not None and len(chosen) > 1 or args.total_angle is not None and len(chosen) > 1:
        raise UsageError("give one target: --target-angle, --total-angle, or --tip-x/--tip-y")
    if not chosen:
        raise UsageError("pressure needs a target: --target-angle DEG (unloaded), --total-angle DEG or --tip-x/--tip-y MM (under the payloads)")
    if args.pressure is not None:
        raise UsageError("--pressure is what this command finds: give a target instead")
    if args.target_angle is not None:
        refuse(args, ["payload", "payload_angle", "payload_at", "no_payload", "gravity"], "with --target-angle (the closed form is for the unloaded actuator; use --total-angle for a target under payloads)")
    keep_target, args.target_angle = args.target_angle, None
    scene = scene_from_args(args)
    try:
        if keep_target is not None:
            scene = scene.replace(target_angle_deg=keep_target)
            p = pressure_for_angle(scene)
            data = {
                "ok": True,
                "pressure_mpa": p,
                "method": "closed form (U is linear in P; unloaded, uniform curvature)",
                "target": {"target_angle_deg": keep_target},
                "segments": scene.segments,
                "variant": scene.variant,
            }
        else:
            if not scene.payloads:
                raise UsageError("--total-angle/--tip-x/--tip-y are targets under payloads: add --payload N (or use --target-angle)")
            if args.total_angle is not None:
                r = pressure_for_target(scene, total_angle_deg=args.total_angle)
            else:
                r = pressure_for_target(scene, tip_mm=(args.tip_x, args.tip_y))
            data = r.to_dict()
            data["method"] = "NLP over (theta, P) with dU/dtheta = 0"
            data["segments"] = scene.segments
            data["variant"] = scene.variant
    except SceneError as exc:
        raise UsageError(str(exc)) from None
    except EquilibriumError as exc:
        print(f"esba: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    print_result(args, data, _pressure_table)
    warn_findings(data.get("equilibrium", {}).get("validity", []))
    if not data["ok"]:
        print(f"esba: pressure not found: {data.get('message', '')}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def add_pressure(sub) -> None:
    p = sub.add_parser("pressure", help="the pressure for a target angle (closed form) or a loaded target (NLP)")
    add_scene_flags(p)
    p.add_argument("--total-angle", type=float_arg, metavar="DEG", help="target total angle under the payloads")
    p.add_argument("--tip-x", type=float_arg, metavar="MM", help="target tip x under the payloads")
    p.add_argument("--tip-y", type=float_arg, metavar="MM", help="target tip y under the payloads")
    p.set_defaults(func=_cmd_pressure)


def _cmd_validate(args: argparse.Namespace) -> int:
    from esba.calibration import validation
    from esba.pages.validation import PAGE

    if args.check not in (None, True) and args.out is not None:
        raise UsageError("give the page to check once: --check FILE or --out FILE")
    page = args.check if args.check not in (None, True) else outputs.default_page("validation.md", create=not args.check) if args.out is None else args.out
    if not args.check:
        page = outputs.check_file(page, "--out", (".md",))
    cases = PAGE.compute()
    rows = list(cases.paper)
    if args.check:
        check = PAGE.check(page, data=cases)
        if not check.ok:
            again = "esba validate" if Path(page).resolve() == outputs.default_page("validation.md").resolve() else f"esba validate --out {page}"
            print(f"esba: {page} is {check.status}: run `{again}` and commit it", file=sys.stderr)
            return EXIT_FAILED
    else:
        page = PAGE.write(page, data=cases).path
    data = {"passed": all(r.passed for r in rows), "rows": [r.to_dict() for r in rows]}
    if not args.check:
        data["page"] = str(page)
    print_result(args, data, lambda d: validation.summary(rows) + (f"\nwrote {d['page']}" if "page" in d else f"\n{page} is up to date"))
    return EXIT_OK if data["passed"] else EXIT_FAILED


def add_validate(sub) -> None:
    p = sub.add_parser("validate", help="compare with the paper's Table 2 (n = 1..4); write the validation page")
    p.add_argument("--check", nargs="?", const=True, default=None, metavar="FILE",
                   help="write nothing; exit 1 when the page is stale (FILE, default docs/validation.md in a checkout, else ./validation.md)")
    p.add_argument("--out", default=None, metavar="FILE.md", help="page to write (default docs/validation.md in a checkout, else ./validation.md)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=_cmd_validate)
