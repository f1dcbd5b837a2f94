"""Synthetic visit series with known α and autocorrelated errors, on several rig geometries.

Used by the interval-coverage test (tests/test_fit.py) and benchmark
(benchmarks/bench_coverage.py). The truth is set here, independently of the estimator: spot
positions come from the forward model at a chosen true α and temperature trajectories, plus
unknown per-(run, camera) mounting offsets, plus visit errors that are AR(1) along each chip
axis from visit to visit and correlated between u and v within a visit, 1–3 µm.

Random rigs (:func:`random_rig`) are KR 16-like six-axis arms with randomised link lengths,
taught poses and laser mounting; each chip is placed where the laser meets it, at a random
distance along the ray and a random tilt, with the Robotics Toolbox's forward kinematics (not
thermrs'), as fixtures/make_ur5_rig.py does for the UR5 fixture.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import polars as pl
import thermrs
from thermrs import ForwardModel

from tests.support.rigs import UR5, camera, pose, rig_toml


def random_rig(rng: np.random.Generator) -> thermrs.Rig:
    """A random KR 16-like rig whose two chips each sit in the laser's path at their pose."""
    import roboticstoolbox as rtb

    s = [float(v) for v in rng.uniform(0.7, 1.3, 5)]
    dh = [  # a_mm, alpha_deg, d_mm, theta_offset_deg, sign
        (260.0 * s[0], 90.0, 675.0 * s[1], 0.0, 1),
        (680.0 * s[2], 0.0, 0.0, 0.0, 1),
        (35.0 * s[3], -90.0, 0.0, 0.0, 1),
        (0.0, 90.0, -670.0 * s[4], 0.0, 1),
        (0.0, 90.0, 0.0, 180.0, -1),
        (0.0, 0.0, -158.0, 0.0, 1),
    ]
    robot = rtb.DHRobot(
        [
            rtb.RevoluteDH(a=a, alpha=np.radians(al), d=d, offset=np.radians(off), flip=sg == -1)
            for a, al, d, off, sg in dh
        ]
    )
    origin = rng.uniform(-60, 60, 3)
    direction = np.array([*rng.uniform(-0.3, 0.3, 2), -1.0])
    direction /= np.linalg.norm(direction)
    cams, poses = [], []
    for k, name in enumerate(("A", "B")):
        q = np.array(
            [
                rng.uniform(-60, 60),
                rng.uniform(-110, -40),
                rng.uniform(60, 130),
                rng.uniform(-30, 30),
                rng.uniform(-60, 60),
                rng.uniform(-90, 90),
            ]
        )
        t = robot.fkine(np.radians(q)).A
        o = t[:3, :3] @ origin + t[:3, 3]
        d = t[:3, :3] @ direction
        centre = o + rng.uniform(60, 200) * d
        # The chip's normal tilted up to 25° off the ray, its axes turned at random about it.
        perp = np.cross(d, rng.normal(size=3))
        perp /= np.linalg.norm(perp)
        tilt = np.radians(rng.uniform(0, 25))
        normal = np.cos(tilt) * d + np.sin(tilt) * perp
        x = np.cross(normal, rng.normal(size=3))
        x /= np.linalg.norm(x)
        y = np.cross(normal, x)
        cams.append(
            camera(name, f"/ccd_{k}/image_raw", f"P{k}", centre, x, y, (8.6, 8.3), (752, 582))
        )
        poses.append(pose(f"P{k}", q))
    text = rig_toml(
        name="random KR 16-like rig (coverage study)",
        model="random",
        joint_names=["a1", "a2", "a3", "a4", "a5", "a6"],
        dh=dh,
        laser_origin_mm=origin,
        laser_direction=direction,
        cameras=cams,
        poses=poses,
        rois=("link2", "link3"),
        lengths=[("a2", "link2"), ("d4", "link3"), ("a3", "link3")],
    )
    return thermrs.Rig.from_toml(text, source_name="random-rig")


@dataclass(frozen=True)
class ErrorLaw:
    """Visit errors: AR(1) per camera axis (coefficient drawn in ``rho``), marginal standard
    deviation drawn in ``sd_um``, u–v correlation drawn in ``uv_corr``."""

    rho: tuple[float, float] = (0.3, 0.9)
    sd_um: tuple[float, float] = (1.0, 3.0)
    uv_corr: tuple[float, float] = (0.3, 0.7)


def ar1(rng: np.random.Generator, n: int, rho: float) -> np.ndarray:
    """A stationary AR(1) series of unit variance."""
    e = rng.normal(0.0, np.sqrt(1 - rho**2), n)
    out = np.empty(n)
    out[0] = rng.normal()
    for t in range(1, n):
        out[t] = rho * out[t - 1] + e[t]
    return out


def visit_tables(
    rig: thermrs.Rig,
    rng: np.random.Generator,
    *,
    alpha: float,
    runs: int = 2,
    hours: float = 6.0,
    cycle_s: float = 120.0,
    law: ErrorLaw | None = None,
) -> list[pl.DataFrame]:
    """Run tables (one per run) of synthetic visits with the given true α.

    Each run warms every mapped temperature first-order from its start (amplitude 3–10 K,
    time constant 1.5–6 h; ambient drifts 0–0.5 K); each cycle visits every camera.
    """
    law = law or ErrorLaw()
    model = ForwardModel(rig, alpha_per_k=alpha)
    names = model.temperature_names
    n = int(hours * 3600 / cycle_s)
    t_s = np.arange(n) * cycle_s
    tables = []
    for r in range(runs):
        temps = {}
        for name in names:
            start = rig.reference_c + rng.uniform(0, 3)
            if name == "ambient":
                temps[name] = start + rng.uniform(0, 0.5) * t_s / t_s[-1]
            else:
                amp, tau = rng.uniform(3, 10), rng.uniform(1.5, 6) * 3600
                temps[name] = start + amp * (1 - np.exp(-t_s / tau))
        rows = []
        for k, cam in enumerate(rig.cameras):
            q = rig.camera_pose(cam.name).joints_rad
            sp = model.spots(cam.name, q, temperatures=temps)
            rho_u, rho_v = rng.uniform(*law.rho, 2)
            sd_u, sd_v = rng.uniform(*law.sd_um, 2)
            c = rng.uniform(*law.uv_corr)
            eu = ar1(rng, n, rho_u)
            ev = c * eu + np.sqrt(1 - c**2) * ar1(rng, n, rho_v)
            off = rng.uniform(-50, 50, 2)
            t_ns = (r * 10**14 + (t_s + k * cycle_s / 4) * 1e9).astype(np.int64)
            rows.append(
                pl.DataFrame(
                    {
                        "run": f"run{r + 1}",
                        "camera": cam.name,
                        "visit": np.arange(n),
                        "t_ns": t_ns,
                        "u_um": sp.u_um + off[0] + sd_u * eu,
                        "v_um": sp.v_um + off[1] + sd_v * ev,
                        **{f"{nm}_c": v for nm, v in temps.items()},
                    }
                )
            )
        tables.append(pl.concat(rows))
    return tables


def geometries() -> dict[str, thermrs.Rig]:
    """The fixed geometries: the paper rig and the UR5 fixture."""
    return {"paper rig (KR 15/2)": thermrs.load_rig(), "UR5 fixture": thermrs.load_rig(UR5)}
