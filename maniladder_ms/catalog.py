"""The ManiLadder task catalog: the one place task metadata comes from.

`maniladder_ms/data/task_catalog.yaml` is the spec of every task (id, level, suite, embodiment,
object class, skills, success rule intent, horizon, C_geom/C_proc/C_perc scores). It is validated
on load; `list`, env metadata, evaluation reports and tests all read it through this module.

`maniladder_ms/data/instructions.yaml` holds each task's language instruction: a canonical one and at least
`MIN_PARAPHRASES` paraphrases, loaded into `TaskSpec.instruction` / `TaskSpec.paraphrases`. It is a file of
its own, keyed by task id, rather than fields of the catalog rows: the rows are edited by whoever builds a
task (params, rules), the instructions are written for all 112 tasks at once, and one file each keeps those
edits apart. The loader holds the two files to each other: every catalog task has its instructions, and
every instruction belongs to a catalog task.
"""

from __future__ import annotations

import dataclasses
import difflib
import random
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
CATALOG_FILE = "data/task_catalog.yaml"
INSTRUCTIONS_FILE = "data/instructions.yaml"
MIN_PARAPHRASES = 4
MAX_INSTRUCTION_WORDS = 15  # the canonical instruction: a short sentence a person says to the robot
# which instruction an episode gets (demos, evaluation): the canonical one, or one of the canonical and its
# paraphrases drawn from the episode seed (`TaskSpec.instruction_for`)
INSTRUCTION_MODES = ("canonical", "paraphrase")


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
    # the layout axes whose spread follows from other draws (`layout.object_breadths`): {object: {"x"|"y": [terms]}},
    # a term a layout param of the row (its width counts) or a width in m; read by the layout tables, not by the task
    layout_derived: dict = dataclasses.field(default_factory=dict)
    # the language instruction (`instructions.yaml`): the canonical one and its paraphrases (same meaning)
    instruction: str = ""
    paraphrases: tuple[str, ...] = ()

    @property
    def instructions(self) -> tuple[str, ...]:
        """The canonical instruction, then its paraphrases."""
        return (self.instruction, *self.paraphrases)

    def instruction_for(self, seed: int, mode: str = "canonical") -> str:
        """The instruction an episode with `seed` gets: under "canonical" the canonical one; under "paraphrase"
        one of `instructions` drawn from the task id and the seed (the same episode always gets the same text)."""
        if check_instruction_mode(mode) == "canonical":
            return self.instruction
        return random.Random(f"{self.id}:{int(seed)}").choice(self.instructions)

    @property
    def implemented(self) -> bool:
        """Whether an env for this task is registered in ManiSkill's registry."""
        from mani_skill.utils.registration import REGISTERED_ENVS

        return self.env_id in REGISTERED_ENVS

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["skills"] = list(self.skills)
        d["paraphrases"] = list(self.paraphrases)
        d["implemented"] = self.implemented
        return d


def check_instruction_mode(mode: str) -> str:
    """`mode` if it is one of INSTRUCTION_MODES, else a ValueError naming them."""
    if mode not in INSTRUCTION_MODES:
        raise ValueError(f"unknown instruction mode {mode!r}; choose one of: {', '.join(INSTRUCTION_MODES)}")
    return mode


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

    def __init__(self, data: dict, source: str = "<dict>", instructions: Optional[tuple[str, dict]] = None):
        """`data`: the parsed catalog; `instructions`: (source, parsed instructions file), default the packaged one."""
        self.source = source
        self.version = data.get("version") if isinstance(data, dict) else None
        tasks = tuple(_parse_tasks(data, source))
        _validate_ladder(tasks, data, source)
        instructions_source, instructions = instructions or packaged_instructions()
        texts = parse_instructions(instructions, [t.id for t in tasks], instructions_source)
        self.tasks: tuple[TaskSpec, ...] = tuple(
            dataclasses.replace(t, instruction=texts[t.id][0], paraphrases=texts[t.id][1]) for t in tasks)
        self._by_id = {t.id: t for t in self.tasks}
        self.level_success_ranges = {int(k): tuple(v["success_range"]) for k, v in data["levels"].items()}

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
        derived = raw.get("layout_derived") or {}
        _check_layout_derived(derived, params, where)
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
            layout_derived=derived,
        )


def _check_layout_derived(derived, params: dict, where: str):
    """`layout_derived` is {object: {"x"|"y": [terms]}}, each term a param of the row or a positive width in m."""
    if not isinstance(derived, dict):
        raise CatalogError(f"{where}: layout_derived must be a mapping of object -> {{axis: [terms]}}, got {derived!r}")
    for obj, axes in derived.items():
        if not isinstance(axes, dict) or not axes or set(axes) - {"x", "y"}:
            raise CatalogError(f"{where}: layout_derived[{obj!r}] must map 'x' and/or 'y' to a list of terms, "
                               f"got {axes!r}")
        for axis, terms in axes.items():
            if not isinstance(terms, list) or not terms:
                raise CatalogError(f"{where}: layout_derived[{obj!r}][{axis!r}] must be a non-empty list, got {terms!r}")
            for term in terms:
                number = isinstance(term, (int, float)) and not isinstance(term, bool)
                if not (term in params if isinstance(term, str) else number and term > 0):
                    raise CatalogError(f"{where}: layout_derived[{obj!r}][{axis!r}]: {term!r} is neither a param of "
                                       f"this row nor a positive width in m")


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


