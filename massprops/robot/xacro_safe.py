"""xacro without code: the ``xacro`` package's expansion with every expression evaluated as data.

xacro evaluates ``${...}`` and ``$(eval ...)`` with Python's ``eval``, and
its "safe" globals can be escaped (``python.vars(...)`` reaches ``os``), so a
robot file could run code on the reader's machine.  Here the ``xacro``
package still does the XML work (macros, blocks, properties, scopes, includes,
conditionals), but while :func:`expand_xacro` runs its evaluation hooks are
replaced, and restored on exit:

- ``xacro.safe_eval`` (every ``${...}``, and YAML's ``!degrees``-style tags)
  and ``$(eval ...)`` walk the expression's syntax tree (``ast.parse``; nothing
  is compiled or executed) and admit only: literals; names of properties,
  macro parameters and arguments; ``+ - * / // % **``, comparisons, ``and or
  not``, ``x if c else y``; subscripts and slices of strings, lists and dicts;
  calls of :data:`FUNCTIONS` (math, ``load_yaml``, a few pure built-ins) and of
  the pure string methods in :data:`STRING_METHODS`; dotted access into
  loaded YAML dicts and xacro namespaces.  Anything else (other attributes,
  ``python.``, lambdas, comprehensions) is :class:`XacroExpressionError`,
  naming the expression and its line.
- ``$(env ...)`` and ``$(cwd)`` need ``allow_env``; without it ``$(optenv
  NAME default)`` takes its default, with a warning.
- ``xacro:include``, ``load_yaml``, ``$(find ...)`` and ``package://`` are
  answered by the model's :class:`massprops.robot.resolve.Resolver` and
  confined to its roots.
"""

from __future__ import annotations

import ast
import contextlib
import io
import math
import operator
import os
import re
from contextlib import contextmanager

from ..model.errors import MassPropsError, OptionError, option
from .model import RobotFormatError

__all__ = ["expand_xacro", "XacroExpressionError", "evaluate", "FUNCTIONS", "STRING_METHODS"]

_MATH = ("pi", "e", "tau", "inf", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
         "asinh", "acosh", "atanh", "sqrt", "exp", "log", "log10", "log2", "pow", "hypot", "degrees", "radians",
         "fabs", "floor", "ceil", "trunc", "fmod", "copysign", "isclose", "isfinite", "isinf", "isnan")
_BUILTINS = {"abs": abs, "min": min, "max": max, "round": round, "int": int, "float": float, "str": str,
             "bool": bool, "len": len}
# Pure functions of data, reachable by name (math's also as math.NAME, as xacro exposes them).
FUNCTIONS = {**{name: getattr(math, name) for name in _MATH}, **_BUILTINS}
# Methods of a str that return data and touch nothing else (not format: "{0.__class__}" walks attributes).
STRING_METHODS = frozenset({"split", "rsplit", "strip", "lstrip", "rstrip", "upper", "lower", "replace",
                            "startswith", "endswith", "find", "count", "join", "isdigit"})
_LONGEST = 10 ** 6                   # a string or list longer than this is refused (``'x' * 10**12``)
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Not: operator.not_}
_COMPARE = {ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le,
            ast.Gt: operator.gt, ast.GtE: operator.ge, ast.In: lambda a, b: a in b,
            ast.NotIn: lambda a, b: a not in b, ast.Is: operator.is_, ast.IsNot: operator.is_not}
_DATA = (str, int, float, bool, list, tuple, dict, type(None))
_WHAT = ("massprops evaluates only literals, properties and arguments, arithmetic, comparisons, and/or/not, "
         "x if c else y, subscripts, math, load_yaml and str/int/float/len/min/max/abs/round")


class XacroExpressionError(RobotFormatError):
    """A xacro expression uses something massprops does not evaluate (attributes, ``python.``, lambdas...)."""


class _Refused(Exception):
    """Raised inside the walk; becomes a XacroExpressionError naming the expression and its line."""


class _Method:
    """A whitelisted method bound to a string: calling it is the only thing an expression can do with it."""

    __slots__ = ("text", "name")

    def __init__(self, text, name):
        self.text, self.name = text, name

    def __call__(self, *args):
        if not all(isinstance(a, _DATA) for a in args):
            raise _Refused(f"str.{self.name} takes data only")
        return getattr(self.text, self.name)(*args)


