"""``massprops spin FILE --omega WX WY WZ --duration T``: the rotational equations of motion."""

from __future__ import annotations

import click

from ..dynamics.integrators import DEFAULT_METHOD, METHODS, SPLITTING
from ..dynamics.output import (csv_text, drift, plot_trajectory, plot_work_precision, samples, summary,
                               work_precision_table, write_csv)
from . import options


@click.command(cls=options.Command)
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--omega", type=options.Point(), required=True, metavar="WX,WY,WZ",
              help="Initial angular velocity ω' in local (body) axes [rad/s] (WX,WY,WZ or WX WY WZ).")
@click.option("--duration", type=options.POSITIVE, required=True, metavar="SECONDS",
              help="Simulated time [s].")
@click.option("--torque", type=options.Point(), default=None, metavar="TX,TY,TZ",
              help="Constant torque [mass·length²/s²] (TX,TY,TZ or TX TY TZ); torque-free without it.")
@click.option("--torque-frame", type=click.Choice(["body", "world"]), default="body", show_default=True,
              help="Axes the torque is fixed in.")
@click.option("--method", type=click.Choice(list(METHODS)), default=DEFAULT_METHOD, show_default=True,
              help="split2/4/6: geometric splitting (exact rotations, |H| kept to rounding); others: scipy.")
@click.option("--rtol", type=options.POSITIVE, default=None,
              help="Target relative error (default 1e-9).")
@click.option("--steps", type=click.IntRange(min=1), default=None, metavar="N",
              help="Fixed step count (splitting methods; instead of --rtol).")
@click.option("--samples", type=click.IntRange(min=2), default=1001, show_default=True, metavar="N",
              help="Rows of the time series.")
@click.option("--out", "out_csv", type=click.Path(dir_okay=False), metavar="FILE.csv",
              help="Write the time series as CSV.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False), metavar="FILE.png",
              help="Write a PNG (the time series, or the work–precision plot with --compare-methods).")
@click.option("--compare-methods", is_flag=True,
              help="Run every method at several tolerances against the closed form: table and log-log plot.")
@options.material_options
@options.pose_options
@options.repair_option
@options.format_option("text", "json", "jsonl", "csv")
def spin(file, omega, duration, torque, torque_frame, method, rtol, steps, samples, out_csv, plot_path,
         compare_methods, density, total_mass, unit, rotate, translate, repair, output_format):
    """Integrate Euler's equations J' ω̇' = T' − ω' × J' ω' for the solid in FILE.

    Uses FILE's inertia about its center of mass (density, unit and pose as in
    `props`; the pose's rotation is the initial attitude).  Prints energy and
    momentum drift and, torque-free, the error against the closed-form
    (Jacobi elliptic) solution.  --format json prints one object (the
    principal moments, density, drift figures and the time series), jsonl the
    time series one sample a line, csv the time series (the columns of --out);
    with --compare-methods, the table's rows.  In json, jsonl and csv the line
    naming the moments and density goes to stderr.  Exit 1 on a bad file or
    option.
    """
    options.refuse_conflicts()
    from .. import dynamics
    from ..api import mass_properties
    from ..dynamics.closed_form import torque_free

    if steps is not None and method not in SPLITTING:
        raise click.BadParameter(f"--steps applies to split2/split4/split6, not {method}; give --rtol",
                                 param_hint="--steps")
    pose = options.pose_from_options(rotate, translate)
    result = options.guarded(mass_properties, file, density=density, mass=total_mass, unit=unit, pose=pose,
                             repair=repair, path=file)
    if result is None:
        options.exit_with(True)
    properties = result.properties
    attitude = pose.rotation
    moments = properties.principal.moments
    click.echo(f"{file}: principal moments {moments[0]:.9g} {moments[1]:.9g} {moments[2]:.9g}"
               f"{' (SI)' if unit else ''}; density {properties.density:.6g}{' kg/m³' if properties.unit else ''}",
               err=output_format != "text")
    options.warn_units(density, unit, [properties.unit])
    head = {"file": file, "density": properties.density, "unit": properties.unit,
            "principal_moments": moments, "omega": list(omega), "duration": duration}
    if compare_methods:
        rows = options.guarded(dynamics.work_precision, properties.inertia_com, omega, duration,
                               attitude=attitude, samples=min(samples, 201), path=file)
        if rows is None:
            options.exit_with(True)
        _emit_rows(rows, head, output_format)
        if plot_path and options.guarded(plot_work_precision, plot_path, rows,
                                         f"{file}: work–precision over {duration:g} s") is None:
            options.exit_with(True)
        options.exit_with(False)
    trajectory = options.guarded(dynamics.simulate, properties.inertia_com, omega, duration, attitude=attitude,
                                 torque=torque, torque_frame=torque_frame, method=method,
                                 rtol=1e-9 if rtol is None else rtol, steps=steps, samples=samples, path=file)
    if trajectory is None:
        options.exit_with(True)
    exact = None if torque is not None else torque_free(properties.inertia_com, omega, trajectory.t,
                                                        attitude=attitude)
    _emit_trajectory(trajectory, head, output_format, torque, torque_frame, exact)
    failed = False
    if out_csv:
        failed |= options.guarded(write_csv, out_csv, trajectory, path=out_csv) is None
    if plot_path:
        failed |= options.guarded(plot_trajectory, plot_path, trajectory,
                                  f"{file}: {trajectory.method}, ω'0 = {tuple(omega)} rad/s", si=bool(unit)) is None
    options.exit_with(failed)


def _emit_rows(rows, head, output_format):
    """The work–precision table in ``output_format``."""
    from dataclasses import asdict

    from .. import report
    dicts = [asdict(r) for r in rows]
    if output_format == "text":
        click.echo(work_precision_table(rows))
    elif output_format == "json":
        options.echo(report.to_json({**head, "work_precision": dicts}))
    elif output_format == "jsonl":
        options.echo(report.to_jsonl(dicts), nl=False)
    else:
        options.echo(report.to_csv(dicts, list(dicts[0]) if dicts else []), nl=False)


def _emit_trajectory(trajectory, head, output_format, torque, torque_frame, exact):
    """The run's summary (text), or it with the time series (json), or the time series (jsonl, csv)."""
    from .. import report
    if output_format == "text":
        for line in summary(trajectory, torque, torque_frame, exact):
            click.echo(line)
    elif output_format == "json":
        run = {"method": trajectory.method, "steps": trajectory.steps, "elapsed_s": trajectory.elapsed_s,
               "torque": None if torque is None else list(torque), "torque_frame": torque_frame}
        options.echo(report.to_json({**head, **run, **drift(trajectory, torque, torque_frame, exact),
                                     "trajectory": samples(trajectory)}))
    elif output_format == "jsonl":
        options.echo(report.to_jsonl(samples(trajectory)), nl=False)
    else:
        options.echo(csv_text(trajectory), nl=False)
