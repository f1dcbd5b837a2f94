"""Scenario texts shared by the tests."""

# A short warm-up whose thermal nodes have known, short time constants (link 2: 20 min, link 3:
# 30 min) so that 90 minutes cover several of them; the rises are heat.rs' calibrated ones.
FAST_NODES = """
[[node]]
name = "link2"
tau_min = 20.0
rise_saturating = { r0_k = 0.438342, span_k = 5.030472, s0 = 0.0964029 }
[[node]]
name = "link3"
tau_min = 30.0
rise_saturating = { r0_k = 1.602697, span_k = 6.041837, s0 = 0.1241591 }
[[node]]
name = "base"
tau_min = 600.0
rise_k = [0.10, 0.85, 0.50]
"""

WARM_UP_90_MIN = """format = "thermrs-scenario/1"
seed = {seed}
[[run]]
name = "warm"
speed_pct = 30
duration_min = 90
cycle_s = 60
start = "ambient"
"""

# Three 6-hour runs at 30/75/10 % in one recording, a joint whose zero drifts with link 3
# (SPEC §6 ``joint_offset``, 12.8 µrad/K) that the nominal model leaves out (issue #17;
# tests/cli/conftest.py records it, with a replicate: the same protocol, another seed).
THREE_RUNS_JOINT_OFFSET = """format = "thermrs-scenario/1"
name = "three runs, a joint zero that drifts with link 3"
seed = 17
[[run]]
name = "s30"
speed_pct = 30
duration_min = 360
cycle_s = 300
start = "ambient"
[[run]]
name = "s75"
speed_pct = 75
duration_min = 360
cycle_s = 300
start = "continue"
idle_before_min = 240
[[run]]
name = "s10"
speed_pct = 10
duration_min = 360
cycle_s = 300
start = "continue"
[ambient]
start_c = 23.0
noise_c = 0.02
[camera]
mode = "visits"
frames_per_visit = 1
[output]
compression = "lz4"
[[node]]
name = "link2"
tau_min = 60.0
rise_saturating = { r0_k = 0.438342, span_k = 5.030472, s0 = 0.0964029 }
[[node]]
name = "link3"
tau_min = 90.0
rise_saturating = { r0_k = 1.602697, span_k = 6.041837, s0 = 0.1241591 }
[[node]]
name = "base"
tau_min = 600.0
rise_k = [0.10, 0.85, 0.50]
[[effect]]
name = "joint_offset"
joint = "joint_a3"
temperature = "link3"
urad_per_k = 12.8
"""
#: Visits per camera and run of :data:`THREE_RUNS_JOINT_OFFSET`: 360 min / 300 s.
THREE_RUNS_VISITS = 72
