"""The ManiLadder task catalog: the one place task metadata comes from.

`maniladder_ms/data/task_catalog.yaml` is the spec of every task (id, level, suite, embodiment,
object class, skills, success rule intent, horizon, C_geom/C_proc/C_perc scores). It is validated
on load; `list`, env metadata, evaluation reports and tests all read it through this module.
"""

from __future__ import annotations

import dataclasses
import difflib
import re
import string
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Iterable, Optional

import yaml

LEVELS = (1, 2, 3, 4)
OBJECT_PROPERTIES = ("rigid", "deformable")
EMBODIMENTS = ("SG", "SX", "DG", "DX")
SUITES_PER_LEVEL = len(OBJECT_PROPERTIES) * len(EMBODIMENTS)
TASKS_PER_SUITE = (3, 4)
SKILLS = (
    "prehensile",
    "articulated",
    "non_prehensile",
    "assembly",
    "tool_use",
    "dynamic",
    "bimanual",
    "deformable",
    "granular_fluid",
)
OBJECT_CLASSES = ("rigid", "articulated", "rope", "cloth", "clay", "liquid", "granular")
SCORE_KEYS = ("C_geom", "C_proc", "C_perc")
ENV_ID_FORMAT = "ManiLadder-{}-v1"


class CatalogError(ValueError):
    """The catalog file is malformed or breaks a ladder invariant."""


class UnknownTaskError(KeyError):
    """A task id that is not in the catalog."""

    def __str__(self):  # KeyError quotes its message; keep it readable
        return str(self.args[0])


@dataclasses.dataclass(frozen=True)
class TaskSpec:
    id: str
    env_id: str
    level: int
    suite: str
    object_property: str
    object_class: str
    embodiment: str
    mobile: bool
    skills: tuple[str, ...]
    description: str
    success: str
    horizon: int
    demo_plan: str
    scores: dict
    # the task family: one env class holds the family's rule (`evaluate`) and reads `params`, this row's
    # numbers (sizes, tolerances, counts); rows whose scenes differ register thin subclasses of it
    family: str = ""
    params: dict = dataclasses.field(default_factory=dict)
    # `success` with `{param:unit}` placeholders, as written in the catalog; `success` is it rendered
    success_template: str = ""

    @property
    def implemented(self) -> bool:
        """Whether an env for this task is registered in ManiSkill's registry."""
        from mani_skill.utils.registration import REGISTERED_ENVS

        return self.env_id in REGISTERED_ENVS

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["skills"] = list(self.skills)
        d["implemented"] = self.implemented
        return d


def snake_case(name: str) -> str:
    """CamelCase -> snake_case ("PickPlacePen" -> "pick_place_pen", "Stack6Blocks" -> "stack6_blocks")."""
    return re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", name).lower()


# units of `{param:unit}` placeholders in success text: a factor on the param's (SI) value and a suffix
PARAM_UNITS = {"": (1, ""), "m": (1, " m"), "cm": (100, " cm"), "mm": (1000, " mm"), "deg": (1, " deg"),
               "pct": (100, "%"), "x": (1, "x"), "s": (1, " s"), "kg": (1, " kg"), "g": (1000, " g")}


def format_param(value, unit: str) -> str:
    if unit not in PARAM_UNITS:
        raise CatalogError(f"unknown unit {unit!r} in a success placeholder; known: {', '.join(u for u in PARAM_UNITS if u)}")
    factor, suffix = PARAM_UNITS[unit]
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(format_param(v, unit).removesuffix(suffix) for v in value) + "]" + suffix
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return f"{value}{suffix}"
    return f"{round(value * factor, 6):g}{suffix}"


def template_fields(template: str) -> list[tuple[str, str]]:
    """(param name, unit) of every `{name:unit}` placeholder of a success template."""
    return [(name, spec or "") for _, name, spec, _ in string.Formatter().parse(template) if name is not None]


def render_success(template: str, params: dict, where: str = "") -> str:
    """The success text with each `{name:unit}` replaced by the param's value in that unit."""
    out = []
    for literal, name, spec, _ in string.Formatter().parse(template):
        out.append(literal)
        if name is None:
            continue
        if name not in params:
            raise CatalogError(f"{where}: success text names {{{name}}}, which is not in the row's params")
        out.append(format_param(params[name], spec or ""))
    return "".join(out)


def suite_name(level: int, object_property: str, embodiment: str) -> str:
    return f"L{level}-{object_property}-{embodiment}"