def _sized(value):
    if isinstance(value, (str, list, tuple)) and len(value) > _LONGEST:
        raise _Refused(f"a value of {len(value):,} items is too large")
    if isinstance(value, int) and value.bit_length() > 4 * _LONGEST:
        raise _Refused("an integer this large is not evaluated")
    return value


class _Walk:
    """Evaluates one parsed expression against ``lookup`` (name → value) and ``callables``."""

    def __init__(self, lookup, callables, namespaces):
        self.lookup, self.callables, self.namespaces = lookup, callables, namespaces

    def __call__(self, node):
        handler = getattr(self, "_" + type(node).__name__, None)
        if handler is None:
            raise _Refused(f"{type(node).__name__} ({ast.unparse(node)!r}) is not evaluated")
        return handler(node)

    def _Expression(self, node):
        return self(node.body)

    def _Constant(self, node):
        if not isinstance(node.value, (str, int, float, bool, type(None))):
            raise _Refused(f"the literal {node.value!r} is not evaluated")
        return node.value

    def _Name(self, node):
        if node.id.startswith("_"):
            raise _Refused(f"the name {node.id!r} is not evaluated")
        return self.lookup(node.id)

    def _Attribute(self, node):
        value = self(node.value)
        name = node.attr
        if name.startswith("_"):
            raise _Refused(f"the attribute '.{name}' is not evaluated")
        if isinstance(value, str) and name in STRING_METHODS:
            return _Method(value, name)
        if self.namespaces(value):
            try:
                return value[name]
            except KeyError:
                raise _Refused(f"'{ast.unparse(node.value)}' has no {name!r}") from None
        raise _Refused(f"the attribute '.{name}' of a {type(value).__name__} is not evaluated "
                       "(dotted access works on YAML dicts and xacro namespaces)")

    def _Call(self, node):
        function = self(node.func)
        if not (isinstance(function, _Method) or any(function is f for f in self.callables)):
            raise _Refused(f"calling {ast.unparse(node.func)!r} is not evaluated")
        if any(isinstance(a, ast.Starred) for a in node.args) or any(k.arg is None for k in node.keywords):
            raise _Refused("* and ** arguments are not evaluated")
        args = [self(a) for a in node.args]
        keywords = {k.arg: self(k.value) for k in node.keywords}
        return _sized(function(*args, **keywords))

    def _BinOp(self, node):
        kind = _BINARY.get(type(node.op))
        if kind is None:
            raise _Refused(f"the operator in {ast.unparse(node)!r} is not evaluated")
        left, right = self(node.left), self(node.right)
        if kind is operator.pow and isinstance(left, int) and isinstance(right, int) and abs(left) > 1 and \
                abs(left).bit_length() * right > 4 * _LONGEST:
            raise _Refused("a power this large is not evaluated")
        if kind is operator.mul:
            for seq, count in ((left, right), (right, left)):
                if isinstance(seq, (str, list, tuple)) and isinstance(count, int) and len(seq) * count > _LONGEST:
                    raise _Refused("a repetition this large is not evaluated")
        if kind is operator.mod and isinstance(left, str) and not isinstance(right, (*_DATA,)):
            raise _Refused("% formatting takes data only")
        return _sized(kind(left, right))

    def _UnaryOp(self, node):
        kind = _UNARY.get(type(node.op))
        if kind is None:
            raise _Refused(f"the operator in {ast.unparse(node)!r} is not evaluated")
        return kind(self(node.operand))

    def _BoolOp(self, node):
        is_and = isinstance(node.op, ast.And)
        value = None
        for operand in node.values:
            value = self(operand)
            if bool(value) != is_and:
                return value
        return value

    def _Compare(self, node):
        left = self(node.left)
        for op, right_node in zip(node.ops, node.comparators):
            right = self(right_node)
            if not _COMPARE[type(op)](left, right):
                return False
            left = right
        return True

    def _IfExp(self, node):
        return self(node.body) if self(node.test) else self(node.orelse)

    def _Subscript(self, node):
        value = self(node.value)
        if not isinstance(value, (str, list, tuple, dict)):
            raise _Refused(f"subscripting a {type(value).__name__} is not evaluated")
        return value[self(node.slice)]

    def _Slice(self, node):
        return slice(*(None if part is None else self(part) for part in (node.lower, node.upper, node.step)))

    def _List(self, node):
        return [self(e) for e in node.elts]

    def _Tuple(self, node):
        return tuple(self(e) for e in node.elts)

    def _Dict(self, node):
        if any(k is None for k in node.keys):
            raise _Refused("** in a dict is not evaluated")
        return {self(k): self(v) for k, v in zip(node.keys, node.values)}


