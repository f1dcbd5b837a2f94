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
