"""``massprops regress EXPECTED.csv``: recompute every listed file, fail on any deviation (for CI)."""

from __future__ import annotations

import os
import time

import click

from . import options


@click.command()
@click.argument("expected", type=click.Path(dir_okay=False))
@click.argument("files", nargs=-1, type=click.Path())
@click.option("--record", is_flag=True,
              help="Write the current values of FILE... into EXPECTED (their baseline) instead of comparing; "
                   "rows of other files already in EXPECTED are kept.")
@click.option("--rtol", type=options.NON_NEGATIVE, default=1e-9, show_default=True,
              help="Relative tolerance, normwise per quantity.")
@click.option("--atol", type=options.NON_NEGATIVE, default=0.0, show_default=True,
              help="Absolute tolerance, in the quantity's units.")
@click.option("--junit", "junit", type=click.Path(dir_okay=False), help="Also write a JUnit XML report here.")
@click.option("--density", type=options.POSITIVE, help="With --record: density to compute with (stored in the baseline).")
@click.option("--unit", type=click.Choice(options.UNIT_CHOICES), help="With --record: the meshes' length unit.")
def regress(expected, files, record, rtol, atol, junit, density, unit):
    """Compare every file listed in EXPECTED (a CSV) with its expected values.

    Recomputes volume, mass, center of mass, inertia about the COM, principal
    moments and principal axes (up to sign; only the subspace of equal
    moments); prints the worst relative deviation per quantity and file, and
    names every value with |actual - expected| > atol + rtol * scale (scale:
    the quantity's largest expected element).  Exit 1 on any deviation or
    unreadable file.

    \b
    massprops regress sample_meshes/expected.csv --junit report.xml
    massprops regress --record baseline.csv parts/*.stl --density 7850 --unit mm
    """
    if record:
        if not files:
            raise click.UsageError("--record needs the FILEs to record")
        _record(expected, files, density, unit)
        return
    if files:
        raise click.UsageError("FILEs are only given with --record; the files to check are listed in EXPECTED")
    if density is not None or unit is not None:
        raise click.UsageError("--density and --unit are for --record; EXPECTED says how to compute each file")
    _compare(expected, rtol, atol, junit)


def _record(expected, files, density, unit):
    from ..validation import regress as lib
    from ..api import mass_properties

    folder = os.path.dirname(os.path.abspath(expected))
    rows, failed = {}, 0
    for path in files:
        result = options.guarded(mass_properties, path, density=density, unit=unit, path=path)
        if result is None:
            failed += 1
            continue
        label = os.path.relpath(os.path.abspath(path), folder).replace(os.sep, "/")
        p = result.properties
        rows[label] = lib.expected_row(label, volume=p.volume, mass=p.mass, center_of_mass=p.center_of_mass,
                                       inertia_com=p.inertia_com, principal=p.principal,
                                       triangles=result.triangles, density=density, unit=unit)
    columns = []
    if os.path.exists(expected):
        kept = options.guarded(lib.read_rows, expected, path=expected)
        if kept is None:
            raise SystemExit(1)
        old_rows, columns = kept
        rows = {**{r["file"]: r for r in old_rows}, **rows}
    lib.write_expected(expected, list(rows.values()), extra_columns=columns)
    click.echo(f"recorded {len(files) - failed} file(s) in {expected}")
    options.exit_with(failed)


def _compare(expected, rtol, atol, junit):
    from ..validation import regress as lib
    from ..api import mass_properties

    rows = options.guarded(lib.read_expected, expected, path=expected)
    if rows is None:
        raise SystemExit(1)
    labels, comparisons, cases = [], [], []
    for row in rows:
        start = time.perf_counter()
        errors = []
        result = options.guarded(_computed, mass_properties, row, errors, path=row.path)
        comparison = None if result is None else lib.compare(row, result.properties, rtol=rtol, atol=atol)
        labels.append(row.label)
        comparisons.append(comparison)
        cases.append((row.label, comparison, errors[0] if errors else "could not be computed",
                      time.perf_counter() - start))
    click.echo(lib.deviation_table(labels, comparisons))
    failures = [(label, d) for label, c in zip(labels, comparisons) if c is not None for d in c.failures]
    for label, deviation in failures:
        click.echo(f"FAIL {label}: {lib.describe(deviation)}")
    broken = sum(c is None for c in comparisons)
    bad_files = len({label for label, _ in failures})
    click.echo(f"{len(rows)} file(s), rtol={rtol:g} atol={atol:g}: " + (
        "all within tolerance" if not failures and not broken else
        f"{len(failures)} deviation(s) in {bad_files} file(s), {broken} file(s) not computed"))
    if junit:
        with open(junit, "w", encoding="utf-8") as f:
            f.write(lib.junit_xml(cases, rtol=rtol, atol=atol))
    options.exit_with(failures or broken)


def _computed(mass_properties, row, errors):
    from ..model.errors import MassPropsError

    try:
        return mass_properties(row.path, density=row.density, unit=row.unit)
    except MassPropsError as exc:
        errors.append(options.render(exc, row.path))
        raise
