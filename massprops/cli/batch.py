"""``massprops batch PATH... -o report.csv``: one report over many files, in parallel or on Dask."""

from __future__ import annotations

import sys

import click

from . import options

_SHOWN_FAILURES = 20


class _Progress:
    """click's progress bar on stderr, begun when the number of files to compute is known.

    Nothing at all when stderr is not a terminal (logs, pipes) or with --quiet.
    """

    def __init__(self, quiet):
        self.enabled = not quiet and sys.stderr.isatty()
        self.bar = None

    def start(self, total):
        if self.enabled and total:
            self.bar = click.progressbar(length=total, label="massprops batch", file=sys.stderr, show_pos=True,
                                         show_eta=True)
            self.bar.__enter__()

    def update(self, outcome):
        if self.bar is not None:
            self.bar.update(1)

    def close(self):
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
            self.bar = None


def _report_failures(summary):
    for file, message in summary.failures[:_SHOWN_FAILURES]:
        options.echo_error(f"{file}: {message}")
    hidden = len(summary.failures) - _SHOWN_FAILURES
    if hidden > 0:
        click.echo(f"... and {hidden} more failed files (status=error in the report)", err=True)


def _skipped_text(skipped):
    """``; skipped 1095 .urdf, 12 .mtl (not mesh formats massprops reads)``, or nothing."""
    if not skipped:
        return ""
    counts = sorted(skipped.items(), key=lambda item: (-item[1], item[0]))
    return "; skipped " + ", ".join(f"{n} {ext}" for ext, n in counts) + " (not mesh formats massprops reads)"


def _summary_line(summary):
    line = f"{summary.ok} ok, {summary.failed} failed"
    if summary.unchanged:
        line += f" ({summary.unchanged} unchanged, reused)"
    rate = f"{summary.files_per_s:.1f} files/s" if summary.computed else "nothing to compute"
    return f"{line}; {summary.computed} computed in {summary.elapsed_s:.2f} s, {rate}"


@click.command(cls=options.Command)
@click.argument("paths", nargs=-1, required=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False, writable=True),
              help="Report file (in --format), written as files finish (csv, jsonl) and sorted at the end.  "
                   "Default (or -): stdout when done.")
@options.format_option("csv", "jsonl", "json", "text")
@click.option("-j", "--jobs", type=click.IntRange(min=1), default=None, metavar="N",
              help="Worker processes (default: all cores); with --scheduler local, the Dask workers.")
@click.option("--resume", is_flag=True,
              help="Keep the report's rows for files whose size and mtime are unchanged; compute the rest.")
@click.option("-r", "--recursive", is_flag=True, help="Descend into sub-directories (and let ** match them).")
@click.option("--scheduler", metavar="local|tcp://HOST:PORT",
              help="Run on Dask: 'local' starts a LocalCluster, an address uses a running scheduler.  "
                   "Default: local worker processes, no Dask.")
@click.option("-q", "--quiet", is_flag=True, help="No progress bar, failure list or summary line.")
@click.option("--timeout", type=options.NON_NEGATIVE, default=300.0, show_default=True, metavar="SECONDS",
              help="Time one file may take in a local worker before it is stopped and reported (0: no limit; "
                   "--resume computes timed-out files again).")
@options.only_option("Comma-separated quantities: volume, mass, surface_area, center_of_mass, inertia, principal "
                     "(the other columns are left empty).")
@options.material_options
@options.pose_options
@options.cell_options
@options.repair_option
@options.self_intersection_option
@options.unpack_option
@options.graph_limit_options
def batch(paths, output, output_format, jobs, resume, recursive, scheduler, quiet, timeout, only, density, total_mass,
          unit, rotate, translate, density_field, density_map, shell, repair, self_intersection, max_unpacked,
          max_instances, max_depth):
    """A report of the mass properties of every mesh PATH names, one row per file, sorted by path.

    PATH is a file, a directory (its mesh files; --recursive for sub-directories),
    a glob such as 'parts/**/*.stl', or @LIST, a text file of paths one a line.
    One file under several names (./a.stl, dir/../a.stl, a link to it) is one
    row, under the first name.  CSV columns are those of docs/conventions.md
    (inertia about the center of mass, local axes; Ixy, Ixz, Iyz are the tensor's
    own elements); --only leaves the columns of other quantities empty;
    --format jsonl writes the full `props` objects one a line, json one array
    of them, text each file's block as `props` prints it and a count line
    (json and text are written whole at the end).  The report, on stdout or
    in the -o file whatever its name, is in the format --format gives.  A file that fails gets
    status=error and its message, and the run goes on; a worker that dies costs
    only its file (retried once).  Exit 0 if every file is ok, 1 if any failed
    (the report is still complete).
    """
    options.refuse_conflicts()
    from ..batch import run as batch_lib
    from ..model.errors import MassPropsError

    if output == "-":
        output = None
    if resume and output is None:
        raise click.UsageError("--resume needs the report file: give it with -o")
    duplicates, skipped = [], {}
    try:
        files = batch_lib.expand_inputs(paths, recursive=recursive, duplicates=duplicates, skipped=skipped)
    except MassPropsError as exc:
        raise click.BadParameter(exc.render("cli"), param_hint="PATH") from None
    pose = options.pose_from_options(rotate, translate)
    settings = batch_lib.Settings(density=density, mass=total_mass, unit=unit, pose=pose, repair=repair,
                                  density_field=density_field, density_map=density_map, shell=shell,
                                  max_unpacked=max_unpacked, max_instances=max_instances, max_depth=max_depth,
                                  self_intersection=self_intersection, only=only, option_style="cli")
    summary = _run(batch_lib, files, settings, output, output_format, jobs, resume, scheduler, quiet,
                   timeout or None)
    if summary.text is not None:
        options.echo(summary.text, nl=False)
    if summary.units:
        options.warn_units(density, unit, summary.units, mixed=True)
    if not quiet:
        if duplicates:
            name, kept = duplicates[0]
            click.echo(f"note: {len(duplicates)} name(s) of files already listed, one row each "
                       f"(e.g. {name} is {kept})", err=True)
        for note in summary.notes:
            click.echo(f"note: {note}", err=True)
        _report_failures(summary)
        click.echo(_summary_line(summary) + _skipped_text(skipped), err=True)
    options.exit_with(summary.failed)


def _run(batch_lib, files, settings, output, output_format, jobs, resume, scheduler, quiet, timeout):
    """run_batch with a progress bar; Ctrl-C keeps the rows done and says how to go on."""
    progress = _Progress(quiet)
    try:
        summary = options.guarded(batch_lib.run_batch, files, settings, output=output, output_format=output_format,
                                  jobs=jobs, scheduler=scheduler, resume=resume, timeout=timeout,
                                  on_start=progress.start, on_outcome=progress.update)
    except KeyboardInterrupt:
        progress.close()
        keeper = output if output_format in ("csv", "jsonl") else f"{output}.state.jsonl"
        kept = f"{keeper} keeps the files done; rerun with --resume to finish" if output else "nothing written"
        click.echo(f"\ninterrupted: {kept}", err=True)
        raise SystemExit(130) from None
    progress.close()
    if summary is None:
        raise SystemExit(1)
    return summary
