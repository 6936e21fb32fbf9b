"""What a robustness study writes under ``--out``: every trial's parameters and outcome
(``outcomes.npz``), the survival map (``survival_map.png``: an image over two axes, a curve
over one), the survival along each sampled axis (``survival_by_axis.png``) and the histogram of
the unit at which the failed trials fell (``fell_at.png``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bipedlab.viz import figures as fg


def write(out, study, params: dict, res: dict, frac, count, rec: dict) -> list:
    out = fg.output_dir(out)
    paths: list = []
    arrays = {f"param_{k}": np.asarray(v) for k, v in params.items()}
    arrays.update({k: np.asarray(v) for k, v in res.items()})
    arrays.update(seed=np.asarray(rec["seed"]), horizon=np.asarray(rec["horizon"]))
    npz = Path(out) / "outcomes.npz"
    np.savez(npz, **arrays)
    paths.append(str(npz))
    title = f"{study.name}: {100 * rec['survival_rate']:.1f} % of {rec['trials']} survived {rec['horizon']} {rec['unit']}"
    axes = study.axes
    if len(axes) >= 2:
        fig, ax = fg.subplots(figsize=(6.2, 4.8))
        a0, a1 = axes[0], axes[1]
        m = np.asarray(frac, float)
        if m.ndim > 2:  # more axes: the map over the first two
            from bipedlab.robustness.engine import survival_map

            m = survival_map(params, res["survived"], axes[:2])[0]
        im = ax.imshow(np.ma.masked_invalid(m), origin="lower", aspect="auto", vmin=0.0, vmax=1.0, cmap="RdYlGn",
                       extent=(a1.lo, a1.hi, a0.lo, a0.hi))
        fig.colorbar(im, ax=ax, label="survival fraction")
        ax.set_xlabel(a1.title())
        ax.set_ylabel(a0.title())
        ax.set_title(title, fontsize=9)
        fg.save(fig, Path(out) / "survival_map.png", paths)
    elif len(axes) == 1:
        fig, ax = fg.subplots(figsize=(6.2, 3.8))
        a0 = axes[0]
        ax.plot(a0.centers(), np.asarray(frac, float), "o-")
        ax.set_ylim(-0.03, 1.03)
        ax.set_xlabel(a0.title())
        ax.set_ylabel("survival fraction")
        ax.set_title(title, fontsize=9)
        fg.save(fig, Path(out) / "survival_map.png", paths)
    if axes:
        fig, axs = fg.subplots(1, len(axes), figsize=(3.4 * len(axes), 3.2), squeeze=False)
        for ax, a in zip(axs[0], axes):
            x = np.asarray(params[a.name])
            e = a.edges()
            idx = np.clip(np.digitize(x, e) - 1, 0, a.bins - 1)
            n = np.bincount(idx, minlength=a.bins)
            s = np.bincount(idx, weights=res["survived"].astype(float), minlength=a.bins)
            with np.errstate(invalid="ignore", divide="ignore"):
                ax.plot(a.centers(), np.where(n > 0, s / np.maximum(n, 1), np.nan), "o-")
            ax.set_ylim(-0.03, 1.03)
            ax.set_xlabel(a.title())
            ax.set_ylabel("survival fraction")
        fg.save(fig, Path(out) / "survival_by_axis.png", paths)
    fig, ax = fg.subplots(figsize=(6.2, 3.4))
    h = np.asarray(rec["fell_at_histogram"])
    ax.bar(np.arange(h.size), h, width=0.85)
    ax.set_xlabel(f"{study.unit} completed before the fall")
    ax.set_ylabel("failed trials")
    ax.set_title(f"{study.name}: {rec['fell']} fell, {rec['nonfinite']} non-finite", fontsize=9)
    fg.save(fig, Path(out) / "fell_at.png", paths)
    if study.figures is not None:
        paths += list(study.figures(out, params, res) or [])
    return paths
