"""One way to read a config or result file: typed classes, checked by msgspec.

Every TOML and JSON the project reads (rig, damper spec, scenario, FIT/DIAG/RIDE.json) is
described by the dataclasses that hold it, with constraints written once on the field's
type (`Positive`, `Fraction`, `Literal[...]`, ...). `convert` checks a parsed document
against that class and turns any problem into one ConfigError line naming the file, the
dotted key, what was expected and what was found. A writer that builds the same classes
gets its file's JSON from `to_json` (DIAG.json), so writer and readers share one shape.

msgspec, not pydantic: it is strict by default (a quoted "false" is not a bool, 6.5 is
not an int, "1e-3" is not a number), it converts into the plain frozen dataclasses the
model already uses (no second class hierarchy to keep in step), its errors carry the
path of the bad value, and it is one small compiled package with no dependencies.
msgspec ignores unknown keys of a dataclass, and TOML allows inf and nan; both are
refused here before conversion, because a typo'd key silently falling back to its
default is the mistake a config reader exists to catch.
"""

from __future__ import annotations

import datetime as dt
import difflib
import json
import math
import re
import tomllib
from dataclasses import MISSING, Field, fields, is_dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, SupportsFloat, TypeVar, Union

import msgspec
from msgspec import inspect as mi

from shockdyno.errors import ConfigError
from shockdyno.result_files import special_file, what_bytes_are

T = TypeVar("T")
# A TOML table or JSON object as tomllib and json give it: its values are untyped (Any)
# until `convert` checks them against a dataclass.
Table = dict[str, Any]
# Any in this module: a file's parsed TOML or JSON before it is checked (tomllib, json and
# msgspec give Any), and the type forms msgspec checks a value against (_py).

# Constraints written once, on the type. (msgspec has no "finite": non-finite numbers
# are refused for every field before conversion.)
Positive = Annotated[float, msgspec.Meta(gt=0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0)]
Fraction = Annotated[float, msgspec.Meta(ge=0, lt=1)]
NonEmpty = Annotated[str, msgspec.Meta(min_length=1)]
Port = Annotated[int, msgspec.Meta(ge=0, le=65535)]

_AT = re.compile(r" - at `(?P<path>[^`]*)`$")
_KEY_IN = re.compile(r" - at `key` in `(?P<path>[^`]*)`$")


def fail(source: str, key: str, text: str) -> ConfigError:
    """The one-line error: `source: key: text` (no key: `source: text`)."""
    key = key.replace("\n", "\\n").replace("\r", "\\r")  # one line, whatever the key holds
    key = key if len(key) <= 80 else key[:77] + "..."
    return ConfigError(f"{source}: {key}: {text}" if key else f"{source}: {text}")


def dotted(at: str, key: object) -> str:
    """`at.key`, the key quoted where it is empty or holds a dot or a space (TOML's own
    quoting): `rig."a.b"` is not `rig.a.b`."""
    k = str(key)
    if not re.fullmatch(r"[A-Za-z0-9_-]+", k):
        k = json.dumps(k, ensure_ascii=False)
    return f"{at}.{k}" if at else k


def parse_toml(text: str, source: str) -> Table:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML ({exc})") from None
    except RecursionError:
        raise ConfigError(f"{source}: nested too deeply to be a config file") from None


def read_text(path: Path, missing: str) -> str:
    """A config file's text; `missing` is the message when there is none ("rig file
    not found: x.toml")."""
    try:
        if path.is_dir():
            raise ConfigError(f"{path}: is a folder, not a file")
        if special_file(path):
            raise ConfigError(f"{path}: not a regular file")
        return path.read_text(encoding="utf-8-sig")  # an editor's BOM is not a TOML error
    except FileNotFoundError:
        raise ConfigError(missing) from None
    except UnicodeDecodeError:
        what = what_bytes_are(path.read_bytes()[:64])  # a recording given as a config
        text = "is not UTF-8 text" if what == "not JSON" else f"is {what}, not a text file"
        raise ConfigError(f"{path}: {text}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read ({exc})") from None


def read_toml(path: Path, missing: str) -> tuple[str, Table]:
    text = read_text(path, missing)
    return text, parse_toml(text, str(path))


def convert(data: Any, cls: type[T], source: str, at: str = "", *, unknown_keys: bool = False) -> T:
    """`data` (a parsed TOML/JSON value) as a `cls`, or one ConfigError line naming
    `source` and the dotted key below `at`.

    `unknown_keys`: allow keys `cls` does not name, and skip them. For result files
    (FIT/DIAG/RIDE.json), which gain keys over versions: an older reader must still read
    a newer file. Non-finite numbers are refused in both: a result holds null for one,
    so a NaN in it was not written by this project."""
    info = mi.type_info(cls)
    try:
        _check_keys(data, info, source, at, unknown_keys)
        return msgspec.convert(data, cls, strict=True)
    except msgspec.ValidationError as exc:
        raise _explain(str(exc), data, info, source, at) from None
    except RecursionError:
        raise fail(source, at, "nested too deeply") from None


