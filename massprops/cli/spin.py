"""``massprops spin FILE --omega WX WY WZ --duration T``: the rotational equations of motion."""

from __future__ import annotations

import contextlib

import click
import numpy as np

from ..dynamics import DEFAULT_METHOD, METHODS, SPLITTING
from . import options

CSV_HEADER = "t,wx,wy,wz,qw,qx,qy,qz,Hx,Hy,Hz,K"


def _pyplot():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        from ..errors import MassPropsError
        raise MassPropsError("--plot needs matplotlib, which is not installed",
                             fix="pip install 'massprops[plot]'") from None
    return plt


@contextlib.contextmanager
def _writable(path):
    try:
        yield
    except OSError as exc:
        from ..errors import MassPropsError
        raise MassPropsError(f"cannot write the file ({exc.strerror or exc})", path=path,
                             fix="check that the directory exists and is writable") from None


def write_csv(path, trajectory):
    """The time series: t, ω' (body), quaternion of A (w,x,y,z), H (world), K."""
    table = np.column_stack([trajectory.t, trajectory.omega, trajectory.quat, trajectory.momentum,
                             trajectory.energy])
    with _writable(path):
        np.savetxt(path, table, delimiter=",", header=CSV_HEADER, comments="", fmt="%.17g")
    return path


def plot_trajectory(path, trajectory, title):
    plt = _pyplot()
    figure, panels = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for k, name in enumerate("xyz"):
        panels[0].plot(trajectory.t, trajectory.omega[:, k], label=f"ω'{name}")
        panels[1].plot(trajectory.t, trajectory.momentum[:, k], label=f"H{name}")
    panels[2].plot(trajectory.t, trajectory.energy, label="K")
    for panel, label in zip(panels, ("ω' [rad/s], body axes", "H, world axes", "K")):
        panel.set_ylabel(label)
        panel.legend(loc="upper right", fontsize=8)
        panel.grid(True, alpha=0.3)
    panels[2].set_xlabel("t [s]")
    figure.suptitle(title)
    return _save(plt, figure, path)


def _save(plt, figure, path):
    figure.tight_layout()
    try:
        with _writable(path):
            figure.savefig(path, dpi=110)
    finally:
        plt.close(figure)
    return path


def plot_work_precision(path, rows, title):
    plt = _pyplot()
    figure, panel = plt.subplots(figsize=(7, 5))
    for method in dict.fromkeys(r.method for r in rows):
        mine = [r for r in rows if r.method == method]
        panel.loglog([r.elapsed_s for r in mine], [max(r.omega_error, 1e-17) for r in mine], marker="o",
                     linestyle="-" if method.startswith("split") else "--", label=method)
    panel.set_xlabel("run time [s]")
    panel.set_ylabel("max relative error of ω' against the closed form")
    panel.grid(True, which="major", alpha=0.3)
    panel.legend(fontsize=8)
    panel.set_title(title)
    return _save(plt, figure, path)


def summary(trajectory, torque, torque_frame, exact):
    """Lines describing drift (and the error against the closed form when torque-free)."""
    lines = [f"method {trajectory.method}: {trajectory.steps} "
             f"{'steps' if trajectory.method.startswith('split') else 'rhs evaluations'}, "
             f"{trajectory.elapsed_s:.3g} s, {len(trajectory.t)} samples to t = {trajectory.t[-1]:.6g} s"]
    h0 = trajectory.momentum[0]
    size = float(np.linalg.norm(h0)) or 1.0
    k0 = float(trajectory.energy[0]) or 1.0
    if torque is None:
        lines.append(f"energy drift      max |K − K0| / K0   = {np.abs(trajectory.energy - k0).max() / k0:.3g}")
        lines.append("momentum drift    max |H − H0| / |H0| = "
                     f"{np.linalg.norm(trajectory.momentum - h0, axis=1).max() / size:.3g}")
    else:
        lines.append(f"energy            K(T) / K0 = {trajectory.energy[-1] / k0:.6g}")
        if torque_frame == "world":
            expected = h0 + np.outer(trajectory.t, torque)
            scale = float(np.linalg.norm(expected, axis=1).max()) or 1.0
            lines.append("momentum          max |H − (H0 + T t)| / max |H| = "
                         f"{np.linalg.norm(trajectory.momentum - expected, axis=1).max() / scale:.3g}")
    lines.append(f"quaternion norm   max ||q| − 1|      = "
                 f"{np.abs(np.linalg.norm(trajectory.quat, axis=1) - 1).max():.3g}")
    if exact is not None:
        from ..dynamics import trajectory_error
        omega_error, attitude_error = trajectory_error(trajectory, exact)
        lines.append(f"closed form       ω' error {omega_error:.3g} (relative), attitude error "
                     f"{attitude_error:.3g} rad")
    return lines