def evaluate(text, lookup, *, callables=(), namespaces=lambda value: False):
    """The value of the expression ``text``, by the rules of the module docstring.

    ``lookup(name)`` gives a name's value (KeyError if none: then :data:`FUNCTIONS`); ``callables`` are the function
    objects a call may reach besides :data:`FUNCTIONS`; ``namespaces(value)`` says whether dotted access
    into ``value`` reads its items.  Raises ``_Refused`` for anything not admitted.
    """
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise _Refused(f"not an expression ({exc.msg})") from None
    def named(name):
        try:
            return lookup(name)
        except KeyError:
            if name in FUNCTIONS:
                return FUNCTIONS[name]
            raise _Refused(f"name {name!r} is not defined") from None
    return _Walk(named, (*FUNCTIONS.values(), *callables), namespaces)(tree)


# -- the xacro package, hooked ------------------------------------------------------

class _Expansion:
    """One file's expansion: its resolver, its options, and what was refused or warned."""

    def __init__(self, path, resolver, allow_env):
        import xacro
        self.xacro, self.path, self.resolver, self.allow_env = xacro, os.fspath(path), resolver, allow_env
        self.refusals, self.warnings = [], []
        self._load_yaml = self.load_yaml        # one bound method: calls are admitted by identity
        self.root = self._root_symbols()

    def _root_symbols(self):
        """The global symbols every property table ends at: data functions only (xacro's have ``python``)."""
        xacro = self.xacro

        def fatal(*args):
            raise xacro.XacroException(" ".join(map(str, args)))

        def silent(*args, **kwargs):
            return ""

        def arg(name):
            return xacro.substitution_args_context["arg"][name]

        own = {"load_yaml": self._load_yaml, "dotify": xacro.YamlDictWrapper, "arg": arg, "fatal": fatal,
               "error": silent, "warning": silent, "message": silent, "print_location": silent}
        self.callables = tuple(own.values())
        root = dict(FUNCTIONS)
        root.update(math=xacro.NameSpace(), xacro=xacro.NameSpace(), load_yaml=self._load_yaml)
        root["math"].update({name: getattr(math, name) for name in _MATH})
        root["xacro"].update(own)
        return root

    def refuse(self, what, reason, expression):
        """The XacroExpressionError for ``expression`` (recorded: xacro may swallow it, we do not)."""
        error = XacroExpressionError(f"xacro {what} {expression}{self._line(expression)}: {reason}; {_WHAT}",
                                     path=self.path,
                                     fix="expand the file with xacro yourself only if you trust it, and give the URDF")
        self.refusals.append(error)
        return error

    def _line(self, expression):
        """`` (line N of FILE)`` where ``expression`` is written (xml.dom keeps no line numbers)."""
        xacro = self.xacro
        # Only files inside the roots are read for this (a refused include is on xacro's file stack).
        files = [f for f in [*(xacro.filestack or [])[::-1], *xacro.all_includes, self.path]
                 if f and self.resolver.inside(f)]
        for candidate in (expression, expression[2:-1] if expression[:2] in ("${", "$(") else expression):
            for name in dict.fromkeys(files):
                try:
                    with open(name, encoding="utf-8", errors="replace") as handle:
                        text = handle.read()
                except OSError:
                    continue
                at = text.find(candidate)
                if at >= 0:
                    where = "" if os.path.abspath(name) == os.path.abspath(self.path) else f" of {name}"
                    return f" (line {text.count(chr(10), 0, at) + 1}{where})"
        return ""

    def _namespace(self, value):
        return isinstance(value, (self.xacro.YamlDictWrapper, self.xacro.NameSpace))

    def safe_eval(self, expression, symbols, locals=None):
        """xacro.safe_eval's replacement: ``${expression}`` against the property table ``symbols``."""
        try:
            return evaluate(expression, symbols.__getitem__, callables=self.callables, namespaces=self._namespace)
        except _Refused as exc:
            raise self.refuse("expression", str(exc), "${" + expression.strip() + "}") from None

    def eval_substitution(self, expression, context):
        """``$(eval expression)``: the same evaluator, with ``arg``, ``dirname`` and math (never Python's eval)."""
        from xacro import substitution_args
        args = context.setdefault("arg", {})

        def arg(name):
            return substitution_args.convert_value(substitution_args._eval_arg(name, args=args), "auto")

        def dirname():
            return substitution_args._eval_dirname(context.get("filename"))

        names = {"true": True, "True": True, "false": False, "False": False, "arg": arg, "dirname": dirname}

        def lookup(name):
            if name in names:
                return names[name]
            return substitution_args.convert_value(args[name], "auto")
        try:
            return str(evaluate(expression, lookup, callables=(arg, dirname)))
        except _Refused as exc:
            raise self.refuse("substitution", str(exc), f"$(eval {expression})") from None

    def env(self, name, default=None, *, optional=False, written=None):
        """``$(env name)`` (``optional``: ``$(optenv name default)``), read only with ``allow_env``."""
        if self.allow_env:
            if optional:
                return os.environ.get(name, default or "")
            if name not in os.environ:
                from xacro.substitution_args import SubstitutionException
                raise SubstitutionException(f"environment variable {name!r} is not set")
            return os.environ[name]
        if optional:
            self.warnings.append(f"xacro $(optenv {name}): the environment is not read: the default "
                                 f"{default or ''!r} is used — give {option('allow_env')} to read it")
            return default or ""
        written = written or f"$(env {name})"
        error = XacroExpressionError(f"xacro {written}{self._line(written)}: reads the environment, "
                                     "which a robot file may not without permission", path=self.path,
                                     fix=f"give {option('allow_env')} if you trust the file")
        self.refusals.append(error)
        raise error

    def find(self, package):
        folder = self.resolver.find_package(package)
        if folder is None:
            tried = self.resolver.log[(f"$(find {package})", None)].tried
            looked = f" (tried: {'; '.join(tried)})" if tried else \
                f" (no {option('package')} for it, no folder of that name or package.xml naming it above the model)"
            raise MassPropsError(f"$(find {package}): package {package!r} not found{looked}",
                                 path=self.path, fix=f"give {option('package')} for {package!r}")
        return folder

    def filename(self, filename_spec, original):
        """Where an include or load_yaml names (``package://`` through the resolver), confined to the roots."""
        if "://" in filename_spec:
            resolution = self.resolver.resolve(filename_spec)
            if resolution.by == "refused":
                from .resolve import OutsideRootError
                error = OutsideRootError(f"xacro file {filename_spec!r}: {resolution.tried[0]}", path=self.path,
                                         fix=resolution.fix)
                self.refusals.append(error)
                raise error
            if resolution.path is not None:
                return resolution.path
        return original(filename_spec)

    def confined(self, filename, what):
        try:
            return self.resolver.confine(filename, f"xacro {what} {filename!r}")
        except MassPropsError as error:
            self.refusals.append(error)
            raise

    def load_yaml(self, filename):
        if not isinstance(filename, str):
            raise _Refused("load_yaml takes a file name")
        path = self.confined(self.xacro.abs_filename_spec(filename), "load_yaml")
        return self._original_load_yaml(path)

    @contextmanager
    def hooked(self):
        """xacro's evaluation, file and environment hooks replaced by ours; all restored on exit."""
        xacro = self.xacro
        from xacro import substitution_args as sa
        original_parse, original_abs = xacro.parse, xacro.abs_filename_spec
        self._original_load_yaml = xacro.load_yaml

        def parse(inp, filename=None):
            if inp is None and filename is not None and os.path.abspath(filename) != os.path.abspath(self.path):
                self.confined(os.path.join(xacro.root_dir, filename), "include")
            return original_parse(inp, filename)

        def cwd_or_extension(text):
            if text.strip() == "$(cwd)" and not self.allow_env:
                return self.env("PWD", written="$(cwd)")
            return original_extension(text)

        original_extension = xacro.eval_extension
        replaced = [(xacro, "safe_eval", self.safe_eval), (xacro, "_global_symbols", self.root),
                    (xacro, "parse", parse), (xacro, "eval_extension", cwd_or_extension),
                    (xacro, "abs_filename_spec", lambda spec: self.filename(spec, original_abs)),
                    (sa, "_eval", self.eval_substitution), (sa, "_eval_find", self.find),
                    (sa, "_eval_env", self.env),
                    (sa, "_eval_optenv", lambda name, default="": self.env(name, default, optional=True))]
        saved = [(module, name, getattr(module, name)) for module, name, _ in replaced]
        try:
            for module, name, value in replaced:
                setattr(module, name, value)
            yield
        finally:
            for module, name, value in saved:
                setattr(module, name, value)


