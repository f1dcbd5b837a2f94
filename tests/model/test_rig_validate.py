"""Rig-file validation (SPEC §3) through the Python API and ``thermrs rig`` (SPEC §7): bad rigs,
invalid TOML, unreadable files, a laser that misses its pose's camera.

Every bad rig is built from the paper rig: its TOML is parsed with :mod:`tomllib`, one thing is
changed in the resulting dict (see ``BAD_RIGS``) and the dict is written back with the small TOML
writer of :mod:`tests.support.rig_mutations`. The error must be a :class:`thermrs.RigError` whose
single-line message is ``rig SOURCE[ line N]: KEY: what is wrong``, naming the key; the CLI must
print that message as one ``thermrs: error: ...`` line on stderr and exit 2, with no traceback.
The tables of bad rigs go through the CLI's entry point in this process; a few cases (a laser
missing its camera, ``--json``, a missing file) through ``python -m thermrs`` in a child.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
import thermrs

from tests.support.rig_mutations import (
    GOOD,
    GOOD_TEXT,
    MISSES,
    SOURCE,
    Mutation,
    append,
    assert_cli_rejects,
    assert_names_key,
    both,
    drop,
    message_detail,
    mutated_text,
    put,
    rename,
    run_rig_cli,
    scale_vec,
)

# --------------------------------------------------------------------------------------------
# The table of bad rigs: (mutation, key the error must name first, further text it must contain)
# --------------------------------------------------------------------------------------------


def bad(case_id: str, mutate: Mutation, key: str, *says: str) -> Any:
    """One bad rig: ``key`` is "" where the message names the key in ``says`` instead (a
    top-level key that is missing). (pytest.param's return type is private.)"""
    return pytest.param(mutate, key, says, id=case_id)


_CAM0 = GOOD["camera"][0]


_ROW = GOOD["robot"]["dh"][0]


BAD_RIGS = [
    # --- unknown keys: a typo must not pass, not even for optional keys -----------------------
    bad("unknown-top-level-name-typo", rename("name", "nmae"), "nmae", "unknown field `nmae`"),
    bad("unknown-top-level-table", put("expanson", {"alpha_per_k": 2.3e-5}), "expanson"),
    bad("unknown-top-level-ambient-typo", rename("ambient", "ambiant"), "ambiant"),
    bad("unknown-top-level-thermal-typo", rename("thermal", "thermel"), "thermel"),
    bad(
        "unknown-robot",
        rename("robot.joint_states_topic", "joint_state_topic"),
        "robot.joint_state_topic",
        "unknown field",
    ),
    bad("unknown-dh-row", put("robot.dh[2].offset_deg", 0.0), "robot.dh[2].offset_deg"),
    bad(
        "max-rates-five",
        put("robot.max_rate_deg_s", [150.0] * 5),
        "robot.max_rate_deg_s",
        "has 5 rates, expected 6",
    ),
    bad(
        "max-rate-zero",
        put("robot.max_rate_deg_s", [150.0, 150.0, 0.0, 280.0, 290.0, 600.0]),
        "robot.max_rate_deg_s[2]",
        "positive rate",
    ),
    bad("unknown-dh-row-typo", rename("robot.dh[5].d_mm", "dmm"), "robot.dh[5].dmm"),
    bad("unknown-laser", rename("laser.direction", "dir"), "laser.dir"),
    bad("unknown-camera", rename("camera[1].topic", "tpoic"), "camera[1].tpoic", "`tpoic`"),
    bad("unknown-camera-extra", put("camera[0].focal_mm", 8.0), "camera[0].focal_mm"),
    bad("unknown-pose", put("pose[0].joints_rad", [0.0] * 6), "pose[0].joints_rad"),
    bad("unknown-thermal", rename("thermal.offset_c", "offset"), "thermal.offset"),
    bad("unknown-thermal-roi-list", rename("thermal.roi", "rois"), "thermal.rois"),
    bad("unknown-roi", rename("thermal.roi[1].rect_px", "rect"), "thermal.roi[1].rect"),
    bad("unknown-ambient", put("ambient.frame_id", "base"), "ambient.frame_id"),
    bad("unknown-expansion", put("expansion.alpha", 2.3e-5), "expansion.alpha"),
    bad(
        "unknown-expansion-length-list", rename("expansion.length", "lengths"), "expansion.lengths"
    ),
    bad(
        "unknown-expansion-length",
        rename("expansion.length[1].temperature", "temp"),
        "expansion.length[1].temp",
    ),
    bad(
        "unknown-tolerance",
        put("tolerances", {"dh_mm": 0.1}),
        "tolerances.dh_mm",
        "unknown field",
    ),
    bad(
        "tolerance-negative",
        put("tolerances", {"ir_gain": -0.01}),
        "tolerances.ir_gain",
        "standard uncertainty",
    ),
    bad("tolerance-nan", put("tolerances", {"ir_clock_s": float("nan")}), "tolerances.ir_clock_s"),
    # --- missing required keys ----------------------------------------------------------------
    bad("missing-format", drop("format"), "", "missing field `format`"),
    bad("missing-robot", drop("robot"), "", "missing field `robot`"),
    bad("missing-laser", drop("laser"), "", "missing field `laser`"),
    bad("missing-camera", drop("camera"), "", "missing field `camera`"),
    bad("missing-pose", drop("pose"), "", "missing field `pose`"),
    bad("missing-expansion", drop("expansion"), "", "missing field `expansion`"),
    bad("missing-robot.model", drop("robot.model"), "robot", "missing field `model`"),
    bad("missing-robot.joint_names", drop("robot.joint_names"), "robot", "`joint_names`"),
    bad("missing-robot.topic", drop("robot.joint_states_topic"), "robot", "`joint_states_topic`"),
    bad("missing-robot.dh", drop("robot.dh"), "robot", "missing field `dh`"),
    bad("missing-dh.sign", drop("robot.dh[3].sign"), "robot.dh[3]", "missing field `sign`"),
    bad("missing-dh.a_mm", drop("robot.dh[0].a_mm"), "robot.dh[0]", "missing field `a_mm`"),
    bad("missing-laser.origin_mm", drop("laser.origin_mm"), "laser", "`origin_mm`"),
    bad("missing-laser.direction", drop("laser.direction"), "laser", "missing field `direction`"),
    bad("missing-camera.topic", drop("camera[0].topic"), "camera[0]", "missing field `topic`"),
    bad("missing-camera.pose", drop("camera[1].pose"), "camera[1]", "missing field `pose`"),
    bad("missing-camera.size_px", drop("camera[1].size_px"), "camera[1]", "`size_px`"),
    bad("missing-pose.joints_deg", drop("pose[1].joints_deg"), "pose[1]", "`joints_deg`"),
    bad("missing-thermal.scale", drop("thermal.scale"), "thermal", "missing field `scale`"),
    bad("missing-thermal.topic", drop("thermal.topic"), "thermal", "missing field `topic`"),
    bad("missing-roi.rect_px", drop("thermal.roi[2].rect_px"), "thermal.roi[2]", "`rect_px`"),
    bad("missing-ambient.topic", drop("ambient.topic"), "ambient", "missing field `topic`"),
    bad("missing-alpha_per_k", drop("expansion.alpha_per_k"), "expansion", "`alpha_per_k`"),
    bad("missing-reference_c", drop("expansion.reference_c"), "expansion", "`reference_c`"),
    bad(
        "missing-length.temperature",
        drop("expansion.length[0].temperature"),
        "expansion.length[0]",
        "missing field `temperature`",
    ),
    # --- wrong types --------------------------------------------------------------------------
    bad("type-format-number", put("format", 1), "format", "invalid type"),
    bad("type-name-number", put("name", 3), "name", "invalid type"),
    bad("type-model-array", put("robot.model", ["KUKA"]), "robot.model", "invalid type"),
    bad("type-joint_names-string", put("robot.joint_names", "joint_a1"), "robot.joint_names"),
    bad("type-dh-not-array", put("robot.dh", _ROW), "robot.dh", "invalid type"),
    bad("type-a_mm-string", put("robot.dh[1].a_mm", "650.0"), "robot.dh[1].a_mm", "string"),
    bad("type-sign-float", put("robot.dh[4].sign", -1.0), "robot.dh[4].sign", "floating point"),
    bad("type-camera-topic-number", put("camera[0].topic", 5), "camera[0].topic", "integer"),
    bad("type-pose-name-number", put("pose[0].name", 1), "pose[0].name", "invalid type"),
    bad("type-camera-not-array", put("camera", _CAM0), "camera", "invalid type"),
    bad("type-ambient-string", put("ambient", "/ambient/temperature"), "ambient", "invalid type"),
    bad("type-thermal-scale-bool", put("thermal.scale", True), "thermal.scale", "invalid type"),
    bad(
        "type-alpha_per_k-string",
        put("expansion.alpha_per_k", "2.32e-5"),
        "expansion.alpha_per_k",
        "string",
    ),
    bad(
        "type-length-name-number",
        put("expansion.length[0].name", 2),
        "expansion.length[0].name",
        "invalid type",
    ),
    bad(
        "length-centre_mm-2",
        put("camera[0].centre_mm", [1017.2, -213.58]),
        "camera[0].centre_mm",
        "has 2 entries",
    ),
    bad(
        "length-pixel_pitch-1",
        put("camera[1].pixel_pitch_um", [8.6]),
        "camera[1].pixel_pitch_um",
        "has 1 entries",
    ),
    bad(
        "length-joints_deg-5",
        put("pose[1].joints_deg", [4.23, 17.5462, -16.884, -89.516, -57.7451]),
        "pose[1].joints_deg",
        "has 5 entries",
    ),
    bad(
        "length-rect_px-3",
        put("thermal.roi[0].rect_px", [40, 60, 120]),
        "thermal.roi[0].rect_px",
        "has 3 entries",
    ),
    # An array with one entry too many must not be silently truncated to its first entries.
    *(
        bad(
            f"too-long-{path}",
            append(path, extra),
            path,
            f"has {length} entries",
        )
        for path, extra, length in [
            ("laser.direction", 0.0, 4),
            ("laser.origin_mm", 0.0, 4),
            ("camera[0].centre_mm", 0.0, 4),
            ("camera[1].x_axis", 0.0, 4),
            ("camera[0].pixel_pitch_um", 8.6, 3),
            ("camera[1].size_px", 1, 3),
            ("pose[0].joints_deg", 90.0, 7),
            ("thermal.size_px", 1, 3),
            ("thermal.roi[0].rect_px", 0, 5),
        ]
    ),
    bad(
        "too-long-direction-with-string",
        append("laser.direction", "x"),
        "laser.direction[3]",
        "invalid type",
    ),
    bad("float-size_px", put("camera[0].size_px", [752.0, 582]), "camera[0].size_px[0]", "float"),
    bad("float-thermal-size_px", put("thermal.size_px", [320, 240.5]), "thermal.size_px[1]"),
    bad(
        "float-rect_px",
        put("thermal.roi[0].rect_px", [40, 60, 120.5, 110]),
        "thermal.roi[0].rect_px[2]",
    ),
    # --- format string ------------------------------------------------------------------------
    bad("format-v2", put("format", "thermrs-rig/2"), "format", '"thermrs-rig/2"'),
    bad("format-empty", put("format", ""), "format", "thermrs-rig/1"),
    bad("format-case", put("format", "THERMRS-RIG/1"), "format"),
    bad("format-other", put("format", "urdf"), "format"),
    # --- robot --------------------------------------------------------------------------------
    bad("robot-model-empty", put("robot.model", ""), "robot.model", "empty"),
    bad(
        "joint_names-5",
        put("robot.joint_names", [f"joint_a{i}" for i in range(1, 6)]),
        "robot.joint_names",
        "5",
    ),
    bad("joint_names-7", append("robot.joint_names", "joint_a7"), "robot.joint_names", "7"),
    bad(
        "joint_names-duplicate",
        put("robot.joint_names[5]", "joint_a5"),
        "robot.joint_names[5]",
        "twice",
    ),
    bad("joint_names-empty", put("robot.joint_names[2]", ""), "robot.joint_names[2]", "empty"),
    bad(
        "joint_states_topic-empty", put("robot.joint_states_topic", ""), "robot.joint_states_topic"
    ),
    bad("dh-5-rows", drop("robot.dh[5]"), "robot.dh", "5 rows"),
    bad("dh-7-rows", append("robot.dh", _ROW), "robot.dh", "7 rows"),
    bad("dh-sign-0", put("robot.dh[0].sign", 0), "robot.dh[0].sign", "1 or -1"),
    bad("dh-sign-2", put("robot.dh[4].sign", 2), "robot.dh[4].sign", "1 or -1"),
    bad("dh-sign-minus-2", put("robot.dh[5].sign", -2), "robot.dh[5].sign"),
    bad("dh-a_mm-nan", put("robot.dh[1].a_mm", math.nan), "robot.dh[1].a_mm", "finite"),
    bad("dh-d_mm-inf", put("robot.dh[3].d_mm", -math.inf), "robot.dh[3].d_mm", "finite"),
    # --- laser --------------------------------------------------------------------------------
    bad("laser-direction-zero", put("laser.direction", [0.0] * 3), "laser.direction", "zero"),
    bad("laser-direction-not-unit", scale_vec("laser.direction", 1.01), "laser.direction", "unit"),
    bad(
        "laser-direction-rounded",
        put("laser.direction", [0.39, -0.08, -0.92]),
        "laser.direction",
        "unit",
    ),
    bad("laser-direction-nan", put("laser.direction[1]", math.nan), "laser.direction[1]"),
    bad("laser-origin-inf", put("laser.origin_mm[2]", math.inf), "laser.origin_mm[2]", "finite"),
    # --- cameras ------------------------------------------------------------------------------
    bad("camera-none", put("camera", []), "camera", "[[camera]]"),
    bad("camera-x_axis-zero", put("camera[1].x_axis", [0.0] * 3), "camera[1].x_axis", "zero"),
    bad("camera-x_axis-not-unit", put("camera[0].x_axis", [0.0, 0.0, 2.0]), "camera[0].x_axis"),
    bad("camera-y_axis-zero", put("camera[0].y_axis", [0.0] * 3), "camera[0].y_axis", "zero"),
    bad("camera-y_axis-not-unit", scale_vec("camera[1].y_axis", 0.5), "camera[1].y_axis", "unit"),
    bad(
        "camera-y_axis-not-orthogonal",
        put("camera[0].y_axis", [0.0, 0.6, 0.8]),
        "camera[0].y_axis",
        "orthogonal",
    ),
    bad(
        "camera-y_axis-equals-x_axis",
        put("camera[1].y_axis", GOOD["camera"][1]["x_axis"]),
        "camera[1].y_axis",
        "orthogonal",
    ),
    bad("camera-centre-nan", put("camera[0].centre_mm[2]", math.nan), "camera[0].centre_mm[2]"),
    bad("pixel_pitch-zero", put("camera[0].pixel_pitch_um[0]", 0.0), "camera[0].pixel_pitch_um[0]"),
    bad(
        "pixel_pitch-negative",
        put("camera[1].pixel_pitch_um[1]", -8.3),
        "camera[1].pixel_pitch_um[1]",
        "positive",
    ),
    bad(
        "pixel_pitch-nan",
        put("camera[1].pixel_pitch_um[0]", math.nan),
        "camera[1].pixel_pitch_um[0]",
    ),
    bad("size_px-zero", put("camera[1].size_px[0]", 0), "camera[1].size_px[0]", "positive"),
    bad("size_px-negative", put("camera[0].size_px[1]", -582), "camera[0].size_px[1]", "positive"),
    bad("camera-pose-unknown", put("camera[1].pose", "C"), "camera[1].pose", '"C"', "[[pose]]"),
    bad("camera-pose-wrong-case", put("camera[0].pose", "a"), "camera[0].pose", '"a"'),
    bad("camera-name-duplicate", put("camera[1].name", "A"), "camera[1].name", "twice"),
    bad("camera-name-empty", put("camera[0].name", ""), "camera[0].name", "empty"),
    bad("camera-topic-empty", put("camera[1].topic", ""), "camera[1].topic", "empty"),
    bad(
        "camera-topic-duplicate",
        put("camera[1].topic", "/ccd_a/image_raw"),
        "camera[1].topic",
        "twice",
    ),
    bad(
        "camera-topic-is-joint-states",
        put("camera[0].topic", "/joint_states"),
        "camera[0].topic",
        "twice",
    ),
    # --- poses --------------------------------------------------------------------------------
    bad("pose-none", put("pose", []), "pose", "[[pose]]"),
    bad("pose-name-duplicate", put("pose[1].name", "A"), "pose[1].name", "twice"),
    bad("pose-name-empty", put("pose[0].name", ""), "pose[0].name", "empty"),
    bad("pose-joint-nan", put("pose[0].joints_deg[4]", math.nan), "pose[0].joints_deg[4]"),
    # --- thermal camera and its ROIs ----------------------------------------------------------
    bad("thermal-scale-zero", put("thermal.scale", 0.0), "thermal.scale", "non-zero"),
    bad("thermal-scale-int-zero", put("thermal.scale", 0), "thermal.scale"),
    bad("thermal-scale-nan", put("thermal.scale", math.nan), "thermal.scale"),
    bad("thermal-offset-inf", put("thermal.offset_c", math.inf), "thermal.offset_c", "finite"),
    bad("thermal-size_px-zero", put("thermal.size_px[0]", 0), "thermal.size_px[0]", "positive"),
    bad("thermal-size_px-negative", put("thermal.size_px[1]", -240), "thermal.size_px[1]"),
    bad("thermal-topic-empty", put("thermal.topic", ""), "thermal.topic", "empty"),
    bad(
        "thermal-topic-duplicate",
        put("thermal.topic", "/ccd_b/image_raw"),
        "thermal.topic",
        "twice",
    ),
    bad(
        "roi-x1-outside",
        put("thermal.roi[1].rect_px", [140, 40, 321, 90]),
        "thermal.roi[1].rect_px",
        "outside",
        "320x240",
    ),
    bad(
        "roi-y1-outside",
        put("thermal.roi[2].rect_px", [60, 170, 140, 241]),
        "thermal.roi[2].rect_px",
        "outside",
    ),
    bad(
        "roi-entirely-outside",
        put("thermal.roi[0].rect_px", [400, 300, 420, 320]),
        "thermal.roi[0].rect_px",
    ),
    bad(
        "roi-outside-shrunk-frame",
        put("thermal.size_px", [100, 100]),
        "thermal.roi[0].rect_px",
        "100x100",
    ),
    bad(
        "roi-empty-x0-eq-x1",
        put("thermal.roi[0].rect_px", [120, 60, 120, 110]),
        "thermal.roi[0].rect_px",
        "empty",
    ),
    bad(
        "roi-empty-y0-eq-y1",
        put("thermal.roi[1].rect_px", [140, 90, 250, 90]),
        "thermal.roi[1].rect_px",
        "empty",
    ),
    bad(
        "roi-inverted",
        put("thermal.roi[2].rect_px", [140, 170, 60, 230]),
        "thermal.roi[2].rect_px",
    ),
    bad(
        "roi-negative-x0",
        put("thermal.roi[0].rect_px", [-1, 60, 120, 110]),
        "thermal.roi[0].rect_px",
    ),
    bad(
        "roi-negative-y0",
        put("thermal.roi[1].rect_px", [140, -40, 250, 90]),
        "thermal.roi[1].rect_px",
    ),
    bad("roi-named-ambient", put("thermal.roi[0].name", "ambient"), "thermal.roi[0].name"),
    bad("roi-name-duplicate", put("thermal.roi[2].name", "link2"), "thermal.roi[2].name", "twice"),
    bad("roi-name-empty", put("thermal.roi[1].name", ""), "thermal.roi[1].name", "empty"),
    # --- ambient ------------------------------------------------------------------------------
    bad("ambient-topic-empty", put("ambient.topic", ""), "ambient.topic", "empty"),
    bad(
        "ambient-topic-duplicate",
        put("ambient.topic", "/thermal/image_raw"),
        "ambient.topic",
        "twice",
    ),
    # --- expansion ----------------------------------------------------------------------------
    bad("alpha-implausible", put("expansion.alpha_per_k", 0.1), "expansion.alpha_per_k"),
    bad("alpha-nan", put("expansion.alpha_per_k", math.nan), "expansion.alpha_per_k", "finite"),
    bad("reference_c-inf", put("expansion.reference_c", math.inf), "expansion.reference_c"),
    *(
        bad(
            f"length-name-{name or 'empty'}",
            put("expansion.length[0].name", name),
            "expansion.length[0].name",
            "not a DH length",
        )
        for name in ("b2", "a7", "a0", "d10", "A2", "a 2", "a02", "")
    ),
    bad(
        "length-listed-twice",
        put("expansion.length[1].name", "a2"),
        "expansion.length[1].name",
        "twice",
    ),
    bad(
        "length-listed-twice-other-temperature",
        append("expansion.length", {"name": "d4", "temperature": "base"}),
        "expansion.length[2].name",
        "twice",
    ),
    bad(
        "length-zero-a4",
        put("expansion.length[0].name", "a4"),
        "expansion.length[0].name",
        '"a4"',
        "0 mm",
    ),
    bad(
        "length-zero-d2", put("expansion.length[1].name", "d2"), "expansion.length[1].name", "0 mm"
    ),
    bad(
        "length-temperature-no-roi",
        put("expansion.length[0].temperature", "link9"),
        "expansion.length[0].temperature",
        '"link9"',
    ),
    bad(
        "length-temperature-wrong-case",
        put("expansion.length[1].temperature", "Link3"),
        "expansion.length[1].temperature",
    ),
    bad(
        "length-temperature-ambient-without-ambient",
        both(drop("ambient"), put("expansion.length[1].temperature", "ambient")),
        "expansion.length[1].temperature",
        '"ambient"',
    ),
    bad(
        "length-temperature-roi-without-thermal",
        both(drop("thermal"), drop("ambient")),
        "expansion.length[0].temperature",
        '"link2"',
    ),
]


# --------------------------------------------------------------------------------------------
# Bad rigs: the Python API
# --------------------------------------------------------------------------------------------


def test_error_hierarchy() -> None:
    assert issubclass(thermrs.RigError, thermrs.ThermrsError)
    assert issubclass(thermrs.InputError, thermrs.ThermrsError)
    assert not issubclass(thermrs.InputError, thermrs.RigError)


@pytest.mark.parametrize(("mutate", "key", "says"), BAD_RIGS)
def test_bad_rig_is_rejected_naming_the_key(
    mutate: Mutation, key: str, says: tuple[str, ...]
) -> None:
    text = mutated_text(mutate)
    with pytest.raises(thermrs.RigError) as info:
        thermrs.Rig.from_toml(text, source_name=SOURCE)
    assert_names_key(str(info.value), SOURCE, key, says)


@pytest.mark.parametrize(
    ("mutate", "typo"),
    [
        pytest.param(rename("camera[1].topic", "tpoic"), "tpoic", id="camera"),
        pytest.param(put("robot.dh[2].offset_deg", 0.0), "offset_deg", id="dh-row"),
        pytest.param(rename("thermal.scale", "scael"), "scael", id="thermal"),
        pytest.param(rename("expansion.length[1].temperature", "temp"), "temp", id="length"),
    ],
)
def test_unknown_key_reports_its_line(mutate: Mutation, typo: str) -> None:
    text = mutated_text(mutate)
    lines = text.splitlines()
    want = next(i for i, line in enumerate(lines, 1) if line.startswith(f"{typo} = "))
    with pytest.raises(thermrs.RigError) as info:
        thermrs.Rig.from_toml(text, source_name=SOURCE)
    line, detail = message_detail(str(info.value), SOURCE)
    assert line == want, str(info.value)
    assert f"unknown field `{typo}`" in detail


def test_load_rig_file_error_names_the_key(tmp_path: Path) -> None:
    path = tmp_path / "typo.toml"
    path.write_text(mutated_text(rename("camera[1].topic", "tpoic")), encoding="utf-8")
    with pytest.raises(thermrs.RigError) as info:
        thermrs.load_rig(path)
    assert_names_key(str(info.value), str(path), "camera[1].tpoic", ())


@pytest.mark.parametrize("kind", ["missing", "directory"])
def test_unreadable_rig_file_is_an_input_error_naming_the_path(tmp_path: Path, kind: str) -> None:
    path = tmp_path / "nowhere.toml"
    if kind == "directory":
        path.mkdir()
    for load in (thermrs.load_rig, thermrs.Rig.from_path):
        with pytest.raises(thermrs.ThermrsError) as info:
            load(path)
        assert isinstance(info.value, thermrs.InputError)
        assert str(path) in str(info.value)
        assert "\n" not in str(info.value)


# Syntactically invalid TOML: (old, new) replacement in the shipped file, and a text that is on
# the offending line (unique in the result) so the reported line can be checked.
SYNTAX_ERRORS = [
    pytest.param(
        '"/ccd_a/image_raw"',
        '"/ccd_a/image_raw',
        'topic = "/ccd_a/image_raw\n',
        "",
        id="unterminated-string",
    ),
    pytest.param("scale = 0.01", "scale 0.01", "scale 0.01", "", id="missing-equals"),
    pytest.param("scale = 0.01", "scale = 0.0.1", "scale = 0.0.1", "", id="bad-float"),
    pytest.param("[ambient]", "[[[ambient]", "[[[ambient]", "", id="bad-header"),
    pytest.param("[ambient]", "[ambient", "[ambient\n", "", id="unclosed-header"),
    pytest.param(
        'format = "thermrs-rig/1"',
        'format = "thermrs-rig/1"\nformat = "thermrs-rig/1"',
        '\nformat = "thermrs-rig/1"\n',
        "format",
        id="duplicate-key",
    ),
    pytest.param(
        'topic = "/ambient/temperature"',
        'topic = "/ambient/temperature"\ntopic = "/ambient/other"',
        'topic = "/ambient/other"',
        "topic",
        id="duplicate-key-in-table",
    ),
    pytest.param(
        "[expansion]",
        '[robot]\nmodel = "x"\n\n[expansion]',
        '[robot]\nmodel = "x"',
        "robot",
        id="duplicate-table",
    ),
]


def _syntax_error_text(old: str, new: str, marker: str) -> tuple[str, int]:
    """The shipped rig with ``old`` replaced by ``new``, and the 1-based line of ``marker``
    (leading newlines in ``marker`` only make it unique and are not counted)."""
    assert GOOD_TEXT.count(old) >= 1
    text = GOOD_TEXT.replace(old, new, 1)
    assert text.count(marker) == 1, marker
    start = text.index(marker) + len(marker) - len(marker.lstrip("\n"))
    return text, text[:start].count("\n") + 1


@pytest.mark.parametrize(("old", "new", "marker", "names"), SYNTAX_ERRORS)
def test_invalid_toml_is_a_one_line_rig_error_with_its_line(
    old: str, new: str, marker: str, names: str
) -> None:
    text, want_line = _syntax_error_text(old, new, marker)
    with pytest.raises(thermrs.RigError) as info:
        thermrs.Rig.from_toml(text, source_name=SOURCE)
    line, detail = message_detail(str(info.value), SOURCE)
    assert line == want_line, str(info.value)
    if names:
        assert names in detail, f"the message does not name {names!r}: {info.value}"


# --------------------------------------------------------------------------------------------
# The laser missing its pose's camera: valid file, but `check` (and the CLI) reject it
# --------------------------------------------------------------------------------------------


def test_laser_missing_its_camera_fails_check() -> None:
    rig = thermrs.Rig.from_toml(mutated_text(MISSES), source_name=SOURCE)
    with pytest.raises(thermrs.RigError) as info:
        rig.check()
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"rig {SOURCE}: ")
    assert 'pose "A"' in message and 'camera "A"' in message


