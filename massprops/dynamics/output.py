"""What a spin run writes: the time series as CSV, plots, and the summary lines."""

from __future__ import annotations

import contextlib

import numpy as np

from ..model.errors import MassPropsError
from ..plotting import pyplot
from .integrators import trajectory_error

__all__ = ["write_csv", "plot_trajectory", "plot_work_precision", "summary", "drift", "samples", "csv_text",
           "work_precision_table"]

CSV_HEADER = "t,wx,wy,wz,qw,qx,qy,qz,Hx,Hy,Hz,K"


def _pyplot():
    return pyplot("--plot", "pip install 'massprops[plot]'")


@contextlib.contextmanager
def _writable(path):
    try:
        yield
    except OSError as exc:
        raise MassPropsError(f"cannot write the file ({exc.strerror or exc})", path=path,
                             fix="check that the directory exists and is writable") from None


def write_csv(path, trajectory):
    """The time series: t, ω' (body), quaternion of A (w,x,y,z), H (world), K (:func:`csv_text`)."""
    text = csv_text(trajectory)
    with _writable(path), open(path, "w", encoding="utf-8", newline="") as handle:
        handle.write(text)
    return path


def plot_trajectory(path, trajectory, title, *, si=False):
    """Three panels against t: ω' (body axes), H (world axes) and K's relative drift from K0.

    ``si``: the inertia was in kg·m² (a --unit was given), else in mass·length² of the mesh.
    No axis uses offset notation; K, nearly constant, is shown as (K − K0)/K0 with K0 in the legend.
    """
    from matplotlib.ticker import ScalarFormatter
    plt = _pyplot()
    momentum_unit, energy_unit = ("kg·m²/s", "J") if si else ("mass·length²/s", "mass·length²/s²")
    figure, panels = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for k, name in enumerate("xyz"):
        panels[0].plot(trajectory.t, trajectory.omega[:, k], label=f"ω'{name}")
        panels[1].plot(trajectory.t, trajectory.momentum[:, k], label=f"H{name}")
    k0 = float(trajectory.energy[0])
    drift = (trajectory.energy - k0) / k0 if k0 else trajectory.energy - k0
    panels[2].plot(trajectory.t, drift, label=f"K0 = {k0:.9g} {energy_unit}")
    labels = ("ω' [rad/s], body axes", f"H [{momentum_unit}], world axes",
              "(K − K0) / K0 [–]" if k0 else f"K − K0 [{energy_unit}]")
    for panel, label in zip(panels, labels):
        panel.set_ylabel(label)
        formatter = ScalarFormatter(useOffset=False, useMathText=True)
        formatter.set_powerlimits((-3, 4))
        panel.yaxis.set_major_formatter(formatter)
        panel.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        panel.grid(True, alpha=0.3)
    panels[2].set_xlabel("t [s]")
    figure.suptitle(title)
    return _save(plt, figure, path)


def _save(plt, figure, path):
    figure.tight_layout()
    try:
        with _writable(path):
            figure.savefig(path, dpi=110, bbox_inches="tight")
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
    panel.set_ylabel("max relative error of ω' against the closed form [–]")
    panel.grid(True, which="major", alpha=0.3)
    panel.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    panel.set_title(title)
    return _save(plt, figure, path)


def drift(trajectory, torque, torque_frame, exact):
    """The run's drift figures (and the error against the closed form when ``exact`` is given), by name.

    Torque-free: ``energy_drift`` max |K − K0| / K0 and ``momentum_drift``
    max |H − H0| / |H0|; with a torque: ``energy_ratio`` K(T) / K0 and, world
    torque, ``momentum_drift`` max |H − (H0 + T t)| / max |H|.  Always
    ``quaternion_norm`` max ||q| − 1|; with ``exact``, ``omega_error``
    (relative) and ``attitude_error`` [rad].
    """
    out = {}
    h0 = trajectory.momentum[0]
    size = float(np.linalg.norm(h0)) or 1.0
    k0 = float(trajectory.energy[0]) or 1.0
    if torque is None:
        out["energy_drift"] = float(np.abs(trajectory.energy - k0).max() / k0)
        out["momentum_drift"] = float(np.linalg.norm(trajectory.momentum - h0, axis=1).max() / size)
    else:
        out["energy_ratio"] = float(trajectory.energy[-1] / k0)
        if torque_frame == "world":
            expected = h0 + np.outer(trajectory.t, torque)
            scale = float(np.linalg.norm(expected, axis=1).max()) or 1.0
            out["momentum_drift"] = float(np.linalg.norm(trajectory.momentum - expected, axis=1).max() / scale)
    out["quaternion_norm"] = float(np.abs(np.linalg.norm(trajectory.quat, axis=1) - 1).max())
    if exact is not None:
        out["omega_error"], out["attitude_error"] = map(float, trajectory_error(trajectory, exact))
    return out


def summary(trajectory, torque, torque_frame, exact):
    """Lines describing drift (and the error against the closed form when torque-free)."""
    lines = [f"method {trajectory.method}: {trajectory.steps} "
             f"{'steps' if trajectory.method.startswith('split') else 'rhs evaluations'}, "
             f"{trajectory.elapsed_s:.3g} s, {len(trajectory.t)} samples to t = {trajectory.t[-1]:.6g} s"]
    d = drift(trajectory, torque, torque_frame, exact)
    if torque is None:
        lines.append(f"energy drift      max |K − K0| / K0   = {d['energy_drift']:.3g}")
        lines.append(f"momentum drift    max |H − H0| / |H0| = {d['momentum_drift']:.3g}")
    else:
        lines.append(f"energy            K(T) / K0 = {d['energy_ratio']:.6g}")
        if "momentum_drift" in d:
            lines.append(f"momentum          max |H − (H0 + T t)| / max |H| = {d['momentum_drift']:.3g}")
    lines.append(f"quaternion norm   max ||q| − 1|      = {d['quaternion_norm']:.3g}")
    if "omega_error" in d:
        lines.append(f"closed form       ω' error {d['omega_error']:.3g} (relative), attitude error "
                     f"{d['attitude_error']:.3g} rad")
    return lines


def samples(trajectory):
    """The time series as dicts, one per sample, keyed by the CSV columns (t, wx, …, K)."""
    table = np.column_stack([trajectory.t, trajectory.omega, trajectory.quat, trajectory.momentum,
                             trajectory.energy])
    names = CSV_HEADER.split(",")
    return [dict(zip(names, map(float, row))) for row in table]


def csv_text(trajectory):
    """The time series as CSV text (the columns of :func:`write_csv`)."""
    from ..report import to_csv
    return to_csv(samples(trajectory), CSV_HEADER.split(","))


def work_precision_table(rows):
    lines = ["| method | rtol | steps / evaluations | time [s] | ω' error | attitude error [rad] |",
             "| --- | --- | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r.method} | {r.rtol:.0e} | {r.steps} | {r.elapsed_s:.3g} | {r.omega_error:.2e} | "
                     f"{r.attitude_error:.2e} |")
    return "\n".join(lines)
