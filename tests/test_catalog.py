import copy
from pathlib import Path

import gymnasium as gym
import pytest
import yaml

import maniladder_ms
from maniladder_ms.catalog import SKILLS, Catalog, CatalogError, UnknownTaskError, load_catalog

SHARED = Path(__file__).resolve().parents[2] / "shared" / "task_catalog.yaml"


@pytest.fixture(scope="module")
def raw():
    return yaml.safe_load((Path(maniladder_ms.__file__).parent / "data" / "task_catalog.yaml").read_text())


def test_packaged_catalog_is_the_full_ladder(catalog):
    assert len(catalog) == 112
    assert sorted({t.level for t in catalog}) == [1, 2, 3, 4]
    assert len({t.suite for t in catalog}) == 32
    for level in (1, 2, 3, 4):
        assert len(catalog.filter(level=level)) == 28
    assert len({t.id for t in catalog}) == 112
    assert all(set(t.skills) <= set(SKILLS) for t in catalog)


@pytest.mark.skipif(not SHARED.exists(), reason="../shared not beside the checkout")
def test_project_catalog_keeps_the_shared_task_list(catalog):
    shared = yaml.safe_load(SHARED.read_text())
    assert [t["id"] for t in shared["tasks"]] == [t.id for t in catalog]


def test_lookup_and_filters(catalog):
    pen = catalog.get("PickPlacePen")
    assert (pen.level, pen.suite, pen.embodiment, pen.skills) == (1, "L1-rigid-SG", "SG", ("prehensile",))
    assert catalog.get("ManiLadder-PickPlacePen-v1") is pen
    assert {t.id for t in catalog.filter(level=1, suite="L1-rigid-SG")} == {
        "PickPlacePen", "HangMug", "OpenBoxRetrieval", "PivotBook"}
    rope = catalog.filter(object_class="rope")
    assert rope and all(t.object_class == "rope" for t in rope)
    assert all("tool_use" in t.skills for t in catalog.filter(skill="tool_use"))
    assert all(t.embodiment == "DX" for t in catalog.filter(embodiment="DX"))
    built = {t.id for t in catalog.filter(implemented=True)}
    assert {"PickPlacePen", "Stack6Blocks", "OpenBoxRetrieval", "LiftBottleHand", "LiftWideBox", "LiftBasketHands"} <= built
    assert all(catalog.get(task_id).env_id in gym.registry for task_id in built)


def test_unknown_task_and_bad_filter_values_are_clear_errors(catalog):
    with pytest.raises(UnknownTaskError, match="Did you mean: PickPlacePen"):
        catalog.get("PickPlacePem")
    with pytest.raises(CatalogError, match="unknown skill 'juggling'"):
        catalog.filter(skill="juggling")
    with pytest.raises(CatalogError, match="unknown suite"):
        catalog.filter(suite="L5-rigid-SG")


def _broken(raw, edit):
    data = copy.deepcopy(raw)
    edit(data)
    return data


BREAKAGES = {
    "duplicate task id": lambda d: d["tasks"][1].update(id=d["tasks"][0]["id"], env_id=d["tasks"][0]["env_id"]),
    "unknown skill": lambda d: d["tasks"][0]["skills"].append("juggling"),
    "expected exactly levels": lambda d: d["levels"].pop(4),
    "missing field": lambda d: d["tasks"][0].pop("horizon"),
    r"has 5 tasks, expected 3-4": lambda d: d["tasks"].append(
        dict(copy.deepcopy(d["tasks"][0]), id="Extra", env_id="ManiLadder-Extra-v1")),
    r"has 2 tasks, expected 3-4": lambda d: [d["tasks"].remove(t) for t in
                                            [t for t in d["tasks"] if t["suite"] == "L1-rigid-SX"][:1]],
    "disagrees with its level": lambda d: d["tasks"][0].update(suite="L2-rigid-SG"),
    "env_id": lambda d: d["tasks"][0].update(env_id="PickPlacePen-v0"),
}


@pytest.mark.parametrize("message", list(BREAKAGES))
def test_broken_catalogs_fail_loudly(raw, message):
    with pytest.raises(CatalogError, match=message):
        Catalog(_broken(raw, BREAKAGES[message]))


def test_unparsable_catalog_file(tmp_path):
    bad = tmp_path / "catalog.yaml"
    bad.write_text("tasks: [unclosed\n")
    with pytest.raises(CatalogError, match="not valid YAML"):
        load_catalog(bad)
    bad.write_text("- just a list\n")
    with pytest.raises(CatalogError, match="expected a mapping"):
        load_catalog(bad)


def _success_section(doc: str) -> str:
    """The **Success:** paragraph of a task class docstring (up to the next bold heading or the end)."""
    import re

    match = re.search(r"\*\*Success:\*\*(.*?)(?=\n\s*\*\*[A-Z][a-z]+[^*]*:\*\*|\Z)", doc or "", re.S)
    assert match, "the docstring has no **Success:** section"
    return match.group(1)


