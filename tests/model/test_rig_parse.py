"""Rig files that must load (SPEC §3): the paper rig, embedded and shared, through
``load_rig``, ``Rig.from_toml`` and ``Rig.from_dict``; valid variants of it (optional tables
left out, integers for floats, a direction unit within tolerance …); optional keys and the
documented defaults of ``[tolerances]``; and the test's own TOML writer, which writes the
variants (:mod:`tests.support.rig_mutations`)."""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import pytest
import thermrs

from tests.support.rig_mutations import (
    GOOD,
    GOOD_TEXT,
    SHARED_RIG,
    SOURCE,
    Mutation,
    append,
    both,
    drop,
    dumps_toml,
    good_doc,
    mutated_text,
    put,
    requires_shared,
    scale_vec,
)

# --------------------------------------------------------------------------------------------
# The writer itself, and rigs that must load
# --------------------------------------------------------------------------------------------


def test_writer_round_trips_the_paper_rig() -> None:
    text = dumps_toml(good_doc())
    assert tomllib.loads(text) == GOOD
    written = thermrs.Rig.from_toml(text, source_name=SOURCE)
    shipped = thermrs.Rig.from_toml(GOOD_TEXT, source_name=SOURCE)
    assert written.to_dict() == shipped.to_dict()


def test_writer_handles_awkward_values() -> None:
    doc = {"k": ['a"b\\c\n\x7f', 1, -0.5, 1e-5, math.inf, True], "t": {"x y": {"z": []}}}
    assert tomllib.loads(dumps_toml(doc)) == doc


def test_embedded_paper_rig_loads() -> None:
    rig = thermrs.load_rig()
    assert [c.name for c in rig.cameras] == ["A", "B"]
    assert sorted(rig.poses) == ["A", "B"]
    assert len(rig.dh) == 6 and len(rig.joint_names) == 6
    assert [r.name for r in rig.rois] == ["link2", "link3", "base"]
    assert rig.ambient_topic == "/ambient/temperature"
    assert rig.mapped_temperatures == ["link2", "link3"]
    assert rig.check()["problems"] == []


def test_from_toml_and_load_rig_agree() -> None:
    from_text = thermrs.Rig.from_toml(GOOD_TEXT, source_name="paper")
    assert from_text.source == "paper"
    assert from_text.to_dict() == thermrs.load_rig(thermrs.default_rig_path()).to_dict()


@requires_shared
def test_shared_paper_rig_loads() -> None:
    rig = thermrs.load_rig(SHARED_RIG)
    assert rig.check()["problems"] == []


GOOD_VARIANTS = [
    pytest.param(
        both(drop("thermal"), drop("ambient"), put("expansion.length", [])),
        id="no-thermal-no-ambient-no-lengths",
    ),
    pytest.param(
        both(drop("thermal"), drop("ambient"), drop("expansion.length")),
        id="no-thermal-no-ambient-length-key-absent",
    ),
    pytest.param(
        both(drop("thermal"), put("expansion.length", [{"name": "a2", "temperature": "ambient"}])),
        id="ambient-only",
    ),
    pytest.param(put("expansion.length[1].temperature", "ambient"), id="length-on-ambient"),
    pytest.param(
        both(
            drop("thermal.roi"),
            put("expansion.length[0].temperature", "ambient"),
            put("expansion.length[1].temperature", "ambient"),
        ),
        id="thermal-without-rois",
    ),
    pytest.param(drop("name"), id="no-rig-name"),
    pytest.param(put("thermal.roi[0].rect_px", [0, 0, 320, 240]), id="roi-whole-frame"),
    pytest.param(put("thermal.roi[1].rect_px", [319, 239, 320, 240]), id="roi-last-pixel"),
    pytest.param(put("robot.dh[1].a_mm", 650), id="integer-for-float"),
    pytest.param(put("thermal.scale", -0.01), id="negative-thermal-scale"),
    pytest.param(scale_vec("laser.direction", 1 + 1e-8), id="direction-within-tolerance"),
    pytest.param(append("pose", {"name": "home", "joints_deg": [0.0] * 6}), id="extra-pose"),
]


