"""``massprops robot props|check|write MODEL...``: robot descriptions (URDF, xacro, SDF, MJCF)."""

from __future__ import annotations

import shutil

import click

from . import options

_FAILING = ("invalid", "error")
_STRICT = ("invalid", "error", "mismatch", "missing")


def _pairs(ctx, param, values):
    """``NAME=VALUE`` options into a tuple of pairs."""
    out = []
    for text in values:
        name, sep, value = text.partition("=")
        if not sep or not name or not value:
            raise click.BadParameter(f"expected NAME=VALUE, got {text!r}", param_hint=f"--{param.name}")
        out.append((name.strip(), value.strip()))
    return tuple(out)


def model_options(f):
    """Options every robot subcommand shares: geometry, mass, paths, meshes, joints."""
    decorators = [
        click.option("--geometry", type=click.Choice(["collision", "visual", "auto"]), default="collision",
                     show_default=True, help="Which geometry gives the solid (auto: collision if a link has any, "
                                             "else visual)."),
        click.option("--mass-policy", type=click.Choice(["density", "keep"]), default=None,
                     help="density: mass from densities; keep: the declared mass spread over the geometry "
                          "(default: density for props, keep for check and write)."),
        click.option("--density", type=options.POSITIVE, help="Density [kg/m³] for geometry the file and --config give none.  "
                                                   "Default 1000 (water, as sdformat and MuJoCo), with a warning."),
        click.option("--package", "package", multiple=True, metavar="NAME=DIR", callback=_pairs,
                     help="Where package://NAME/ (or model://NAME/) lives (repeatable); searched first."),
        click.option("--config", "config_path", type=click.Path(dir_okay=False),
                     help="TOML: [packages], [materials], [links.\"GLOB\"], [geometries.\"GLOB\"]."),
        click.option("--joints", metavar="NAME=VALUE,...",
                     help="Joint values for the robot's total (radians, metres); default all 0."),
        click.option("--on-open", metavar="hull|shell:T|skip",
                     help="An open mesh: use its convex hull, a sheet T metres thick, or leave it out "
                          "(default: the link is an error)."),
        click.option("--xacro-arg", "xacro_args", multiple=True, metavar="NAME=VALUE", callback=_pairs,
                     help="Argument for a .xacro file (repeatable)."),
        click.option("--allow-env", is_flag=True,
                     help="Let a .xacro file read environment variables ($(env), $(optenv), $(cwd)); without it "
                          "$(env) is refused and $(optenv) takes its default."),
        click.option("--root", "roots", multiple=True, metavar="DIR", type=click.Path(file_okay=False),
                     help="A folder the model may also read files from (repeatable); by default only its own "
                          "package and the packages it names."),
        click.option("--tolerance", type=options.POSITIVE, default=1e-9, show_default=True,
                     help="Largest error bound, relative to a link's mass and inertia, where its primitives "
                          "overlap (the overlap is refined until within it)."),
        options.repair_option,
        options.graph_limit_options,
    ]
    for decorate in reversed(decorators):
        f = decorate(f)
    return f


def _settings(command, geometry, mass_policy, density, package, config_path, joints, on_open, xacro_args, allow_env,
              roots, repair, tolerance=1e-9, **extra):
    from ..robot.analyze import RobotSettings
    from ..robot.geometry import parse_on_open
    parse = options.guarded(parse_on_open, on_open)
    if parse is None:
        raise SystemExit(2)
    return RobotSettings(command=command, geometry=geometry, mass_policy=mass_policy, density=density,
                         packages=package, config_path=config_path, joints=joints, repair=repair, on_open=on_open,
                         xacro_args=xacro_args, allow_env=allow_env, roots=roots, option_style="cli", tolerance=tolerance,
                         **extra)


