r"""Impacts near the disk against the step: an ensemble of vibro-impact ringings, paired with a fine reference.

The default scene (chen_bogy2007) over a track whose roughness lies below the grid (RMS 0.6 nm, correlation length
0.05 um: the film sees a nearly smooth disk, the asperity contact its full RMS), from steady flight with a pitch
kick of 30 + 3k rad/s over disk.seed k (k = 1..n): the pad rings in the second pitch mode at a few nanometres and
strikes the asperities about once a period for tens of microseconds, with the flat adhesion law pulling it in
(delta_gamma 0.008).  Each run is deterministic and short (50 us), so a setting's error shows in a few runs, where
a rough track's statistics need hundreds of core-seconds per cell and still carry intervals of +-20 %.  Printed
per setting: the flying height's standard deviation over 0-20 and 20-50 us (mean over the n kicks), its paired
difference from the reference's with a 95 % interval (Student t), and the median substeps and wall time of a run.

The rough cell of Table I (RMS 0.6 nm, delta_gamma 0.008) bounces in exactly these impacts, and its 3-sigma falls
with the energy a step loses in them (README, "Impacts near the disk: what the coarse steps lose").

    python bench/impact_ringing.py              # the default, dt 25 and 12.5 ns, finer contact substeps: ~8 min
    python bench/impact_ringing.py --reference "numerics.dt=6.25e-9,contact.delta_gamma=0" --settings \
"numerics.dt=0.2e-6,contact.delta_gamma=0"

(the second: the same impacts without adhesion, on both sides of the pairing).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.stats import t as student

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
ABS_SCENE = ROOT / "studies" / "scenes" / "chen_bogy2007.toml"

#: The windows [s] whose flying-height standard deviation is compared: the first impacts, and the ringing after.
WINDOWS = ((0.0, 20.0e-6), (20.0e-6, 50.0e-6))
SETTINGS = (
    "numerics.dt=0.2e-6",
    "numerics.dt=25e-9",
    "numerics.dt=12.5e-9",
    "numerics.dt=0.2e-6,numerics.contact_omega_dt=0.125,numerics.contact_splits=7",
)


def ringing_scene(k: int, t_end: float, overrides: list[str]) -> list[str]:
    """The overrides of kick k: the sub-grid track, its seed, the pitch kick, the run's length and sampling."""
    return [
        "disk.rms=0.6e-9",
        "disk.correlation_length=0.05e-6",
        f"disk.seed={k}",
        f"initial.pitch_rate={30.0 + 3.0 * k!r}",
        f"numerics.t_end={t_end!r}",
        "numerics.settle_time=0.0",
        "numerics.output_interval=0.2e-6",
        *overrides,
    ]


def ring(spec: str, n: int, t_end: float, steady) -> tuple[np.ndarray, float, float]:
    """(n, windows) standard deviations [nm], median substeps and median wall time [s] of a run, for one setting."""
    from pipeline.config import load_scene
    from solver.abs.integrate import simulate_abs

    overrides = [s for s in spec.split(",") if s]
    stds, substeps, walls = [], [], []
    for k in range(1, n + 1):
        scene = load_scene(ABS_SCENE, ringing_scene(k, t_end, overrides))
        wall = time.perf_counter()
        result = simulate_abs(scene, steady)
        walls.append(time.perf_counter() - wall)
        if result.status != 0:
            raise SystemExit(f"{spec}, kick {k}: {result.message}")
        fh, t = result.series["flying_height"], result.t
        stds.append([fh[(t >= a) & (t < b)].std() * 1e9 for a, b in WINDOWS])
        substeps.append(result.work["substeps"])
    return np.array(stds), float(np.median(substeps)), float(np.median(walls))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--reference", default="numerics.dt=6.25e-9", help="the reference setting (overrides, comma-separated)"
    )
    parser.add_argument(
        "--settings", nargs="+", default=list(SETTINGS), help="settings to compare (overrides, comma-separated)"
    )
    parser.add_argument("-n", type=int, default=8, help="kicks (disk.seed 1..n)")
    parser.add_argument("--t-end", type=float, default=WINDOWS[-1][1], help="run length [s]")
    args = parser.parse_args()
    if args.n < 2:
        parser.error(f"-n = {args.n}: a paired interval needs at least 2 kicks")
    if args.t_end < WINDOWS[-1][1]:
        parser.error(f"--t-end = {args.t_end} s: the windows need runs of at least {WINDOWS[-1][1]} s")

    from pipeline.config import load_scene
    from solver.abs.steady import fly_start

    steady = fly_start(load_scene(ABS_SCENE, ringing_scene(1, args.t_end, [])))
    half = student.ppf(0.975, args.n - 1) / np.sqrt(args.n)
    head = " / ".join(f"{a * 1e6:.0f}-{b * 1e6:.0f} us" for a, b in WINDOWS)
    print(f"flying-height std [nm] over {head}, {args.n} kicks; paired: setting - reference, mean +- 95 % half-width")
    ref, sub, wall = ring(args.reference, args.n, args.t_end, steady)
    means = "  ".join(f"{m:.3f}" for m in ref.mean(0))
    print(f"  {'reference ' + args.reference:72s} {means}  {'':34s} {sub:7.0f} substeps  {wall:6.1f} s", flush=True)
    for spec in args.settings:
        stds, sub, wall = ring(spec, args.n, args.t_end, steady)
        d = stds - ref
        means = "  ".join(f"{m:.3f}" for m in stds.mean(0))
        paired = "  ".join(f"{m:+.3f} +- {s * half:.3f}" for m, s in zip(d.mean(0), d.std(0, ddof=1), strict=True))
        print(f"  {spec:72s} {means}  {paired:34s} {sub:7.0f} substeps  {wall:6.1f} s", flush=True)


if __name__ == "__main__":
    main()