@pytest.mark.parametrize("task_id", [t.id for t in maniladder_ms.default_catalog().filter(implemented=True)])
def test_success_numbers_live_in_params_only(task_id):
    """The numbers of a task's rule live in its catalog row's `params`: the catalog's success text is
    rendered from them, the class reads exactly them, and the docstring's Success section names them
    instead of repeating numbers that could drift."""
    from maniladder_ms.catalog import template_fields
    from mani_skill.utils.registration import REGISTERED_ENVS

    spec = maniladder_ms.default_catalog().get(task_id)
    cls = REGISTERED_ENVS[spec.env_id].cls
    assert set(cls.PARAMS) == set(spec.params), f"{cls.__name__}.PARAMS != the catalog row's params"
    section = _success_section(cls.__doc__)
    assert not any(ch.isdigit() for ch in section), f"{cls.__name__}: a number in the Success section: {section!r}"
    for name, _ in template_fields(spec.success_template):
        assert f"`{name}`" in section, f"{cls.__name__}: the Success section does not name `{name}`"


def test_success_text_is_rendered_from_params():
    from maniladder_ms.catalog import CatalogError, render_success

    assert render_success("within {tol:cm}, tilt < {tilt:deg}, {share:pct} in", dict(tol=0.02, tilt=15, share=0.8)) == \
        "within 2 cm, tilt < 15 deg, 80% in"
    with pytest.raises(CatalogError, match="not in the row's params"):
        render_success("within {tol:cm}", {}, "row X")
    with pytest.raises(CatalogError, match="unknown unit"):
        render_success("within {tol:furlong}", dict(tol=1))


# ---- language instructions (maniladder_ms/data/instructions.yaml) ---------------------------------------------


def test_every_task_has_an_instruction_and_paraphrases(catalog):
    from maniladder_ms.catalog import MAX_INSTRUCTION_WORDS, MIN_PARAPHRASES

    canonical = set()
    for t in catalog:
        texts = t.instructions
        assert t.instruction and len(t.instruction.split()) <= MAX_INSTRUCTION_WORDS, t.id
        assert len(t.paraphrases) >= MIN_PARAPHRASES, t.id
        assert len({x.casefold().rstrip(".") for x in texts}) == len(texts), f"{t.id}: alike texts"
        # what a person says: no success-rule numbers (counts are spelled out: "six blocks")
        assert not any(ch.isdigit() for x in texts for ch in x), f"{t.id}: a number in an instruction"
        canonical.add(t.instruction.casefold())
    assert len(canonical) == len(catalog)  # an instruction names one task


def _instructions_file(tmp_path, edit):
    data = copy.deepcopy(yaml.safe_load((Path(maniladder_ms.__file__).parent / "data" / "instructions.yaml").read_text()))
    edit(data)
    path = tmp_path / "instructions.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


BAD_INSTRUCTIONS = {
    r"no instructions for catalog task\(s\) HangMug": lambda d: d.pop("HangMug"),
    r"PickPlacePen: 3 paraphrase\(s\), expected at least 4": lambda d: d["PickPlacePen"]["paraphrases"].pop(),
    r"PickPlacePen: duplicate instruction": lambda d: d["PickPlacePen"]["paraphrases"].append("pick up the pen and  put it in the tray"),
    r"not in the catalog: PickPlacePencil \(did you mean PickPlacePen\?\)": lambda d: d.update(
        PickPlacePencil=dict(d["PickPlacePen"])),
    r"HangMug: the instruction has 16 words": lambda d: d["HangMug"].update(instruction=" ".join(["word"] * 16)),
    r"HangMug: the same instruction as PickPlacePen": lambda d: d["HangMug"].update(
        instruction=d["PickPlacePen"]["instruction"]),
    r"HangMug: expected exactly the keys": lambda d: d["HangMug"].pop("paraphrases"),
    r"HangMug: instructions must be non-empty strings": lambda d: d["HangMug"]["paraphrases"].append(" "),
}


@pytest.mark.parametrize("message", list(BAD_INSTRUCTIONS))
def test_broken_instructions_fail_loudly(tmp_path, message):
    with pytest.raises(CatalogError, match=message):
        load_catalog(instructions=_instructions_file(tmp_path, BAD_INSTRUCTIONS[message]))


def test_good_instructions_file_loads_beside_the_packaged_catalog(tmp_path):
    path = _instructions_file(tmp_path, lambda d: d["PickPlacePen"].update(instruction="Tidy the pen away."))
    cat = load_catalog(instructions=path)
    assert cat.get("PickPlacePen").instruction == "Tidy the pen away." and len(cat) == 112


def test_paraphrase_draw_is_deterministic_and_covers_every_variant(catalog):
    from maniladder_ms.evaluation import eval_seed

    seeds = [eval_seed(0, k) for k in range(100)]
    for t in (catalog.get("PickPlacePen"), catalog.get("TieKnotHands")):
        drawn = [t.instruction_for(s, "paraphrase") for s in seeds]
        assert drawn == [t.instruction_for(s, "paraphrase") for s in seeds]  # same seed, same text
        assert set(drawn) == set(t.instructions)  # 100 episodes see the canonical and every paraphrase
        assert {t.instruction_for(s) for s in seeds} == {t.instruction}  # the default is the canonical one
    with pytest.raises(ValueError, match="unknown instruction mode 'random'"):
        catalog.get("PickPlacePen").instruction_for(0, "random")