def _analyze_all(models, settings, jobs):
    """Every model's object, in order; several models run in worker processes like ``batch``."""
    from ..robot.analyze import analyze
    if len(models) <= 1 or jobs == 1:
        return [analyze(m, settings) for m in models]
    from concurrent.futures import ProcessPoolExecutor
    from ..batch.run import default_jobs
    workers = min(jobs or default_jobs(), len(models))
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(analyze, models, [settings] * len(models)))


def _emit(objects, output_format, text):
    from .. import report
    from ..report import robot as robot_report
    if output_format == "json":
        click.echo(report.to_json(objects))
    elif output_format == "jsonl":
        click.echo(report.to_jsonl(objects), nl=False)
    elif output_format == "csv":
        click.echo(robot_report.csv_text(objects), nl=False)
    else:
        for obj in objects:
            click.echo(text(obj))
            click.echo("")
    for obj in objects:
        if obj.get("status") == "error" and output_format != "text":
            options.echo_error(f"{obj['model']}: {obj['message']}")


def html_option(f):
    return click.option("--html", "html_path", type=click.Path(dir_okay=False), metavar="REPORT.html",
                        help="Also write a self-contained web page: the robot at --joints, each link's computed and "
                             "declared equivalent inertia box and centre of mass, and the table (one MODEL; needs "
                             "plotly, the view extra).")(f)


def _one_model_for_html(models, html_path):
    if html_path and len(models) != 1:
        raise click.UsageError(f"--html draws one model; {len(models)} were given — run once per model")


def _html(models, settings, objects, html_path):
    """Write the robot page for the one model, or say why not (one line); returns whether it failed."""
    from ..view import write_picture
    from ..view.robot import robot_picture
    if objects[0].get("status") == "error":
        options.echo_error(f"{html_path}: not written: {models[0]} could not be read")
        return True
    picture = options.guarded(robot_picture, models[0], settings, objects[0], path=models[0])
    if picture is None or options.guarded(write_picture, picture, html_path, path=html_path) is None:
        return True
    click.echo(f"wrote {html_path}", err=True)
    return False


def _exit(objects, failing, failed=False):
    bad = failed or any(obj.get("status") == "error" or any(link["status"] in failing for link in obj["links"])
                        for obj in objects)
    options.exit_with(bad)


@click.group()
def robot():
    """Robot descriptions: per-link mass properties, checks of the declared inertials, corrected files.

    MODEL is a URDF (.urdf, or .xacro with the xacro package), SDF or MJCF
    (through the mujoco package) file; the format comes from its root element.
    URDF/SDF ixy etc. are tensor elements (−∫xy dm) about the center of mass
    in the inertial frame (rpy: R = Rz(y) Ry(p) Rx(r)).  All values are SI.
    """


# The keys of a link (and of the total) that each --only quantity prints; error bounds follow their quantity.
_ONLY_KEYS = {"volume": ("volume",), "mass": ("mass",), "surface_area": ("surface_area",),
              "center_of_mass": ("center_of_mass", "center_of_mass_global"),
              "inertia": ("inertia_com", "inertia_com_global", "inertia_origin"),
              "principal": ("principal_moments", "principal_axes", "degenerate", "principal_axes_rad")}


def _keep_only(objects, only):
    """The objects with the link and total quantities --only leaves out removed (their bounds too)."""
    if not only:
        return objects
    dropped = {key for name, keys in _ONLY_KEYS.items() if name not in only for key in keys}

    # check's computed inertial (at the declared mass) shows as principal moments in its table
    computed_dropped = dropped - ({"inertia_com"} if "principal" in only else set())

    def trim(part):
        if not part:
            return part
        part = {k: v for k, v in part.items() if k not in dropped}
        if isinstance(part.get("error"), dict):
            part["error"] = {k: v for k, v in part["error"].items() if k not in dropped}
        if isinstance(part.get("computed"), dict):
            part["computed"] = {k: v for k, v in part["computed"].items() if k not in computed_dropped}
        return part
    return [{**obj, "links": [trim(link) for link in obj.get("links", [])],
             **({"total": trim(obj["total"])} if obj.get("total") else {})} for obj in objects]


