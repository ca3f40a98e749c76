"""The source's five scene-2 findings against a design's four Table-I studies (README, "The five findings").

Each argument is a file prefix of the four study files PREFIXpad_width.nc, PREFIXpreload.nc,
PREFIXroughness_adhesion.nc and PREFIXfriction.nc; a missing file leaves its findings out:

    python bench/scene2_findings.py results/mtp_
    python bench/scene2_findings.py results/mtp_ results/robustness_zeta0_mtp_ \
        results/robustness_summits_berkeley_mtp_ \
        results/robustness_flat_adhesion_mtp_ results/robustness_first_design_ results/

For each finding it prints the two levels' means, the paired change over the shared track seeds (mean +- 95 %
half-width, t-interval) of the 3-sigma bouncing [nm] and the mean contact force [uN], and the verdict by the
rules below, written before the micro-pad sweeps were read.  A change is significant when its paired interval
excludes 0.

1. adhesion 0.008 -> 0.08 J/m2 (RMS 0.2 nm): agree if 3-sigma and contact force both rise significantly and no
   track at 0.08 sticks; disagree if either falls significantly or any track sticks.
2. roughness: agree if 3-sigma rises significantly from 0 to 0.2 and from 0.2 to 0.6 nm, and the smooth disk's
   3-sigma is below 0.05 nm (a steady state).
3. friction 0 -> 0.6: agree if the change of 3-sigma is below 10 % of the mu-0.3 mean, or not significant.
4. pad 120 -> 80 um: agree if 3-sigma and contact force both fall significantly; disagree if either rises.
5. preload 0.1 -> 1.6 gf: agree if 3-sigma falls significantly and the mean contact force rises by less than 10 %
   of the added preload (1.47 mN); disagree if 3-sigma rises significantly.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import xarray as xr
from scipy import stats

GF = 9.80665e-3  # N per gram-force
SCALES = {"bouncing_3sigma": 1e9, "mean_contact_force": 1e6}  # nm, uN


def interval(x: np.ndarray) -> tuple[float, float]:
    """Mean and 95 % half-width (t) of a sample; 0 for a constant one (a smooth disk's shared run)."""
    x = np.asarray(x, dtype=float).ravel()
    if x.size < 2 or np.all(x == x[0]):
        return float(x.mean()), 0.0
    return float(x.mean()), float(stats.t.ppf(0.975, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size))


def values(ds: xr.Dataset, name: str, **cell: float) -> np.ndarray:
    """One cell's per-track values (realization order); an error naming the axis if the cell is not on it."""
    for dim, value in cell.items():
        axis = ds[dim].values
        if not np.any(np.isclose(axis, value, rtol=1e-6, atol=0.0)):
            raise SystemExit(f"{ds.attrs.get('study', 'the study')}: {dim} = {value:g} is not on its axis "
                             f"({', '.join(f'{v:g}' for v in axis)}); the finding needs that cell")  # fmt: skip
    return ds[name].sel(cell, method="nearest").values.ravel()


def compare(ds: xr.Dataset, a: dict, b: dict) -> dict[str, tuple]:
    """(level a, level b, paired b - a) intervals of 3-sigma and contact force."""
    out = {}
    for name, scale in SCALES.items():
        va, vb = values(ds, name, **a) * scale, values(ds, name, **b) * scale
        out[name] = (interval(va), interval(vb), interval(vb - va))
    return out


def sign(c: tuple[float, float]) -> int:
    """+1 / -1 for a significant rise / fall, 0 when the interval holds 0."""
    return 0 if abs(c[0]) <= c[1] else int(np.sign(c[0]))


def stuck(ds: xr.Dataset, **cell: float) -> tuple[int, int]:
    """Tracks of a cell classed stuck, and the tracks."""
    flags = values(ds, "regime", **cell)
    code = list(ds["regime"].attrs["flag_meanings"].split()).index("stuck")
    return int(np.count_nonzero(flags == ds["regime"].attrs["flag_values"][code])), flags.size


def findings(prefix: str) -> list[tuple[str, str, dict | None, str]]:
    """(finding, compared levels, intervals or None, verdict) rows for one design's study files."""
    files = {n: Path(f"{prefix}{n}.nc") for n in ("pad_width", "preload", "roughness_adhesion", "friction")}
    ds = {n: xr.open_dataset(p) if p.exists() else None for n, p in files.items()}
    rows: list[tuple[str, str, dict | None, str]] = []
    ra, fr, pw, pl = ds["roughness_adhesion"], ds["friction"], ds["pad_width"], ds["preload"]
    if ra is not None:
        r = compare(ra, {"rms": 0.2e-9, "delta_gamma": 0.008}, {"rms": 0.2e-9, "delta_gamma": 0.08})
        n_stuck, n = stuck(ra, rms=0.2e-9, delta_gamma=0.08)
        s3, sf = sign(r["bouncing_3sigma"][2]), sign(r["mean_contact_force"][2])
        verdict = "agree" if s3 > 0 and sf > 0 and not n_stuck else "not significant"
        if s3 < 0 or sf < 0 or n_stuck:
            verdict = f"disagree ({n_stuck} of {n} tracks stuck)"
        rows.append(
            ("1. more adhesion: more bouncing and contact, still partial contact", "dgamma 0.008 -> 0.08", r, verdict)
        )
        r0 = compare(ra, {"rms": 0.0, "delta_gamma": 0.008}, {"rms": 0.2e-9, "delta_gamma": 0.008})
        r1 = compare(ra, {"rms": 0.2e-9, "delta_gamma": 0.008}, {"rms": 0.6e-9, "delta_gamma": 0.008})
        smooth = r0["bouncing_3sigma"][0][0]
        ok = sign(r0["bouncing_3sigma"][2]) > 0 and sign(r1["bouncing_3sigma"][2]) > 0 and smooth < 0.05
        rows.append(("2. roughness drives bouncing; a smooth disk is steady", "RMS 0 -> 0.2 nm", r0,
                     ("agree" if ok else "disagree") + f" (smooth disk 3-sigma {smooth:.2g} nm)"))  # fmt: skip
        rows.append(("", "RMS 0.2 -> 0.6 nm", r1, ""))
    if fr is not None:
        r = compare(fr, {"mu": 0.0, "delta_gamma": 0.008}, {"mu": 0.6, "delta_gamma": 0.008})
        middle = interval(values(fr, "bouncing_3sigma", mu=0.3, delta_gamma=0.008) * 1e9)[0]
        change = r["bouncing_3sigma"][2]
        ok = abs(change[0]) < 0.1 * middle or sign(change) == 0
        rows.append(("3. friction has a slight effect", "mu 0 -> 0.6", r,
                     ("agree" if ok else "disagree") + f" ({change[0] / middle:+.1%} of the mu-0.3 mean)"))  # fmt: skip
    if pw is not None:
        r = compare(pw, {"pad_width": 120e-6}, {"pad_width": 80e-6})
        s3, sf = sign(r["bouncing_3sigma"][2]), sign(r["mean_contact_force"][2])
        verdict = "agree" if s3 < 0 and sf < 0 else ("disagree" if s3 > 0 or sf > 0 else "not significant")
        rows.append(("4. a narrower pad: less bouncing and contact", "pad 120 -> 80 um", r, verdict))
    if pl is not None:
        r = compare(pl, {"preload": 0.1 * GF}, {"preload": 1.6 * GF})
        s3, rise = sign(r["bouncing_3sigma"][2]), r["mean_contact_force"][2][0]
        verdict = "agree" if s3 < 0 and rise < 0.1 * 1.5 * GF * 1e6 else ("disagree" if s3 > 0 else "not significant")
        rows.append(("5. more preload: less bouncing, contact force not much up", "preload 0.1 -> 1.6 gf", r, verdict))
    return rows


def text(c: tuple[float, float]) -> str:
    return f"{c[0]:.3g} +- {c[1]:.2g}"


def main(prefixes: list[str]) -> None:
    for prefix in prefixes:
        print(f"\n{prefix}*.nc")
        print("| finding | compared | 3-sigma [nm] | paired change | contact force [uN] | paired change | verdict |")
        print("|---|---|---|---|---|---|---|")
        for finding, levels, r, verdict in findings(prefix):
            b, c = r["bouncing_3sigma"], r["mean_contact_force"]
            print(f"| {finding} | {levels} | {text(b[0])} -> {text(b[1])} | {text(b[2])} | "
                  f"{text(c[0])} -> {text(c[1])} | {text(c[2])} | {verdict} |")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:] or ["results/mtp_"])