def _inner(exc):
    """The first MassPropsError in the chain of xacro's wrapped exceptions, or None."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, MassPropsError):
            return exc
        seen.add(id(exc))
        exc = getattr(exc, "exc", None) or exc.__cause__ or exc.__context__
    return None


_CLASS = re.compile(r"<class '[\w.]+'>:?\s*")
_UNDEFINED_ARG = re.compile(r"Undefined substitution argument\s*(\S*)")


def _failed(exc, path):
    """xacro's failure as one line for the shell: no Python class names, the option that fixes it where known."""
    detail = _CLASS.sub("", " ".join(str(exc).split())).strip()
    inner = getattr(exc, "exc", None)
    argument = _UNDEFINED_ARG.match(detail)
    if argument:
        name = argument.group(1) or " ".join(str(inner or "").split()) or "NAME"
        name = name.strip("'\" ")
        return RobotFormatError(f"xacro: the argument {name!r} has no value (no default in the file)", path=path,
                                fix=f"give {option('xacro_arg')} with NAME {name}")
    if not detail:
        detail = _CLASS.sub("", " ".join(str(inner or "").split())).strip() or "it stopped with no message"
    return RobotFormatError(f"xacro failed: {detail}", path=path, fix="run `xacro FILE` to see the full message")


def expand_xacro(path, resolver, mappings=None, *, allow_env=False, includes=None):
    """``(URDF bytes, warnings)``: the ``.xacro`` file expanded, its expressions evaluated as data only.

    ``includes``, a list, receives the files the expansion included (for :mod:`massprops.robot.xacro_sources`).

    Raises
    ------
    XacroExpressionError
        An expression outside what is evaluated (see the module docstring), or ``$(env)`` without ``allow_env``.
    OutsideRootError
        An include, ``load_yaml`` or ``package://`` outside the model's roots.
    RobotFormatError
        xacro could not expand the file.
    """
    try:
        import xacro  # noqa: F401 - the package does the XML work
    except ImportError:
        raise OptionError("reading .xacro needs the xacro package, which is not installed", path=path,
                          fix='pip install "massprops[robot]" (or expand it first: xacro FILE > robot.urdf)') from None
    expansion = _Expansion(path, resolver, allow_env)
    saved_includes, xacro.all_includes = xacro.all_includes, []
    with expansion.hooked(), contextlib.redirect_stderr(io.StringIO()):
        try:
            doc = xacro.process_file(os.fspath(path), mappings=dict(mappings or {}))
            if includes is not None:
                includes.extend(os.path.abspath(f) for f in xacro.all_includes)
        except Exception as exc:  # noqa: BLE001 - xacro raises many kinds; the edge wants one line
            if expansion.refusals:
                raise expansion.refusals[0] from None
            inner = _inner(exc)
            if inner is not None:
                raise inner from None
            raise _failed(exc, path) from None
        finally:
            xacro.all_includes = saved_includes
    if expansion.refusals:                  # swallowed by xacro (an optional include): refused all the same
        raise expansion.refusals[0]
    return doc.toxml(encoding="utf-8"), tuple(dict.fromkeys(expansion.warnings))