@robot.command("props")
@click.argument("models", nargs=-1, required=True, type=click.Path(dir_okay=False))
@model_options
@options.only_option("Comma-separated quantities printed per link and for the total: volume, mass, surface_area, "
                     "center_of_mass, inertia, principal.  Default: all (the total needs every link's mass, "
                     "centre of mass and inertia, so those are computed whatever is printed).")
@options.format_option("text", "json", "jsonl", "csv")
@click.option("-j", "--jobs", type=click.IntRange(min=1), default=None, metavar="N",
              help="Worker processes for several models (default: all cores).")
@html_option
def props(models, only, output_format, jobs, html_path, **kwargs):
    """Every link's mass properties from its geometry, and the robot's total at --joints.

    Per link: mass, center of mass (link frame), inertia about it (link axes),
    principal moments and axes, error bounds, and each geometry with the file
    it resolved to.  Exit 1 if a model or a link could not be computed.
    """
    options.refuse_conflicts()
    from ..report.robot import props_text
    _one_model_for_html(models, html_path)
    settings = _settings("props", **kwargs)
    objects = _analyze_all(models, settings, jobs)
    _emit(_keep_only(objects, only), output_format, props_text)
    _exit(objects, ("error",), bool(html_path) and _html(models, settings, objects, html_path))


@robot.command("check")
@click.argument("models", nargs=-1, required=True, type=click.Path(dir_okay=False))
@model_options
@click.option("--declared-only", is_flag=True, help="Check the declared inertials alone (no meshes read).")
@options.only_option("Comma-separated quantities printed of each link's geometry: volume, mass, surface_area, "
                     "center_of_mass, inertia, principal.  Default: all.  The check itself (status, diagnoses, "
                     "the comparison, --format junit) always compares mass, centre of mass and inertia.")
@click.option("--strict", is_flag=True, help="Exit 1 also on mismatch and missing.")
@click.option("--massless", multiple=True, metavar="GLOB", help="Links whose mass 0 is intended (repeatable).")
@click.option("--inertia-rtol", type=options.POSITIVE, default=0.1, show_default=True,
              help="Mismatch when max|J_declared − J| / max|J| exceeds this.")
@click.option("--com-rtol", type=options.POSITIVE, default=0.1, show_default=True,
              help="Mismatch when the COM distance exceeds this fraction of the link size.")
@click.option("--diagnosis-rtol", type=options.POSITIVE, default=0.02, show_default=True,
              help="How close a diagnosis's transformed tensor must come to the declared one.")
@click.option("--junit", type=click.Path(dir_okay=False, writable=True), help="Also write JUnit XML here.")
@options.format_option("text", "json", "jsonl", "csv", "junit")
@click.option("-j", "--jobs", type=click.IntRange(min=1), default=None, metavar="N",
              help="Worker processes for several models (default: all cores).")
@html_option
def check(models, declared_only, only, strict, massless, inertia_rtol, com_rtol, diagnosis_rtol, junit, output_format,
          jobs, html_path, **kwargs):
    """Check each link's declared inertial: valid, and consistent with its geometry.

    Status per link: ok, mismatch (with diagnoses), invalid, missing,
    no-geometry, massless, error.  --format junit prints JUnit XML, one test
    case per link (failures: the statuses that make the exit status 1).  Exit 1 only on invalid or error (with
    --strict also on mismatch and missing); a mismatch explains, since declared
    inertials are rarely of uniform solids.
    """
    options.refuse_conflicts()
    from ..robot.check import Tolerances
    from ..report.robot import check_text, junit_xml
    _one_model_for_html(models, html_path)
    settings = _settings("check", tolerances=Tolerances(inertia_rtol, com_rtol, diagnosis_rtol),
                         massless=tuple(massless), declared_only=declared_only, **kwargs)
    objects = _analyze_all(models, settings, jobs)
    failing = _STRICT if strict else _FAILING
    if output_format == "junit":
        click.echo(junit_xml(objects, failing), nl=False)
    else:
        _emit(_keep_only(objects, only), output_format, check_text)
    if junit:
        with open(junit, "w", encoding="utf-8") as handle:
            handle.write(junit_xml(objects, failing))
    _exit(objects, failing, bool(html_path) and _html(models, settings, objects, html_path))