class Catalog:
    """Validated, read-only view of the task catalog."""

    def __init__(self, data: dict, source: str = "<dict>"):
        self.source = source
        self.version = data.get("version") if isinstance(data, dict) else None
        self.tasks: tuple[TaskSpec, ...] = tuple(_parse_tasks(data, source))
        self._by_id = {t.id: t for t in self.tasks}
        self.level_success_ranges = {int(k): tuple(v["success_range"]) for k, v in data["levels"].items()}
        _validate_ladder(self.tasks, data, source)

    def __len__(self):
        return len(self.tasks)

    def __iter__(self):
        return iter(self.tasks)

    def __contains__(self, task_id: str):
        return task_id in self._by_id

    def get(self, task_id: str) -> TaskSpec:
        """The spec of `task_id` (a catalog id like "PickPlacePen" or its env id)."""
        key = task_id
        if key.startswith("ManiLadder-") and key.endswith("-v1"):
            key = key[len("ManiLadder-") : -len("-v1")]
        if key not in self._by_id:
            close = difflib.get_close_matches(key, self._by_id, n=3)
            hint = f" Did you mean: {', '.join(close)}?" if close else ""
            raise UnknownTaskError(
                f"unknown ManiLadder task '{task_id}'.{hint} `maniladder list` shows all {len(self)} tasks."
            )
        return self._by_id[key]

    def filter(
        self,
        level: Optional[int] = None,
        suite: Optional[str] = None,
        embodiment: Optional[str] = None,
        object_class: Optional[str] = None,
        object_property: Optional[str] = None,
        skill: Optional[str] = None,
        implemented: Optional[bool] = None,
    ) -> list[TaskSpec]:
        """Tasks matching every given criterion; an unknown criterion value raises CatalogError."""
        _check_choice("level", level, LEVELS)
        _check_choice("suite", suite, self.suites())
        _check_choice("embodiment", embodiment, EMBODIMENTS)
        _check_choice("object class", object_class, OBJECT_CLASSES)
        _check_choice("object property", object_property, OBJECT_PROPERTIES)
        _check_choice("skill", skill, SKILLS)
        out = []
        for t in self.tasks:
            if level is not None and t.level != level:
                continue
            if suite is not None and t.suite != suite:
                continue
            if embodiment is not None and t.embodiment != embodiment:
                continue
            if object_class is not None and t.object_class != object_class:
                continue
            if object_property is not None and t.object_property != object_property:
                continue
            if skill is not None and skill not in t.skills:
                continue
            if implemented is not None and t.implemented != implemented:
                continue
            out.append(t)
        return out

    def suites(self) -> list[str]:
        """All suite names in ladder order: level, then rigid/deformable, then SG/SX/DG/DX."""
        return [suite_name(lv, p, e) for lv in LEVELS for p in OBJECT_PROPERTIES for e in EMBODIMENTS]


def _check_choice(name: str, value, choices: Iterable):
    choices = list(choices)
    if value is not None and value not in choices:
        raise CatalogError(f"unknown {name} {value!r}; choose one of: {', '.join(map(str, choices))}")


_REQUIRED_FIELDS = (
    "id", "env_id", "level", "suite", "object_property", "object_class", "embodiment",
    "mobile", "skills", "description", "success", "horizon", "demo", "scores",
)