@pytest.mark.parametrize("json_flag", [[], ["--json"]], ids=["tables", "json"])
def test_cli_laser_missing_its_camera_exits_2(tmp_path: Path, json_flag: list[str]) -> None:
    path = tmp_path / "rotated.toml"
    path.write_text(mutated_text(MISSES), encoding="utf-8")
    message = assert_cli_rejects(run_rig_cli(str(path), *json_flag))
    assert message.startswith(f"rig {path}: ")
    assert 'pose "A"' in message and 'camera "A"' in message


# --------------------------------------------------------------------------------------------
# Bad rigs: the CLI
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("mutate", "key", "says"), BAD_RIGS)
def test_cli_rejects_bad_rig_in_one_line(
    tmp_path: Path, mutate: Mutation, key: str, says: tuple[str, ...]
) -> None:
    path = tmp_path / "rig.toml"
    path.write_text(mutated_text(mutate), encoding="utf-8")
    message = assert_cli_rejects(run_rig_cli(str(path), in_process=True))
    assert_names_key(message, str(path), key, says)


def test_cli_bad_rig_with_json_prints_no_json(tmp_path: Path) -> None:
    path = tmp_path / "rig.toml"
    path.write_text(mutated_text(put("thermal.scale", 0.0)), encoding="utf-8")
    message = assert_cli_rejects(run_rig_cli(str(path), "--json"))
    assert_names_key(message, str(path), "thermal.scale", ())


@pytest.mark.parametrize(("old", "new", "marker", "names"), SYNTAX_ERRORS)
def test_cli_rejects_invalid_toml_in_one_line(
    tmp_path: Path, old: str, new: str, marker: str, names: str
) -> None:
    text, want_line = _syntax_error_text(old, new, marker)
    path = tmp_path / "rig.toml"
    path.write_text(text, encoding="utf-8")
    message = assert_cli_rejects(run_rig_cli(str(path), in_process=True))
    line, detail = message_detail(message, str(path))
    assert line == want_line, message
    if names:
        assert names in detail, message


def test_cli_missing_rig_file_exits_2_naming_the_path(tmp_path: Path) -> None:
    path = tmp_path / "absent.toml"
    message = assert_cli_rejects(run_rig_cli(str(path)))
    assert str(path) in message