def work_precision_table(rows):
    lines = ["| method | rtol | steps / evaluations | time [s] | ω' error | attitude error [rad] |",
             "| --- | --- | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r.method} | {r.rtol:.0e} | {r.steps} | {r.elapsed_s:.3g} | {r.omega_error:.2e} | "
                     f"{r.attitude_error:.2e} |")
    return "\n".join(lines)


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--omega", type=float, nargs=3, required=True, metavar="WX WY WZ",
              help="Initial angular velocity ω' in local (body) axes [rad/s].")
@click.option("--duration", type=click.FloatRange(min=0, min_open=True), required=True, metavar="T",
              help="Simulated time [s].")
@click.option("--torque", type=float, nargs=3, default=None, metavar="TX TY TZ",
              help="Constant torque [mass·length²/s²]; torque-free without it.")
@click.option("--torque-frame", type=click.Choice(["body", "world"]), default="body", show_default=True,
              help="Axes the torque is fixed in.")
@click.option("--method", type=click.Choice(list(METHODS)), default=DEFAULT_METHOD, show_default=True,
              help="split2/4/6: geometric splitting (exact rotations, |H| kept to rounding); others: scipy.")
@click.option("--rtol", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Target relative error (default 1e-9).")
@click.option("--steps", type=click.IntRange(min=1), default=None,
              help="Fixed step count (splitting methods; instead of --rtol).")
@click.option("--samples", type=click.IntRange(min=2), default=1001, show_default=True,
              help="Rows of the time series.")
@click.option("--out", "out_csv", type=click.Path(dir_okay=False), help="Write the time series as CSV.")
@click.option("--plot", "plot_path", type=click.Path(dir_okay=False),
              help="Write a PNG (the time series, or the work–precision plot with --compare-methods).")
@click.option("--compare-methods", is_flag=True,
              help="Run every method at several tolerances against the closed form: table and log-log plot.")
@options.material_options
@options.pose_options
@options.repair_option
def spin(file, omega, duration, torque, torque_frame, method, rtol, steps, samples, out_csv, plot_path,
         compare_methods, density, total_mass, unit, rotate, translate, repair):
    """Integrate Euler's equations J' ω̇' = T' − ω' × J' ω' for the solid in FILE.

    Uses FILE's inertia about its center of mass (density, unit and pose as in
    `props`; the pose's rotation is the initial attitude).  Prints energy and
    momentum drift and, torque-free, the error against the closed-form
    (Jacobi elliptic) solution.  Exit 1 on a bad file or option.
    """
    from .. import dynamics
    from ..compute import mass_properties
    from ..dynamics_exact import torque_free

    if rtol is not None and steps is not None:
        raise click.UsageError("give --rtol or --steps, not both")
    if steps is not None and method not in SPLITTING:
        raise click.BadParameter(f"--steps applies to split2/split4/split6, not {method}; give --rtol",
                                 param_hint="--steps")
    if compare_methods and torque is not None:
        raise click.UsageError("--compare-methods measures errors against the torque-free closed form; "
                               "drop --torque")
    pose = options.guarded(options.pose_from_options, rotate, translate)
    if pose is None:
        options.exit_with(True)
    result = options.guarded(mass_properties, file, density=density, mass=total_mass, unit=unit, pose=pose,
                             repair=repair, path=file)
    if result is None:
        options.exit_with(True)
    properties = result.properties
    attitude = pose.rotation
    moments = properties.principal.moments
    click.echo(f"{file}: principal moments {moments[0]:.9g} {moments[1]:.9g} {moments[2]:.9g}"
               f"{' (SI)' if unit else ''}")
    if compare_methods:
        rows = options.guarded(dynamics.work_precision, properties.inertia_com, omega, duration,
                               attitude=attitude, samples=min(samples, 201), path=file)
        if rows is None:
            options.exit_with(True)
        click.echo(work_precision_table(rows))
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
    for line in summary(trajectory, torque, torque_frame, exact):
        click.echo(line)
    failed = False
    if out_csv:
        failed |= options.guarded(write_csv, out_csv, trajectory, path=out_csv) is None
    if plot_path:
        failed |= options.guarded(plot_trajectory, plot_path, trajectory,
                                  f"{file}: {trajectory.method}, ω'0 = {tuple(omega)} rad/s") is None
    options.exit_with(failed)