def _parse_tasks(data: dict, source: str):
    if not isinstance(data, dict) or not isinstance(data.get("tasks"), list):
        raise CatalogError(f"{source}: expected a mapping with a 'tasks' list")
    if not isinstance(data.get("levels"), dict):
        raise CatalogError(f"{source}: expected a 'levels' mapping")
    for i, raw in enumerate(data["tasks"]):
        where = f"{source}: task #{i}" + (f" ({raw.get('id')})" if isinstance(raw, dict) else "")
        if not isinstance(raw, dict):
            raise CatalogError(f"{where}: expected a mapping")
        missing = [k for k in _REQUIRED_FIELDS if k not in raw]
        if missing:
            raise CatalogError(f"{where}: missing field(s) {', '.join(missing)}")
        unknown_skills = sorted(set(raw["skills"]) - set(SKILLS))
        if unknown_skills:
            raise CatalogError(f"{where}: unknown skill(s) {unknown_skills}; known: {', '.join(SKILLS)}")
        if raw["level"] not in LEVELS:
            raise CatalogError(f"{where}: level {raw['level']!r} not in {LEVELS}")
        if raw["embodiment"] not in EMBODIMENTS:
            raise CatalogError(f"{where}: embodiment {raw['embodiment']!r} not in {EMBODIMENTS}")
        if raw["object_property"] not in OBJECT_PROPERTIES:
            raise CatalogError(f"{where}: object_property {raw['object_property']!r} not in {OBJECT_PROPERTIES}")
        if raw["object_class"] not in OBJECT_CLASSES:
            raise CatalogError(f"{where}: object_class {raw['object_class']!r} not in {OBJECT_CLASSES}")
        expected_suite = suite_name(raw["level"], raw["object_property"], raw["embodiment"])
        if raw["suite"] != expected_suite:
            raise CatalogError(f"{where}: suite {raw['suite']!r} disagrees with its level/property/embodiment ({expected_suite})")
        if raw["env_id"] != ENV_ID_FORMAT.format(raw["id"]):
            raise CatalogError(f"{where}: env_id {raw['env_id']!r} should be {ENV_ID_FORMAT.format(raw['id'])!r}")
        if not isinstance(raw["horizon"], int) or raw["horizon"] <= 0:
            raise CatalogError(f"{where}: horizon must be a positive integer, got {raw['horizon']!r}")
        missing_scores = [k for k in SCORE_KEYS if k not in raw["scores"]]
        if missing_scores:
            raise CatalogError(f"{where}: missing score(s) {', '.join(missing_scores)}")
        family = raw.get("family", raw["id"])
        if not isinstance(family, str) or not re.fullmatch(r"[A-Z][A-Za-z0-9]*", family):
            raise CatalogError(f"{where}: family must be a CamelCase name, got {family!r}")
        params = raw.get("params") or {}
        if not isinstance(params, dict):
            raise CatalogError(f"{where}: params must be a mapping of name -> value, got {params!r}")
        yield TaskSpec(
            id=raw["id"],
            env_id=raw["env_id"],
            level=raw["level"],
            suite=raw["suite"],
            object_property=raw["object_property"],
            object_class=raw["object_class"],
            embodiment=raw["embodiment"],
            mobile=bool(raw["mobile"]),
            skills=tuple(raw["skills"]),
            description=raw["description"],
            success=render_success(raw["success"], params, where),
            success_template=raw["success"],
            family=family,
            params=params,
            horizon=raw["horizon"],
            demo_plan=raw["demo"].get("plan", ""),
            scores={k: raw["scores"][k] for k in SCORE_KEYS},
        )


def _validate_ladder(tasks: tuple[TaskSpec, ...], data: dict, source: str):
    seen = set()
    for t in tasks:
        if t.id in seen:
            raise CatalogError(f"{source}: duplicate task id {t.id!r}")
        seen.add(t.id)
    levels = sorted({int(k) for k in data["levels"]})
    if levels != list(LEVELS):
        raise CatalogError(f"{source}: expected exactly levels {list(LEVELS)}, found {levels}")
    for level in LEVELS:
        suites = {t.suite for t in tasks if t.level == level}
        if len(suites) != SUITES_PER_LEVEL:
            raise CatalogError(f"{source}: level {level} has {len(suites)} suites, expected {SUITES_PER_LEVEL}")
        for suite in sorted(suites):
            n = sum(t.suite == suite for t in tasks)
            if not TASKS_PER_SUITE[0] <= n <= TASKS_PER_SUITE[1]:
                raise CatalogError(
                    f"{source}: suite {suite} has {n} tasks, expected {TASKS_PER_SUITE[0]}-{TASKS_PER_SUITE[1]}"
                )


def load_catalog(path: Optional[str | Path] = None) -> Catalog:
    """Load and validate a catalog file; without a path, the packaged catalog."""
    if path is None:
        return default_catalog()
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        raise CatalogError(f"{path}: not valid YAML: {e}") from e
    return Catalog(data, source=str(path))


@lru_cache(maxsize=1)
def default_catalog() -> Catalog:
    text = resources.files("maniladder_ms").joinpath("data/task_catalog.yaml").read_text()
    # libyaml's parser where PyYAML has it: the same data, ~10x faster than the pure-Python one (0.06 s
    # against 0.6 s at 112 rows), and `import maniladder_ms` loads the catalog to register the tasks
    return Catalog(yaml.load(text, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader)),
                   source="maniladder_ms/data/task_catalog.yaml")