def _normalized(text: str) -> str:
    """An instruction as compared for duplicates: case, spacing and the final full stop do not count."""
    return " ".join(text.casefold().rstrip(".!").split())


def parse_instructions(data, task_ids: list[str], source: str) -> dict[str, tuple[str, tuple[str, ...]]]:
    """{task id: (canonical instruction, paraphrases)} of a parsed instructions file, checked against the
    catalog's task ids: each task has a canonical instruction of at most MAX_INSTRUCTION_WORDS words and at
    least MIN_PARAPHRASES paraphrases, no two of its texts alike, no two tasks with the same canonical one,
    and no entry for a task that is not in the catalog."""
    if not isinstance(data, dict):
        raise CatalogError(f"{source}: expected a mapping of task id -> {{instruction, paraphrases}}")
    unknown = [k for k in data if k not in task_ids]
    if unknown:
        hints = [f"{k} (did you mean {', '.join(close)}?)" if (close := difflib.get_close_matches(str(k), task_ids, n=1))
                 else str(k) for k in unknown]
        raise CatalogError(f"{source}: instructions for task(s) not in the catalog: {', '.join(hints)}")
    missing = [t for t in task_ids if t not in data]
    if missing:
        raise CatalogError(f"{source}: no instructions for catalog task(s) {', '.join(missing)}; every task needs "
                           f"an instruction and at least {MIN_PARAPHRASES} paraphrases")
    out, owner = {}, {}
    for task_id in task_ids:
        entry, where = data[task_id], f"{source}: {task_id}"
        if not isinstance(entry, dict) or set(entry) != {"instruction", "paraphrases"}:
            raise CatalogError(f"{where}: expected exactly the keys 'instruction' and 'paraphrases', got {entry!r}")
        text, paraphrases = entry["instruction"], entry["paraphrases"]
        if not isinstance(paraphrases, list):
            raise CatalogError(f"{where}: paraphrases must be a list of sentences, got {paraphrases!r}")
        bad = [t for t in [text, *paraphrases] if not isinstance(t, str) or not t.strip()]
        if bad:
            raise CatalogError(f"{where}: instructions must be non-empty strings, got {bad[0]!r}")
        if len(text.split()) > MAX_INSTRUCTION_WORDS:
            raise CatalogError(f"{where}: the instruction has {len(text.split())} words; keep it to "
                               f"{MAX_INSTRUCTION_WORDS} (the paraphrases may be longer)")
        if len(paraphrases) < MIN_PARAPHRASES:
            raise CatalogError(f"{where}: {len(paraphrases)} paraphrase(s), expected at least {MIN_PARAPHRASES}")
        seen: dict[str, str] = {}
        for t in [text, *paraphrases]:
            if _normalized(t) in seen:
                raise CatalogError(f"{where}: duplicate instruction {t!r} (same as {seen[_normalized(t)]!r})")
            seen[_normalized(t)] = t
        if _normalized(text) in owner:
            raise CatalogError(f"{where}: the same instruction as {owner[_normalized(text)]}: {text!r}")
        owner[_normalized(text)] = task_id
        out[task_id] = (text.strip(), tuple(p.strip() for p in paraphrases))
    return out


def _read_yaml(source: str, text: Optional[str] = None):
    """The parsed YAML file `source` (or `text`, read from there)."""
    try:
        # libyaml's parser where PyYAML has it: the same data, ~10x faster than the pure-Python one (0.06 s
        # against 0.6 s at 112 rows), and `import maniladder_ms` loads the catalog to register the tasks
        return yaml.load(Path(source).read_text() if text is None else text,
                         Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except yaml.YAMLError as e:
        raise CatalogError(f"{source}: not valid YAML: {e}") from e


def _read_packaged(name: str):
    """(source label, parsed data) of a packaged data file."""
    return f"maniladder_ms/{name}", _read_yaml(f"maniladder_ms/{name}", resources.files("maniladder_ms").joinpath(name).read_text())


@lru_cache(maxsize=1)
def packaged_instructions() -> tuple[str, dict]:
    """(source label, parsed data) of the packaged instructions file (checked against a catalog when one is built)."""
    return _read_packaged(INSTRUCTIONS_FILE)


def load_catalog(path: Optional[str | Path] = None, instructions: Optional[str | Path] = None) -> Catalog:
    """Load and validate a catalog file with an instructions file; without either, the packaged one (a catalog
    of other tasks needs an instructions file of its own: every task, and only those, must have instructions)."""
    if path is None and instructions is None:
        return default_catalog()
    source, data = (str(path), _read_yaml(str(path))) if path is not None else _read_packaged(CATALOG_FILE)
    texts = packaged_instructions() if instructions is None else (str(instructions), _read_yaml(str(instructions)))
    return Catalog(data, source=source, instructions=texts)


@lru_cache(maxsize=1)
def default_catalog() -> Catalog:
    source, data = _read_packaged(CATALOG_FILE)
    return Catalog(data, source=source)
