"""Every input file through one mechanism: the strict YAML reader (`swarm.files.read_yaml`), a
pydantic model per kind of file, and one translation of pydantic's errors into the project's one
line, `FILE: KEY.PATH: found X, expected Y` (`InputError`).

```python
header = load_model("maps/test_small.yaml", MapFile, "map YAML file")  # read strictly, then validate
profile = validate(ProfileFile, data, "planners/x.yaml")     # InputError on the first problem
```

Models subclass `InputModel`: unknown keys refused, no type coercion, no NaN or infinities, and an
int field takes an integer-valued float, so `iterations: 2e4` (a float in YAML 1.2) reads as 20000
while `12.5` is refused.
"""

from __future__ import annotations

import functools
import math
import os
import re
import types
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Literal, TypeVar, Union, get_args, get_origin

from pydantic import BaseModel, ConfigDict, PlainValidator, ValidationError, WithJsonSchema, model_validator
from pydantic_core import PydanticCustomError

from swarm.errors import InputError
from swarm.files import read_yaml

Parts = list[str | int]
M = TypeVar("M", bound=BaseModel)


def _whole(value: object) -> object:
    """An integer-valued finite float (`2e4`, `20.0`) as an int; anything else as it is."""
    if isinstance(value, float) and math.isfinite(value) and value.is_integer():
        return int(value)
    return value


class InputModel(BaseModel):
    """Base of every input file's model: unknown keys refused, types as written (strict), finite
    numbers; an int field also takes an integer-valued float, as YAML 1.2 reads `2e4`."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _whole_numbers(cls, data: object) -> object:
        if not isinstance(data, dict):
            return data
        ints = _int_fields(cls)
        return {k: _whole(v) if k in ints else v for k, v in data.items()}


@functools.cache
def _int_fields(model: type[BaseModel]) -> frozenset[str]:
    """Names of the fields of `model` that hold an int (or an optional int)."""
    return frozenset(name for name, f in model.model_fields.items() if _strip(f.annotation) is int)


def expected(expected: str, found: object = None, key: str | None = None) -> PydanticCustomError:
    """An error for a model's own checks whose message is what was expected; `found` and `key`
    refine the one-line report (`key`: a key below the failing location the error is about)."""
    ctx: dict[str, Any] = {"expected": expected}
    if found is not None:
        ctx["found"] = found
    if key is not None:
        ctx["key"] = key
    return PydanticCustomError("expected", "{expected}", ctx)


def _xy(value: object) -> tuple[float, float]:
    if (
        isinstance(value, list | tuple)
        and len(value) == 2
        and all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        return float(value[0]), float(value[1])
    raise expected("a pair [x, y] of finite numbers (metres)")


#: A point [x, y] in metres (a YAML list; strict pydantic would want a tuple).
XY = Annotated[
    tuple[float, float],
    PlainValidator(_xy),
    WithJsonSchema({"type": "array", "items": {"type": "number"}, "minItems": 2, "maxItems": 2}),
]


def tagged_classes(ann: Any) -> dict[str, type[BaseModel]]:
    """{tag: model} of a union of models told apart by a `type: Literal[...]` field ({} otherwise)."""
    out: dict[str, type[BaseModel]] = {}
    for arg in get_args(_strip(ann)):
        model = _strip(arg)
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            continue
        field = model.model_fields.get("type")
        if field is not None and get_origin(field.annotation) is Literal:
            out.update({tag: model for tag in get_args(field.annotation)})
    return out


def validate(model: type[M], data: object, source: str | os.PathLike[str], tag_words: str = "a type") -> M:
    """`model.model_validate(data)`; the first problem is an `InputError` against `source`."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        parts, found, expected = describe(first_error(exc, data, model), data, model, tag_words)
        raise InputError(source, key_path(parts), found, expected) from None


def first_error(exc: ValidationError, raw: object, root: type[BaseModel]) -> dict[str, Any]:
    """The error to report: the first, unless it comes from a union member the data was not
    meant for (a mapping tried as a string), when the first from the member it was meant for."""
    errors = exc.errors(include_url=False)
    return next((e for e in errors if _At(e["loc"], raw, root).on_track), errors[0])


def load_model(path: str | os.PathLike[str], model: type[M], what: str) -> M:
    """Read a YAML file strictly (`swarm.files.read_yaml`) and validate it against `model`."""
    return validate(model, read_yaml(path, what), path)


# --- walking the model alongside the data --------------------------------------------------------------


