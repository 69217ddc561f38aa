"""Sweep files: a base scene and the parameters to vary, expanded into named scenarios.

A sweep file is TOML (see docs/batch.md)::

    base = "skin_press.toml"   # scene file relative to this file, or a bundled scene name,
                               # or an inline [base] table holding a whole scene
    repeat = 1                 # runs of every scenario; ids gain __rep<k> when > 1
    [set]                      # overrides for every scenario (not part of the ids)
    duration = 0.5
    [grid]                     # the Cartesian product of these lists
    "material.stiffness" = [80.0, 160.0, 320.0]
    "tool.radius" = [0.0005, 0.001]
    [[cases]]                  # explicit scenarios, run after the grid's
    "material.damping" = 1.0

Keys are the dotted scene keys of ``warp-cut run --set``. Keys under ``tag.`` label a scenario
(for example the tool angle its keyframes encode) without changing the scene: they appear in
the id, in results.csv and on the plots. A scenario is the base scene with ``[set]`` and then
its own parameters applied, exactly as ``warp-cut run BASE --set KEY=VALUE ...`` would.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import re
import shlex
import tomllib
from dataclasses import dataclass
from pathlib import Path

import tomli_w

from ..errors import SceneError
from ..scene import apply_overrides, bundled_scene_names, bundled_scene_path

__all__ = ["Scenario", "Sweep", "load_sweep", "parse_sweep", "toml_value", "TAG_PREFIX"]

TAG_PREFIX = "tag."
"""Parameters under this prefix label scenarios and are not applied to the scene."""

_TOP_KEYS = {"base", "repeat", "set", "grid", "cases"}
_KEY_PART = re.compile(r"^[A-Za-z0-9_-]+$")
_ID_UNSAFE = re.compile(r"[^A-Za-z0-9._=+~-]")
_ID_MAX = 100
_MAX_SCENARIOS = 100_000


@dataclass(frozen=True)
class Scenario:
    """One run of a sweep.

    Attributes:
        id: Directory name under ``DIR/runs/``, derived from the parameters (stable, readable).
        params: Dotted key -> value in sweep order (``tag.*`` included).
        rep: Repeat index in [0, repeat).
        overrides: ``section.key=value`` strings (TOML values) applied after the sweep's ``[set]``.
    """

    id: str
    params: dict
    rep: int
    overrides: tuple


@dataclass
class Sweep:
    """A parsed sweep file.

    Attributes:
        path: The sweep file.
        base_data: The base scene as loaded from TOML.
        base_text: Its TOML source (an inline base written out, its relative mesh path made
            absolute).
        base_path: The base scene file (the sweep file for an inline base, whose default scene
            name is then the sweep file's stem).
        base_inline: True if the base is an inline ``[base]`` table.
        settings: The ``[set]`` overrides as ``section.key=value`` strings.
        repeat: Runs of each scenario.
        parameters: Every swept key, in order.
        scenarios: The expanded scenarios, in sweep order.
    """

    path: Path
    base_data: dict
    base_text: str
    base_path: Path
    base_inline: bool
    settings: tuple
    repeat: int
    parameters: list
    scenarios: list

    def overrides(self, scenario: Scenario) -> list[str]:
        """All ``--set`` strings of a scenario, in the order they are applied."""
        return list(self.settings) + list(scenario.overrides)

    def fingerprint(self, scenario: Scenario) -> str:
        """Hash of everything that decides a scenario's result (base, overrides, repeat)."""
        text = json.dumps([self.base_data, self.overrides(scenario), scenario.rep],
                          sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def command(self, scenario: Scenario) -> str | None:
        """The equivalent ``warp-cut run`` command, or None for an inline base scene."""
        if self.base_inline:
            return None
        words = ["warp-cut", "run", str(self.base_path)]
        for item in self.overrides(scenario):
            words += ["--set", item]
        return shlex.join(words)


def toml_value(value) -> str:
    """``value`` as an inline TOML value (what ``--set key=VALUE`` parses back exactly)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_toml_string(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"no TOML form for {type(value).__name__}")


def _toml_string(text: str) -> str:
    """``text`` as a TOML basic string."""
    # JSON escapes are TOML escapes, except that TOML wants no surrogate pairs and no raw DEL
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _digest(value) -> str:
    """Eight hex digits of a hash of ``value`` (its JSON form)."""
    return hashlib.sha1(json.dumps(value, sort_keys=True, default=str).encode()).hexdigest()[:8]


def _id_value(value) -> str:
    """A parameter value as it appears in a scenario id."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str)):
        return str(value) if not isinstance(value, float) else repr(value)
    return "~" + _digest(value)  # lists and tables: a short hash keeps the id readable


def _scenario_id(params: dict) -> str:
    """``key=value`` pairs joined by ``__``, made safe as a directory name and cut to 100 characters."""
    text = "__".join(f"{k}={_id_value(v)}" for k, v in params.items()) or "base"
    text = _ID_UNSAFE.sub("-", text)
    if len(text) > _ID_MAX:
        text = text[:_ID_MAX - 20].rstrip("._-") + "~" + _digest(params)
    return text


def _check_value(path, where: str, value) -> None:
    """Raise SceneError if ``value`` has no TOML form."""
    try:
        toml_value(value)
    except TypeError:
        raise SceneError(path, where, f"unsupported value {value!r} (dates and times are not "
                                      "scene values)") from None


def _check_key(path, where: str, key: str) -> None:
    """Raise SceneError if ``key`` is not a dotted scene key."""
    if not isinstance(key, str) or not all(_KEY_PART.match(p) for p in key.split(".")):
        raise SceneError(path, where, f"{key!r} is not a dotted scene key like "
                                      "\"material.stiffness\" (letters, digits, _ and -)")


def _table(path, data: dict, key: str) -> dict:
    """``data[key]`` (default empty), which must be a table."""
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise SceneError(path, key, f"must be a table, got {type(value).__name__}")
    return value


def _inline_base(path: Path, base: dict):
    """(data, text) of an inline base; a relative ``tissue.path`` resolves against the sweep file."""
    base = copy.deepcopy(base)
    tissue = base.get("tissue")
    if isinstance(tissue, dict) and isinstance(tissue.get("path"), str):
        tissue["path"] = str((path.parent / tissue["path"]).resolve())
    try:
        return base, tomli_w.dumps(base)
    except (TypeError, ValueError) as exc:
        raise SceneError(path, "base", f"cannot be written as a scene file: {exc}") from exc


def _load_base(path: Path, data: dict):
    """(base_data, base_text, base_path, inline) of the sweep's ``base`` key."""
    base = data.get("base")
    if isinstance(base, dict):
        return (*_inline_base(path, base), path.resolve(), True)
    if not isinstance(base, str) or not base:
        raise SceneError(path, "base", "is required: a scene file relative to the sweep file, "
                                       "a bundled scene name, or an inline [base] table")
    candidate = path.parent / base
    if not candidate.is_file():
        bundled = bundled_scene_path(base)
        if not bundled.is_file():
            raise SceneError(path, "base", f"scene not found: {candidate} (bundled scenes: "
                                           f"{', '.join(bundled_scene_names())})")
        candidate = bundled
    try:
        text = candidate.read_text(encoding="utf-8")
        return tomllib.loads(text), text, candidate.resolve(), False
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError(candidate, "file", f"is not valid TOML: {exc}") from exc


def _cases(path, data: dict) -> list[dict]:
    """The ``[[cases]]`` tables, keys and values checked."""
    cases = data.get("cases", [])
    if not isinstance(cases, list) or not all(isinstance(c, dict) for c in cases):
        raise SceneError(path, "cases", "must be an array of tables ([[cases]])")
    for n, case in enumerate(cases):
        for key, value in case.items():
            _check_key(path, f"cases[{n}]", key)
            _check_value(path, f"cases[{n}].\"{key}\"", value)
    return cases


def _grid(path, data: dict) -> dict:
    """The ``[grid]`` table, keys and value lists checked, at most 100 000 combinations."""
    grid = _table(path, data, "grid")
    for key, values in grid.items():
        _check_key(path, "grid", key)
        if not isinstance(values, list) or not values:
            raise SceneError(path, f"grid.\"{key}\"", "must be a non-empty list of values "
                                                      "(a list value is itself a list: [[...]])")
        for value in values:
            _check_value(path, f"grid.\"{key}\"", value)
    count = math.prod(len(v) for v in grid.values())
    if count > _MAX_SCENARIOS:
        raise SceneError(path, "grid", f"gives {count} scenarios; allowed up to {_MAX_SCENARIOS}")
    return grid


def _unique_ids(path, ids: list[str], params: list[dict]) -> list[str]:
    """Disambiguate ids that collide after sanitising; identical parameter sets are an error."""
    seen: dict[str, int] = {}
    out = list(ids)
    for n, sid in enumerate(ids):
        if sid in seen:
            first = seen[sid]
            if params[first] == params[n]:
                raise SceneError(path, "cases", f"two scenarios have the same parameters "
                                                f"({sid}); use repeat to run one several times")
            out[first] = f"{ids[first]}~{_digest(params[first])}"
            out[n] = f"{sid}~{_digest(params[n])}"
        else:
            seen[sid] = n
    return out


def parse_sweep(data: dict, path) -> Sweep:
    """Validate a sweep dictionary and expand it into scenarios.

    Args:
        data: The sweep as loaded from TOML.
        path: The sweep file (relative base scenes resolve against it; named in errors).

    Returns:
        The sweep with its scenarios.

    Raises:
        SceneError: An unknown key, a bad value or base scene; the message names the key.
    """
    path = Path(path)
    unknown = set(data) - _TOP_KEYS
    if unknown:
        raise SceneError(path, sorted(unknown)[0], f"unknown key; allowed: {sorted(_TOP_KEYS)}")
    repeat = data.get("repeat", 1)
    if isinstance(repeat, bool) or not isinstance(repeat, int) or not 1 <= repeat <= 10_000:
        raise SceneError(path, "repeat", f"must be an integer in [1, 10000], got {repeat!r}")
    settings = _table(path, data, "set")
    for key, value in settings.items():
        _check_key(path, "set", key)
        _check_value(path, f"set.\"{key}\"", value)
        if key.startswith(TAG_PREFIX):
            raise SceneError(path, f"set.\"{key}\"", "tags label swept scenarios; not allowed in [set]")
    grid, cases = _grid(path, data), _cases(path, data)
    base_data, base_text, base_path, inline = _load_base(path, data)
    settings = tuple(f"{k}={toml_value(v)}" for k, v in settings.items())
    apply_overrides(base_data, list(settings), path)  # a [set] key that cannot apply fails here

    param_sets = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())] if grid else []
    param_sets += [dict(case) for case in cases]
    if not param_sets:
        param_sets = [{}]
    if len(param_sets) * repeat > _MAX_SCENARIOS:
        raise SceneError(path, "repeat", f"gives {len(param_sets) * repeat} scenarios; "
                                         f"allowed up to {_MAX_SCENARIOS}")
    ids = _unique_ids(path, [_scenario_id(p) for p in param_sets], param_sets)
    scenarios = []
    for sid, params in zip(ids, param_sets):
        overrides = tuple(f"{k}={toml_value(v)}" for k, v in params.items()
                          if not k.startswith(TAG_PREFIX))
        for rep in range(repeat):
            scenarios.append(Scenario(sid if repeat == 1 else f"{sid}__rep{rep}", params, rep,
                                      overrides))
    parameters = list(dict.fromkeys(k for p in param_sets for k in p))
    return Sweep(path=path, base_data=base_data, base_text=base_text, base_path=base_path,
                 base_inline=inline,
                 settings=settings,
                 repeat=repeat, parameters=parameters, scenarios=scenarios)


def load_sweep(source) -> Sweep:
    """Load and expand a sweep file.

    Args:
        source: A path, or the name of a bundled ``*sweep*`` file.

    Returns:
        The sweep with its scenarios.

    Raises:
        SceneError: The file is missing, not TOML, or not a valid sweep.
    """
    path = Path(source)
    if not path.is_file():
        bundled = bundled_scene_path(str(source))
        if not bundled.is_file():
            raise SceneError(path, "file", "sweep file not found")
        path = bundled
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise SceneError(path, "file", f"is not valid TOML: {exc}") from exc
    return parse_sweep(data, path)
