"""Effect size on an axis of signal to noise, measured in the bench world itself.

An effect's size is what it leaves over the nominal model on the held-out runs when both are
fitted to the noise-free truth: the same case rendered without visit errors and with perfect
instruments, with and without the effect; the difference regressed, on the training run, on
the nominal model's α column (the rig file's geometry, the case's temperatures) and a per-series
offset (run, camera, chip axis); α so refitted, each held-out series keeps only its own offset;
the rms of what remains on the held-out rows. Plain least squares by QR on unit-norm columns.
SNR = that rms ÷ σ, the visit repeatability. An effect is scaled to a target SNR by its one
amplitude (for ``thermal_lag`` its time constant), by secant steps in log–log, within the
amplitude's cap; the SNR actually reached is what a case is binned by.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.bench.world.truth import Truth
from thermrs.bench.world.world import Scene, nominal_prediction, render

FloatArray = npt.NDArray[np.float64]

__all__ = ["Sizer", "stack"]


def stack(tables: list[pl.DataFrame]) -> tuple[FloatArray, npt.NDArray[np.int64], FloatArray]:
    """Rows of every run's u then v: (values µm, series index, 1.0 on held-out rows)."""
    ys, ser, held = [], [], []
    k = 0
    for ri, t in enumerate(tables):
        for cam in t["camera"].unique(maintain_order=True).to_list():
            part = t.filter(pl.col("camera") == cam)
            for axis in ("u_um", "v_um"):
                y = part[axis].to_numpy()
                ys.append(y)
                ser.append(np.full(y.size, k))
                held.append(np.full(y.size, float(ri > 0)))
                k += 1
    return np.concatenate(ys), np.concatenate(ser).astype(np.int64), np.concatenate(held)


def _lstsq(x: FloatArray, y: FloatArray) -> FloatArray:
    """Least squares by QR on unit-norm columns."""
    norm = np.linalg.norm(x, axis=0)
    norm[norm == 0] = 1.0
    q, r = np.linalg.qr(x / norm)
    return np.asarray(np.linalg.solve(r, q.T @ y) / norm, dtype=np.float64)


@dataclass
class Sizer:
    """Measures and scales effect sizes for one scene (module docs)."""

    scene: Scene

    def __post_init__(self) -> None:
        base = render(self.scene, noise=False)
        self._base, self._series, held = stack(base)
        self._held = held > 0
        a = self.scene.alpha_per_k
        h = 1e-3 * a
        up = stack(render(self.scene, noise=False, nominal=True, alpha_per_k=a + h))[0]
        dn = stack(render(self.scene, noise=False, nominal=True, alpha_per_k=a - h))[0]
        self._x_alpha = (up - dn) / (2 * h)

    @property
    def x_alpha(self) -> FloatArray:
        """The nominal model's α column (µm per unit α, every row of :func:`stack`)."""
        return self._x_alpha

    def residual(self, effects: tuple[Truth, ...]) -> FloatArray:
        """What ``effects`` leave on every row after the nominal refit (held-out rows: their
        offsets only; training rows: α and offsets)."""
        return self._refit(stack(render(self.scene, effects, noise=False))[0] - self._base)

    def nuisance_snr(self) -> float:
        """What the world's own nuisances leave over the nominal model, ÷ σ: the true spots
        without visit errors against the nominal model fed the instruments' readings (their
        gain, offset, drift, noise and clock; the true rig against the file; the true α),
        refitted as :meth:`residual` does. A ``none`` case whose nuisances leave a gap of a
        visible size is not free of gaps."""
        readings = render(self.scene)  # instruments as recorded (their spots are not used)
        pred = np.concatenate(nominal_prediction(self.scene, readings))
        r = self._refit(self._base - pred)
        return float(np.sqrt(np.mean(r[self._held] ** 2))) / self.scene.campaign.sigma_um

    def _refit(self, e: FloatArray) -> FloatArray:
        tr = ~self._held
        train_series = np.unique(self._series[tr])
        onehot = (self._series[tr][:, None] == train_series[None, :]).astype(np.float64)
        beta = _lstsq(np.column_stack([self._x_alpha[tr], onehot]), e[tr])
        r = np.asarray(e - beta[0] * self._x_alpha, dtype=np.float64)
        for s in np.unique(self._series[self._held]):
            m = self._series == s
            r[m] -= r[m].mean()
        r[tr] = e[tr] - np.column_stack([self._x_alpha[tr], onehot]) @ beta
        return r

    def rms(self, effects: tuple[Truth, ...]) -> float:
        """The effect size (µm): rms of :meth:`residual` over the held-out rows."""
        r = self.residual(effects)
        return float(np.sqrt(np.mean(r[self._held] ** 2)))

    def snr(self, effects: tuple[Truth, ...]) -> float:
        """Size ÷ the visit repeatability σ."""
        return self.rms(effects) / self.scene.campaign.sigma_um

    def scale(self, truth: Truth, target_snr: float, *, tol: float = 0.01) -> tuple[Truth, float]:
        """``truth`` at the amplitude whose SNR is ``target_snr`` (within ``tol``), or at its
        cap if that falls short; returns it and the SNR reached."""
        goal = target_snr * self.scene.campaign.sigma_um
        a0 = truth.amplitude
        r0 = self.rms((truth,))
        slope = 1.0
        a, r = a0, r0
        for _ in range(8):
            if r > 0 and abs(r / goal - 1) <= tol:
                break
            if r <= 0:
                a_new = min(a * 10, truth.cap)
            else:
                a_new = min(a * (goal / r) ** (1 / slope), truth.cap)
            if a_new == a:
                break
            r_new = self.rms((truth.scaled(a_new),))
            if r > 0 and r_new > 0 and abs(np.log(a_new / a)) > 1e-9:
                slope = float(np.clip(np.log(r_new / r) / np.log(a_new / a), 0.2, 3.0))
            a, r = a_new, r_new
        return truth.scaled(a), r / self.scene.campaign.sigma_um