def _strip(ann: Any) -> Any:
    """The type under Annotated[...] and Optional[...]."""
    while True:
        origin = get_origin(ann)
        if origin is Annotated:
            ann = get_args(ann)[0]
            continue
        if origin in (Union, types.UnionType):
            args = [a for a in get_args(ann) if a is not type(None)]
            if len(args) == 1:
                ann = args[0]
                continue
        return ann


def kind_of(ann: Any) -> tuple[str, Any]:
    """('model', cls) | ('list', item) | ('dict', value) | ('tagged', None) | ('union', members) |
    ('leaf', type)."""
    ann = _strip(ann)
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return "model", ann
    origin = get_origin(ann)
    if origin is list:
        return "list", get_args(ann)[0]
    if origin is dict:
        return "dict", get_args(ann)[1]
    if origin in (Union, types.UnionType):
        args = [_strip(a) for a in get_args(ann)]
        if all(isinstance(a, type) and issubclass(a, BaseModel) and "type" in a.model_fields for a in args):
            return "tagged", None
        return "union", tuple(a for a in args if a is not type(None))
    return "leaf", ann


def _label(ann: Any) -> str:
    """The start of pydantic's label for a union member in an error location ('str', 'dict', 'X')."""
    origin = get_origin(ann) or ann
    return getattr(origin, "__name__", str(origin))


def _member_for(members: Sequence[Any], node: object) -> Any:
    """The union member the data `node` was meant for: the first whose type it has, else None."""
    for m in members:
        origin = get_origin(m) or m
        if isinstance(origin, type) and issubclass(origin, BaseModel):
            origin = dict
        if isinstance(origin, type) and isinstance(node, origin):
            return m
    return None


ABSENT = object()


def child_at(node: object, key: str | int) -> object:
    if isinstance(node, dict) and key in node:
        return node[key]
    if isinstance(node, list) and isinstance(key, int) and 0 <= key < len(node):
        return node[key]
    return ABSENT


class _At:
    """Where a pydantic error location points: the key path in the file and the schema there."""

    def __init__(self, loc: Sequence[str | int], raw: object, root: type[BaseModel]) -> None:
        self.parts: Parts = []
        self.model: type[BaseModel] | None = None  # the model holding the last key
        self.field = None  # its FieldInfo
        self.ann: Any = None  # the type expected at the location
        self.is_key = False
        self.on_track = True  # every union on the way was tried with the member the data is for
        ann: Any = root
        node = raw
        for el in loc:
            kind, inner = kind_of(ann) if ann is not None else ("leaf", None)
            if kind == "tagged":  # pydantic puts the tag (the `type`) in the location: not a key of the file
                ann = tagged_classes(ann).get(el) if isinstance(el, str) else None
                continue
            if kind == "union":  # pydantic names the member it tried: not a key of the file either
                ann = _member_for(inner, node)
                self.on_track &= ann is not None and str(el).split("[")[0] == _label(ann)
                continue
            if el == "[key]":  # a mapping's key, not its value, is wrong
                self.ann, self.is_key = str, True
                break
            if kind == "model":
                self.model = inner
                self.field = inner.model_fields.get(el) if isinstance(el, str) else None
                ann = self.field.annotation if self.field is not None else None
            elif kind in ("list", "dict"):
                ann = inner
            else:
                ann = None
            self.parts.append(el)
            node = child_at(node, el)
        else:
            self.ann = ann
        self.value = node

    @property
    def key(self) -> str:
        keys = [p for p in self.parts if isinstance(p, str)]
        return keys[-1] if keys else ""


def key_path(parts: Sequence[str | int]) -> str:
    """['tasks', 1, 'sensor', 'sweep_width_m'] -> 'tasks[1].sensor.sweep_width_m'."""
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


# --- units and what-was-expected ----------------------------------------------------------------------

#: Key suffixes and the unit they mean, longest first.
UNITS = (
    ("_per_km", "per kilometre driven"),
    ("_per_ha", "per hectare"),
    ("_per_h", "per hour"),
    ("_kgm2", "in kg m^2"),
    ("_mps", "in metres per second"),
    ("_dbm", "in dBm"),
    ("_dbi", "in dBi"),
    ("_deg", "in degrees"),
    ("_db", "in dB"),
    ("_hz", "in hertz"),
    ("_wh", "in watt-hours"),
    ("_kg", "in kilograms"),
    ("_w", "in watts"),
    ("_m", "in metres"),
    ("_s", "in seconds"),
    ("_h", "in hours"),
)
_NUMBER_WITH_UNIT = re.compile(r"^\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?\s*[^\d\s.].*$")


def unit_of(key: str) -> tuple[str, str]:
    """(suffix, words) of a key's unit: 'sweep_width_m' -> ('_m', 'in metres'); ('', '') if none."""
    for suffix, words in UNITS:
        if key == suffix[1:] or key.endswith(suffix):
            return suffix, words
    return "", ""