# A field's metadata: the key is left out of the file while the field holds its default
# (a key its writer has only ever written when it says something, e.g. a parameter's
# `fixed`, a figure's `plot`); a reader gets the default back.
OMITTED_AT_DEFAULT = {"omitted_at_default": True}


def to_json(doc: object) -> Any:  # Any: a JSON value, for json.dumps
    """A typed document (dataclasses, tuples, dicts, numbers, text) as the JSON value its
    file holds, for `json.dumps`: the keys in their fields' order, a field marked
    OMITTED_AT_DEFAULT left out at its default. `convert` reads it back."""
    if is_dataclass(doc) and not isinstance(doc, type):
        out = {}
        for f in fields(doc):
            value = getattr(doc, f.name)
            if f.metadata.get("omitted_at_default") and value == _default(f):
                continue
            out[f.name] = to_json(value)
        return out
    if isinstance(doc, list | tuple):
        return [to_json(v) for v in doc]
    if isinstance(doc, dict):
        return {k: to_json(v) for k, v in doc.items()}
    return doc


def finite_or_none(x: SupportsFloat | None) -> float | None:
    """A number as a result file holds it: null when not finite or absent (JSON has no
    NaN, and a result file refuses one)."""
    return float(x) if x is not None and math.isfinite(x) else None


def _default(f: Field[Any]) -> Any:
    return f.default_factory() if f.default_factory is not MISSING else f.default


def check(obj: object, source: str) -> None:
    """`obj` (a dataclass built in code, e.g. a spec with fitted values) against the
    constraints of its own field types, as its file would be read."""
    convert(msgspec.to_builtins(obj), type(obj), source)


def expected(t: mi.Type) -> str:
    """What a value of this type looks like, in a user's words."""
    if isinstance(t, mi.UnionType):
        inner = [x for x in t.types if not isinstance(x, mi.NoneType)]
        return " or ".join(expected(x) for x in inner)
    if isinstance(t, mi.BoolType):
        return "true or false (no quotes)"
    if isinstance(t, mi.IntType | mi.FloatType):
        word = "a whole number" if isinstance(t, mi.IntType) else "a number"
        if t.ge is not None and t.le is not None:
            return f"{word} from {t.ge:g} to {t.le:g}"
        if t.ge is not None and t.lt is not None:
            return f"{word} from {t.ge:g} up to (not including) {t.lt:g}"
        bounds = [
            f"{op} {v:g}"
            for op, v in ((">", t.gt), (">=", t.ge), ("<", t.lt), ("<=", t.le))
            if v is not None
        ]
        return " ".join([word, *bounds])
    if isinstance(t, mi.StrType):
        return "non-empty text in quotes" if t.min_length else "text in quotes"
    if isinstance(t, mi.LiteralType):
        return "one of " + ", ".join(str(v) for v in t.values)
    if isinstance(t, mi.TupleType):
        return "a list [" + ", ".join(expected(x) for x in t.item_types) + "]"
    if isinstance(t, mi.ListType | mi.SetType | mi.FrozenSetType | mi.VarTupleType):
        return "a list"
    if isinstance(t, mi.DictType | mi.DataclassType | mi.StructType | mi.TypedDictType):
        return "a table"
    return "a value of another kind"


# -- the two checks msgspec does not make --------------------------------------------


def _fields(t: mi.Type) -> dict[str, mi.Field] | None:
    if isinstance(t, mi.DataclassType | mi.StructType):
        return {f.encode_name: f for f in t.fields}
    return None


def _check_keys(data: Any, t: mi.Type, source: str, at: str, unknown_ok: bool = False) -> None:
    """Unknown keys (with the nearest known one; unless `unknown_ok`) and non-finite
    numbers, anywhere."""
    if isinstance(data, float) and not math.isfinite(data):
        raise fail(source, at, f"must be a finite number, got {data}")
    if isinstance(t, mi.UnionType):
        inner = [x for x in t.types if not isinstance(x, mi.NoneType)]
        t = inner[0] if len(inner) == 1 else mi.AnyType()
    known = _fields(t)
    if isinstance(data, dict):
        for key, value in data.items():
            where = dotted(at, key)
            if known is not None:
                if key not in known:
                    if unknown_ok:
                        continue
                    near = difflib.get_close_matches(str(key), known, n=1)
                    hint = f" (did you mean {near[0]}?)" if near else ""
                    raise fail(source, where, f"unknown key{hint}")
                _check_keys(value, known[key].type, source, where, unknown_ok)
            elif isinstance(t, mi.DictType):
                _check_keys(value, t.value_type, source, where, unknown_ok)
            else:
                _check_keys(value, mi.AnyType(), source, where, unknown_ok)
    elif isinstance(data, list):
        item: mi.Type = mi.AnyType()
        if isinstance(t, mi.ListType | mi.VarTupleType):
            item = t.item_type
        for i, value in enumerate(data):
            tt = t.item_types[i] if isinstance(t, mi.TupleType) and i < len(t.item_types) else item
            _check_keys(value, tt, source, f"{at}[{i}]", unknown_ok)