@robot.command("write")
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False, writable=True), help="Write the new file here.")
@click.option("--in-place", is_flag=True, help="Overwrite MODEL, keeping MODEL.bak.")
@click.option("--links", "links_glob", multiple=True, metavar="GLOB",
              help="Write these links (repeatable); default: links whose inertial is missing or invalid.")
@click.option("--all", "all_links", is_flag=True, help="Write every link that has geometry.")
@click.option("--frame", type=click.Choice(["link", "principal"]), default="link", show_default=True,
              help="link: origin at the COM, no rotation, full tensor in link axes; principal: diagonal tensor "
                   "with the principal axes' rotation.")
@click.option("--expand", is_flag=True, help="For a .xacro file: write the expanded URDF (-o) instead of editing the "
                                            ".xacro files where the inertials are written literally.")
@model_options
def write(model, output, in_place, links_glob, all_links, frame, expand, **kwargs):
    """Write <inertial> elements computed from the geometry; every other byte stays as it was.

    Each inertial goes into the file that holds it: an MJCF body in an
    included file is written there, a .xacro link's literal <inertial> in its
    .xacro file (--in-place when that is not MODEL itself; every file written
    is listed).  An inertial made by a xacro macro is left, naming the macro
    and the values; --expand writes the expanded URDF instead.

    Numbers are written in shortest round-trip form and read back through the
    strict checks (A + B >= C with no tolerance, positive definite); a thin
    plate's moments may be nudged by a few ulps for that, and it is said.
    """
    options.refuse_conflicts()
    from ..robot.write import write_inertials
    if not output and not in_place:
        raise click.UsageError("give -o OUT or --in-place (one of them)")
    settings = _settings("check", **kwargs)
    result = options.guarded(write_inertials, model, settings, links_glob=links_glob or None, all_links=all_links,
                             frame=frame, expand=expand, path=model)
    if result is None:
        raise SystemExit(1)
    import os
    main = os.path.abspath(model)
    others = [f for f in result.files if f != main]
    if others and not in_place:
        also = " (and in MODEL itself)" if main in result.files else ""
        options.echo_error(f"{model}: the inertials to write are in {', '.join(sorted(others))}{also}, which -o "
                           "cannot write beside one output file — give --in-place (each file written keeps "
                           "FILE.bak)")
        raise SystemExit(1)
    files = dict(result.files) if in_place else {os.path.abspath(output): result.data}
    for path, data in files.items():
        if in_place:
            shutil.copy2(path, path + ".bak")
        with open(path, "wb") as handle:
            handle.write(data)
    from ..model.errors import printable, render_options
    for record in result.written:
        note = f"; {record['nudge_note']}" if record.get("nudge_note") else ""
        where = f" in {record['file']}" if in_place and record.get("file") and record["file"] != main else ""
        click.echo(f"wrote {record['link']}{where} (was {record['before']}): mass {record['mass']:.9g} kg{note}")
        for warning in record["warnings"]:
            click.echo(f"  warning: {printable(render_options(warning, 'cli'))}")
    for record in result.skipped:
        click.echo(f"left {record['link']}: {printable(render_options(record['reason'], 'cli'))}")
    if in_place:
        listed = ", ".join(f"{p} (backup {p}.bak)" for p in files) or "no file"
        click.echo(f"{len(result.written)} inertial(s) written to {listed}")
    else:
        click.echo(f"{len(result.written)} inertial(s) written to {output}")
    options.exit_with([r for r in result.skipped if r["failed"]])