def _number_words(at: _At, integer: bool | None = None) -> str:
    if integer is None:
        integer = _strip(at.ann) is int
    what = "a whole number" if integer else "a number"
    words = unit_of(at.key)[1]
    return f"{what} {words}" if words else what


def model_keys(model: type[BaseModel]) -> str:
    return ", ".join(model.model_fields)


def _literal_words(at: _At, ctx: Mapping[str, Any]) -> str:
    ann = _strip(at.ann)
    if get_origin(ann) is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(ann))
    return f"one of {ctx.get('expected', '?')}".replace(" or ", ", ")


def _short(value: object) -> object:
    """The found value, or a short description of a big one."""
    if len(repr(value)) <= 80:
        return value
    if isinstance(value, dict):
        return f"a mapping with keys {', '.join(map(str, list(value)[:8]))}"
    if isinstance(value, list):
        return f"a list of {len(value)} items"
    return repr(value)[:77] + "..."


def describe(
    error: Mapping[str, Any], raw: object, root: type[BaseModel], tag_words: str = "a type"
) -> tuple[Parts, object, str]:
    """(key path parts, found, expected) of one pydantic error of `root.model_validate(raw)`;
    `tag_words` names what a tagged union's `type` chooses ("a task type")."""
    typ = error["type"]
    ctx = error.get("ctx") or {}
    at = _At(error["loc"], raw, root)
    parts, value = at.parts, error.get("input")
    if typ == "extra_forbidden":
        known = model_keys(at.model) if at.model is not None else "?"
        return parts, parts[-1] if parts else value, f"no such key (known keys: {known})"
    if typ == "missing":
        desc = ""
        if at.field is not None and at.field.description:
            desc = ": " + at.field.description.split(". ")[0].rstrip(".")
        return parts, "nothing", f"the required key '{at.key}'{desc}"
    if typ in ("union_tag_invalid", "union_tag_not_found"):
        tags = ", ".join(repr(t) for t in tagged_classes(at.ann)) or ctx.get("expected_tags", "?")
        found = ctx.get("tag", "nothing")
        return [*parts, "type"], found, f"{tag_words}, one of {tags}"
    if typ == "expected":  # the model's own checks (`expected`)
        if "key" in ctx:
            parts = [*parts, ctx["key"]]
        return parts, _short(ctx.get("found", value)), str(ctx["expected"])
    if typ in ("float_type", "float_parsing", "int_type", "int_parsing", "int_from_float", "finite_number"):
        integer = typ.startswith("int") or None
        if typ == "int_type" and _is_plain_number(value):
            integer = True
        expected = _number_words(at, integer)
        if typ == "finite_number":
            expected = "a finite number" + expected[len("a number") :]
        suffix = unit_of(at.key)[0]
        if isinstance(value, str) and _NUMBER_WITH_UNIT.match(value):
            expected += f", without a unit (the key's '{suffix}' gives it)" if suffix else ", without a unit"
        return parts, _short(value), expected
    bounds = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}
    if typ in bounds:
        limit = next(iter(ctx.values())) if ctx else "?"
        plain = _is_plain_number(limit) and not isinstance(limit, int)  # an int as written: 2**64 - 1
        limit_text = f"{limit:g}" if plain else str(limit)
        return parts, value, f"{_number_words(at)} {bounds[typ]} {limit_text}"
    if typ == "literal_error":
        return parts, _short(value), _literal_words(at, ctx)
    if typ in ("too_short", "too_long"):
        n = ctx.get("min_length" if typ == "too_short" else "max_length")
        side = "at least" if typ == "too_short" else "at most"
        return parts, _short(value), f"a list of {side} {n} item{'s' if n != 1 else ''}"
    if typ == "string_too_short":
        return parts, value, "a non-empty string"
    if typ == "string_type":
        return parts, _short(value), "names (string keys)" if at.is_key else "a string"
    if typ == "bool_type":
        return parts, _short(value), "true or false"
    if typ == "list_type":
        return parts, _short(value), "a list"
    if typ in ("dict_type", "model_type", "model_attributes_type") and not parts and value is None:
        return parts, "an empty file", f"a mapping (keys: {model_keys(root)})"
    if typ in ("dict_type", "model_type", "model_attributes_type"):
        kind, inner = kind_of(at.ann) if at.ann is not None else ("leaf", None)
        keys = f" (keys: {model_keys(inner)})" if kind == "model" else ""
        return parts, _short(value), f"a mapping{keys}"
    return parts, _short(value), str(error.get("msg", typ)).lower()


def _is_plain_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)