@pytest.mark.parametrize("mutate", GOOD_VARIANTS)
def test_valid_variants_load(mutate: Mutation) -> None:
    rig = thermrs.Rig.from_toml(mutated_text(mutate), source_name=SOURCE)
    assert [c.name for c in rig.cameras] == ["A", "B"]


def test_rated_joint_rates_are_optional_and_leave_the_rig_hash_alone() -> None:
    """``robot.max_rate_deg_s`` is read when given; a rig without it hashes as before (its
    JSON leaves the key out), so datasets extracted earlier keep their rig."""
    rates = [152.0, 152.0, 152.0, 284.0, 293.0, 604.0]
    rig = thermrs.Rig.from_toml(
        mutated_text(put("robot.max_rate_deg_s", rates)), source_name=SOURCE
    )
    assert rig.max_rate_deg_s == tuple(rates)
    plain = thermrs.load_rig()
    assert plain.max_rate_deg_s is None
    assert "max_rate_deg_s" not in plain._native.to_json()


def test_rig_without_thermal_and_ambient_has_no_temperatures() -> None:
    text = mutated_text(both(drop("thermal"), drop("ambient"), put("expansion.length", [])))
    rig = thermrs.Rig.from_toml(text, source_name=SOURCE)
    assert rig.rois == [] and rig.thermal_topic is None and rig.ambient_topic is None
    assert rig.lengths == [] and rig.mapped_temperatures == []


# --------------------------------------------------------------------------------------------
# Defaults and round trips
# --------------------------------------------------------------------------------------------


def _documented_defaults() -> dict[str, float]:
    """The defaults docs/tolerances.md states, each beside its published source."""
    doc = (Path(__file__).parents[2] / "docs" / "tolerances.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| `(\w+)` \| ([0-9.]+) \|", doc, flags=re.M)
    return {k: float(v) for k, v in rows}


def test_tolerances_default_to_the_documented_values_and_a_table_overrides_some() -> None:
    # SPEC §3 [tolerances]: standard uncertainties; a file without the section takes the
    # defaults docs/tolerances.md sources, and knows it took them.
    # The embedded paper rig states its own; without the section the defaults apply.
    assert thermrs.load_rig().tolerances_stated is True
    bare = GOOD_TEXT[: GOOD_TEXT.index("\n# How well this set-up is known")]
    r = thermrs.Rig.from_toml(bare)
    documented = _documented_defaults()
    assert len(documented) == 11
    assert r.tolerances == documented
    assert r.tolerances_stated is False
    assert "tolerances" not in r.to_dict()
    text = bare + "\n[tolerances]\nir_gain = 0.02\nir_clock_s = 0\n"
    stated = thermrs.Rig.from_toml(text)
    t = stated.tolerances
    assert t["ir_gain"] == 0.02 and t["ir_clock_s"] == 0.0
    assert t["length_mm"] == documented["length_mm"]
    assert stated.tolerances_stated is True
    # A stated section survives a round trip; an absent one stays absent.
    assert thermrs.Rig.from_dict(stated.to_dict()).tolerances_stated is True
    assert thermrs.Rig.from_dict(r.to_dict()).tolerances_stated is False


def test_a_rig_from_its_own_data_is_the_same_rig() -> None:
    r = thermrs.load_rig()
    again = thermrs.Rig.from_dict(r.to_dict())
    assert again.to_dict() == r.to_dict()
    d = r.to_dict()
    d["camera"][0]["x_axis"] = [0.0, 0.0, 2.0]
    with pytest.raises(thermrs.RigError, match=r"camera\[0\]\.x_axis"):
        thermrs.Rig.from_dict(d)