# -- msgspec's message in the user's words ---------------------------------------------


def _steps(path: str) -> list[str | int]:
    """'$.a.b[2].c' -> ['a', 'b', 2, 'c']; a dict's key, which msgspec does not name
    ('$.terms[...]'), is '...'."""
    out: list[str | int] = []
    for name, index, key in re.findall(r"\.([^.\[]+)|\[(\d+)\]|\[(\.\.\.)\]", path[1:]):
        out.append(name or key or int(index))
    return out


def _py(t: mi.Type) -> Any:  # Any: a type form built at run time, for msgspec.convert
    """The Python type msgspec would check a value against (to find a dict's bad key)."""
    if isinstance(t, mi.DataclassType | mi.StructType):
        return t.cls
    if isinstance(t, mi.DictType):
        return dict[_py(t.key_type), _py(t.value_type)]  # type: ignore[misc]
    if isinstance(t, mi.ListType):
        return list[_py(t.item_type)]  # type: ignore[misc]
    if isinstance(t, mi.UnionType):
        return Union[tuple(_py(x) for x in t.types)]  # noqa: UP007 (built at run time)
    if isinstance(t, mi.IntType | mi.FloatType):
        kind = int if isinstance(t, mi.IntType) else float
        bounds = {k: getattr(t, k) for k in ("gt", "ge", "lt", "le") if getattr(t, k) is not None}
        return Annotated[kind, msgspec.Meta(**bounds)] if bounds else kind
    if isinstance(t, mi.StrType) and t.min_length:
        return Annotated[str, msgspec.Meta(min_length=t.min_length)]
    if isinstance(t, mi.LiteralType):
        return Literal[tuple(t.values)]
    simple = {mi.BoolType: bool, mi.StrType: str, mi.NoneType: type(None)}
    return simple.get(type(t), Any)


def _bad_key(data: dict[Any, Any], value_type: mi.Type) -> object:
    """The first key of `data` whose value fails its type."""
    py = _py(value_type)
    for key, value in data.items():
        try:
            msgspec.convert(value, py, strict=True)
        except msgspec.ValidationError:
            return key
    return "..."


def _walk(data: Any, t: mi.Type, steps: list[str | int]) -> tuple[Any, mi.Type, list[str | int]]:
    """The value and type at a path, and the path with each dict's bad key named."""
    named: list[str | int] = []
    for s in steps:
        if isinstance(t, mi.UnionType):
            inner = [x for x in t.types if not isinstance(x, mi.NoneType)]
            t = inner[0] if len(inner) == 1 else mi.AnyType()
        known = _fields(t)
        step: object = s
        if known is not None and isinstance(s, str) and s in known:
            t = known[s].type
        elif isinstance(t, mi.DictType):
            if s == "..." and isinstance(data, dict):
                step = _bad_key(data, t.value_type)
            t = t.value_type
            named.append(_Key(step))  # a table's key, whatever its type: `codes.7`
            data = data.get(step) if isinstance(data, dict) else None
            continue
        elif isinstance(t, mi.ListType | mi.VarTupleType):
            t = t.item_type
        elif isinstance(t, mi.TupleType) and isinstance(s, int) and s < len(t.item_types):
            t = t.item_types[s]
        else:
            t = mi.AnyType()
        named.append(s)  # step is s here: only a dict's key is renamed (above)
        try:
            data = data[step]
        except (KeyError, IndexError, TypeError):
            data = None
    return data, t, named


class _Key(str):
    """A table's key on a path (not a list's index, even when it reads as a number)."""


def _dotted(steps: list[str | int], at: str) -> str:
    out = at
    for s in steps:
        out = f"{out}[{s}]" if isinstance(s, int) and not isinstance(s, _Key) else dotted(out, s)
    return out


def shown(value: object) -> str:
    """A bad value as the user wrote it (TOML/JSON spelling: true, null), cut short."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, dt.date | dt.time):
        return value.isoformat()  # TOML's own date and time
    if isinstance(value, list):
        text = json.dumps(value, ensure_ascii=False, default=str)
    else:
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _explain(msg: str, data: Any, info: mi.Type, source: str, at: str) -> ConfigError:
    m = _KEY_IN.search(msg)
    if m:
        steps = _steps(m["path"])
        head = msg[: m.start()].removeprefix("Expected ")
        return fail(source, _dotted(steps, at), f"keys must be {head.strip('`')}s")
    m = _AT.search(msg)
    steps = _steps(m["path"]) if m else []
    text = msg[: m.start()] if m else msg
    value, t, steps = _walk(data, info, steps)
    miss = re.match(r"Object missing required field `([^`]+)`", text)
    if miss:
        return fail(source, _dotted([*steps, miss[1]], at), "missing")
    want = text if isinstance(t, mi.AnyType) else expected(t)
    return fail(source, _dotted(steps, at), f"must be {want}, got {shown(value)}")
