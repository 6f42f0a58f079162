"""Typed scenario configs: frozen dataclasses loaded from TOML and ``--set`` overrides.

A config is a tree of frozen dataclasses. Each field is declared with :func:`param`,
which records its allowed range or choices, its unit and a one-line description, so
that validation and error messages come from one place::

    @dataclass(frozen=True)
    class ReaderConfig:
        ptx_dbm: float = param(30.0, lo=-10.0, hi=36.0, unit="dBm", doc="conducted TX power")

:func:`load_config` merges, in order, the dataclass defaults, a TOML file and
``key.sub=value`` overrides (values parsed as TOML literals, bare words as strings),
then checks every key, type and range. Any mistake raises :class:`ConfigError` whose
message is one line naming the key, the bad value and what is allowed (with a
did-you-mean for misspelled keys). :func:`to_toml` writes the resolved config back as
TOML text (stored in every dataset's provenance).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import tomllib
import types
import typing
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, Literal

from rfsim.core.errors import ConfigError, UserError, did_you_mean
from rfsim.core.memo import PureCache

_META_KEY = "rfsim"


def param(
    default: Any,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    unit: str = "",
    doc: str = "",
) -> Any:
    """A dataclass field with a validated range, a unit and a description.

    Choices are expressed with ``Literal[...]`` types on the field itself.

    Parameters
    ----------
    default : object
        Default value (immutable: a tuple, not a list).
    lo, hi : float or None
        Bounds of numbers (and of every element of numeric tuples); None: unbounded.
    lo_open, hi_open : bool
        Make the bound strict.
    unit : str
        Unit shown in help and errors.
    doc : str
        One-line description.

    Returns
    -------
    dataclasses.Field
        The field.

    Raises
    ------
    TypeError
        For a mutable default (list, dict, set).
    """
    meta = {_META_KEY: {"lo": lo, "hi": hi, "lo_open": lo_open, "hi_open": hi_open,
                        "unit": unit, "doc": doc}}
    if isinstance(default, (list, dict, set)):
        raise TypeError("mutable defaults are not allowed; use a tuple")
    return dataclasses.field(default=default, metadata=meta)


def field_meta(f: dataclasses.Field) -> dict[str, Any]:
    """The :func:`param` metadata of a field (empty defaults if declared plainly).

    ``nonempty`` is true for a list field whose default is not empty: such a list may not
    be set to ``[]`` (a list that may be empty has the default ``()``).

    Parameters
    ----------
    f : dataclasses.Field
        The field.

    Returns
    -------
    dict of str to object
        ``lo``, ``hi``, ``lo_open``, ``hi_open``, ``unit``, ``doc``, ``nonempty``.
    """
    meta = f.metadata.get(_META_KEY, {"lo": None, "hi": None, "lo_open": False,
                                      "hi_open": False, "unit": "", "doc": ""})
    return {**meta, "nonempty": isinstance(f.default, tuple) and len(f.default) > 0}


# ----------------------------------------------------------------------------- checking


def _range_text(meta: Mapping[str, Any]) -> str:
    lo, hi = meta["lo"], meta["hi"]
    left = "(" if meta["lo_open"] else "["
    right = ")" if meta["hi_open"] else "]"
    lo_s = "-inf" if lo is None else f"{lo:g}"
    hi_s = "inf" if hi is None else f"{hi:g}"
    unit = f" {meta['unit']}" if meta["unit"] else ""
    return f"{left}{lo_s}, {hi_s}{right}{unit}"


def _check_range(key: str, value: float, meta: Mapping[str, Any], kind: str) -> None:
    lo, hi = meta["lo"], meta["hi"]
    if not math.isfinite(value):
        raise ConfigError(key, value, f"a finite {kind} in {_range_text(meta)}")
    bad = (lo is not None and (value < lo or (meta["lo_open"] and value == lo))) or (
        hi is not None and (value > hi or (meta["hi_open"] and value == hi)))
    if bad:
        article = "an" if kind[0] in "aeiou" else "a"
        raise ConfigError(key, value, f"{article} {kind} in {_range_text(meta)}")


def _coerce(key: str, value: Any, tp: Any, meta: Mapping[str, Any]) -> Any:
    """Check ``value`` against the annotation ``tp`` and return it in canonical form."""
    origin = typing.get_origin(tp)
    if origin is Literal:
        choices = typing.get_args(tp)
        if value in choices and type(value) is type(choices[choices.index(value)]):
            return value
        hint = did_you_mean(str(value), [str(c) for c in choices]) if isinstance(value, str) else ""
        allowed = "one of " + ", ".join(repr(c) for c in choices)
        raise ConfigError(key, value, allowed + hint)
    if origin in (types.UnionType, typing.Union):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None or value == "none":
            return None
        if len(args) != 1:
            raise TypeError(f"unsupported union type for {key}: {tp}")
        return _coerce(key, value, args[0], meta)
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(value, (list, tuple)):
            raise ConfigError(key, value, f"a list of {_type_name(args[0])}")
        if len(args) == 2 and args[1] is Ellipsis:
            if not value and meta.get("nonempty"):
                raise ConfigError(key, value, f"a non-empty list of {_type_name(args[0])}")
            items = [_coerce(f"{key}[{i}]", v, args[0], meta) for i, v in enumerate(value)]
        else:
            if len(value) != len(args):
                raise ConfigError(key, value, f"a list of exactly {len(args)} values")
            items = [_coerce(f"{key}[{i}]", v, a, meta) for i, (v, a) in enumerate(zip(value, args))]
        return tuple(items)
    if dataclasses.is_dataclass(tp):
        if isinstance(value, tp):
            return value
        if not isinstance(value, Mapping):
            raise ConfigError(key, value, f"a table of {tp.__name__} settings")
        return from_dict(tp, value, prefix=key)
    if tp is bool:
        if isinstance(value, bool):
            return value
        raise ConfigError(key, value, "true or false")
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            else:
                raise ConfigError(key, value, f"an integer in {_range_text(meta)}")
        _check_range(key, value, meta, "integer")
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(key, value, f"a number in {_range_text(meta)}")
        value = float(value)
        _check_range(key, value, meta, "number")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(key, value, "a string")
        return value
    raise TypeError(f"unsupported config field type for {key}: {tp!r}")


@functools.lru_cache(maxsize=None)
def type_hints(cls: type) -> dict[str, Any]:
    """``typing.get_type_hints(cls)``, computed once per class (it dominates config loading)."""
    return typing.get_type_hints(cls)


def field_at(cls: type, key: str) -> tuple[dataclasses.Field, Any] | None:
    """(field, type) of the dotted ``key`` in the config class ``cls``.

    Parameters
    ----------
    cls : type
        A config dataclass.
    key : str
        Dotted key, e.g. ``"reader.ptx_dbm"``.

    Returns
    -------
    tuple of (dataclasses.Field, type) or None
        The field and its type hint; None if there is none.
    """
    parts = key.split(".")
    for j, part in enumerate(parts):
        if not dataclasses.is_dataclass(cls):
            return None
        fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
        if part not in fields:
            return None
        hint = type_hints(cls)[part]
        if j == len(parts) - 1:
            return fields[part], hint
        cls = hint
    return None


def check_value(cls: type, key: str, value: Any) -> Any:
    """Check one value of the dotted ``key`` against its field's type, range or choices.

    The per-field checks of :func:`from_dict` without the cross-field checks of the
    configs' ``__post_init__``.

    Parameters
    ----------
    cls : type
        A config dataclass.
    key : str
        Dotted key.
    value : object
        The value as given.

    Returns
    -------
    object
        The value in canonical form.

    Raises
    ------
    ConfigError
        For an unknown key or a value its field does not allow.
    """
    found = field_at(cls, key)
    if found is None:
        raise ConfigError(key, value, "a known config key (see 'rfsim config SCENARIO --keys')")
    f, hint = found
    return _coerce(key, value, hint, field_meta(f))


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", str(tp))


def from_dict(cls: type, data: Mapping[str, Any], *, prefix: str = "") -> Any:
    """Build the dataclass ``cls`` from a (nested) mapping, validating everything.

    Missing keys take the defaults.

    Parameters
    ----------
    cls : type
        A config dataclass.
    data : mapping
        Nested values (e.g. parsed TOML).
    prefix : str
        Dotted key of ``cls`` in its parent, for error messages.

    Returns
    -------
    object
        An instance of ``cls``.

    Raises
    ------
    ConfigError
        Unknown keys, wrong types and out-of-range values, naming the dotted key.
    """
    hints = type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    kwargs: dict[str, Any] = {}
    for name, value in data.items():
        key = f"{prefix}.{name}" if prefix else name
        if name not in fields:
            raise ConfigError(key, value, "a known key" + _known_keys_hint(name, fields))
        default = fields[name].default
        if isinstance(value, Mapping) and dataclasses.is_dataclass(default):
            value = _deep_merge(to_dict(default), value)
        kwargs[name] = _coerce(key, value, hints[name], field_meta(fields[name]))
    try:
        return cls(**kwargs)
    except ConfigError as err:
        if prefix and not err.key.startswith(prefix + "."):
            raise ConfigError(f"{prefix}.{err.key}", err.value, err.allowed) from None
        raise


def _deep_merge(base: Mapping[str, Any], top: Mapping[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in top.items():
        out[k] = _deep_merge(out[k], v) if isinstance(v, Mapping) and isinstance(out.get(k), Mapping) else v
    return out


def _known_keys_hint(name: str, fields: Mapping[str, Any]) -> str:
    hint = did_you_mean(name, fields)
    return hint if hint else f" (one of {', '.join(sorted(fields))})"


def check_fields(config: Any, prefix: str = "") -> None:
    """Validate the fields of a config built in code, from its ``__post_init__``.

    Same per-field checks as :func:`from_dict` (types, ranges, choices), with keys named
    ``prefix.field``; values are stored in canonical form (e.g. ints as floats).

    Parameters
    ----------
    config : object
        The config dataclass instance (updated in place).
    prefix : str
        Dotted key of the config, for error messages.

    Raises
    ------
    ConfigError
        For a value its field does not allow.
    """
    cls = type(config)
    fields = dataclasses.fields(config)
    values = tuple([getattr(config, f.name) for f in fields])
    try:  # the verdict of these values, checked before (compared by value and type)
        kept = CHECKED_FIELDS(cls, prefix, values, tuple(map(type, values)))
    except TypeError:  # an unhashable value (an array): checked field by field
        kept = _kept_fields(cls, prefix, values)
    for f, value, same in zip(fields, values, kept):
        if not same:  # stored in canonical form (e.g. an int as a float): the value converted again
            object.__setattr__(config, f.name, _coerce(f"{prefix}.{f.name}" if prefix else f.name, value,
                                                       type_hints(cls)[f.name], field_meta(f)))


def _kept_fields(cls: type, prefix: str, values: tuple, types_: tuple | None = None) -> tuple[bool, ...]:
    """The per-field checks of :func:`check_fields` on the field values ``values`` of the config
    class ``cls`` (``types_``: their types, a part of the memo's key only): raises the first
    field's ConfigError, else per field whether its value is kept as given (True) or stored in
    canonical form (False: :func:`_coerce` returned another object)."""
    hints = type_hints(cls)
    out = []
    for f, value in zip(dataclasses.fields(cls), values):
        key = f"{prefix}.{f.name}" if prefix else f.name
        out.append(_coerce(key, value, hints[f.name], field_meta(f)) is value)
    return tuple(out)


#: :func:`_kept_fields` by config class, prefix, field values and their types: a pure function
#: of them (a config's checks read its class's annotations and field metadata only), so that a
#: config built again with the same values (a tag per trial from one TagConfig) is checked once.
CHECKED_FIELDS = PureCache(_kept_fields, 256)


def validate(config: Any) -> Any:
    """Re-check an already built config (e.g. one created in Python code).

    Parameters
    ----------
    config : object
        A config dataclass instance.

    Returns
    -------
    object
        A new, validated instance.

    Raises
    ------
    ConfigError
        For a value its field does not allow.
    """
    return from_dict(type(config), to_dict(config))


# ----------------------------------------------------------------------------- overrides


def parse_override(text: str) -> tuple[list[str], Any]:
    """Split ``"a.b=value"`` into the key path and the parsed value.

    The value is read as a TOML literal (``30``, ``1.5e-6``, ``true``, ``[1, 2]``,
    ``"text"``); anything that is not valid TOML is taken as a bare string.

    Parameters
    ----------
    text : str
        A ``--set`` argument.

    Returns
    -------
    path : list of str
        The key's parts, e.g. ``["a", "b"]``.
    value : object
        The parsed value.

    Raises
    ------
    UserError
        Without ``=`` or with an empty key part.
    """
    if "=" not in text:
        raise UserError(f"--set {text!r}: expected KEY=VALUE, e.g. --set reader.ptx_dbm=30")
    key, raw = text.split("=", 1)
    key, raw = key.strip(), raw.strip()
    parts = key.split(".")
    if not key or any(not p for p in parts):
        raise UserError(f"--set {text!r}: the key must be dotted names, e.g. reader.ptx_dbm")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return parts, value


def _set_nested(data: dict[str, Any], path: list[str], value: Any) -> None:
    node = data
    for part in path[:-1]:
        child = node.setdefault(part, {})
        if not isinstance(child, dict):
            raise ConfigError(".".join(path[:-1]), child, "a table (it is a plain value)")
        node = child
    node[path[-1]] = value


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file.

    Parameters
    ----------
    path : str or pathlib.Path
        The file.

    Returns
    -------
    dict of str to object
        The parsed TOML.

    Raises
    ------
    UserError
        One line, for a missing, unreadable, non-UTF-8 or malformed file.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as err:
        raise UserError(f"config file {str(p)!r}: cannot be read ({err.strerror})") from None
    except UnicodeDecodeError as err:
        raise UserError(f"config file {str(p)!r}: not UTF-8 text, so not TOML (byte {err.start} "
                        f"is {err.object[err.start:err.start + 1]!r})") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise UserError(f"config file {str(p)!r}: not valid TOML ({err})") from None


def load_config(cls: type, toml_path: str | Path | None = None,
                overrides: Iterable[str] = ()) -> Any:
    """Defaults ← TOML file ← ``--set`` overrides, validated into ``cls``.

    Parameters
    ----------
    cls : type
        A config dataclass.
    toml_path : str or pathlib.Path or None
        TOML file (None: defaults only).
    overrides : iterable of str
        ``KEY=VALUE`` overrides, applied in order.

    Returns
    -------
    object
        An instance of ``cls``.

    Raises
    ------
    UserError
        For a bad file or override (:class:`ConfigError` for a bad value).
    """
    data: dict[str, Any] = read_toml(toml_path) if toml_path is not None else {}
    for text in overrides:
        path, value = parse_override(text)
        _set_nested(data, path, value)
    return from_dict(cls, data)


# ----------------------------------------------------------------------------- output


def to_dict(config: Any) -> dict[str, Any]:
    """Nested plain-dict view of a config (tuples stay tuples, None stays None).

    Parameters
    ----------
    config : object
        A config dataclass instance.

    Returns
    -------
    dict of str to object
        The values, nested configs as dicts.
    """
    out: dict[str, Any] = {}
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        out[f.name] = to_dict(value) if dataclasses.is_dataclass(value) else value
    return out


def toml_value(value: Any) -> str:
    """One value as TOML text (``"none"`` for None).

    Parameters
    ----------
    value : bool, int, float, str, tuple, list or None
        The value.

    Returns
    -------
    str
        TOML literal.

    Raises
    ------
    TypeError
        For a value TOML cannot hold.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if value is None:
        return '"none"'
    raise TypeError(f"cannot write {value!r} as TOML")


def to_toml(config: Any) -> str:
    """The resolved config as TOML text (round-trips through :func:`load_config`).

    Parameters
    ----------
    config : object
        A config dataclass instance.

    Returns
    -------
    str
        TOML text.
    """
    lines: list[str] = []

    def emit(d: Mapping[str, Any], table: str) -> None:
        scalars = {k: v for k, v in d.items() if not isinstance(v, dict)}
        tables = {k: v for k, v in d.items() if isinstance(v, dict)}
        if table and scalars:
            lines.append(f"[{table}]")
        for k, v in scalars.items():
            lines.append(f"{k} = {toml_value(v)}")
        if scalars:
            lines.append("")
        for k, v in tables.items():
            emit(v, f"{table}.{k}" if table else k)

    emit(to_dict(config), "")
    return "\n".join(lines).rstrip() + "\n"


def describe(cls: type, prefix: str = "", defaults: Any = None) -> list[tuple[str, str, str, str]]:
    """(key, default, allowed, description) rows for help output.

    Parameters
    ----------
    cls : type
        A config dataclass.
    prefix : str
        Dotted key of ``cls``.
    defaults : object or None
        The instance whose values are the defaults (a nested config's default in its parent,
        which may differ from the nested class's own defaults); None: the class defaults.

    Returns
    -------
    list of tuple of str
        One row per leaf key.
    """
    rows = []
    hints = type_hints(cls)
    for f in dataclasses.fields(cls):
        key = f"{prefix}.{f.name}" if prefix else f.name
        tp = hints[f.name]
        value = f.default if defaults is None else getattr(defaults, f.name)
        if dataclasses.is_dataclass(tp):
            rows.extend(describe(tp, key, value if dataclasses.is_dataclass(value) else None))
            continue
        meta = field_meta(f)
        if typing.get_origin(tp) is Literal:
            allowed = " | ".join(repr(c) for c in typing.get_args(tp))
        elif tp in (int, float):
            allowed = _range_text(meta)
        else:
            allowed = _type_name(tp)
        rows.append((key, toml_value(value), allowed, meta["doc"]))
    return rows


__all__ = [
    "param",
    "field_meta",
    "from_dict",
    "validate",
    "check_fields",
    "check_value",
    "field_at",
    "type_hints",
    "parse_override",
    "read_toml",
    "load_config",
    "to_dict",
    "to_toml",
    "toml_value",
    "describe",
]
