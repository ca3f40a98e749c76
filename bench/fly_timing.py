"""Wall time of scene 2's steady search (``hdi fly``) per case, and A/B against other copies of the solver.

Cases (``--case``, all by default), studies/scenes/chen_bogy2007.toml with:

* ``default``: 121 x 101, the flying default (Newton from the standard guess);
* ``pad95-0.8gf``: the 95-um pad at 0.8 gf, whose equilibrium lies beyond the flying branch's fold, held up by
  contact (the continuation through the fold);
* ``1.6gf``: 1.6 gf, no equilibrium at all (the continuation until it gives up, naming the fold);
* ``81x67-dgamma0.08``: 81 x 67 at dgamma 0.08, no equilibrium either.

Each flight runs in a fresh process (``python -c``) with the tree's own ``solver/`` first on the path and its
own scene file, and reports its wall time, the steady Reynolds solves, the sparse LU factorizations where the
solver counts them (``AbsFilm.factorizations``), and the flying height or the fold.  With ``--against DIR
[DIR ...]`` the trees alternate within every round (this tree first in odd rounds, last in even ones), so that
a shared machine's load hits all alike, and the medians are printed with their ratios to the first DIR.

    git worktree add /tmp/old REF        # the solver to compare with
    python bench/fly_timing.py --against /tmp/old --rounds 3 --case default 1.6gf
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASES = {
    "default": {},
    "pad95-0.8gf": {"slider.trailing_pad_width": 95e-6},
    "1.6gf": {"suspension.preload": 15.6906e-3},
    "81x67-dgamma0.08": {"numerics.nx": 81, "numerics.ny": 67, "contact.delta_gamma": 0.08},
}

#: A coarse flight that loads every kernel a flight uses.
WARM_UP = {"numerics.nx": 61, "numerics.ny": 41, "numerics.refine": 3.0, "contact.delta_gamma": 0.0}

#: The flight, run in the tree under test (its solver imports itself by absolute name).
FLY = """
import json, sys, time, tomllib
from solver.kinds import scene_from_dict
from solver.abs.film import AbsFilm
from solver.abs.steady import fly_abs
path = "studies/scenes/chen_bogy2007.toml"
data = tomllib.loads(open(path).read())
for key, value in json.loads(sys.argv[1]).items():
    section, _, name = key.partition(".")
    data.setdefault(section, {})[name] = value
scene = scene_from_dict(data, source=path)
film = AbsFilm(scene)
t = time.perf_counter()
try:
    result = f"flying height {fly_abs(scene, film=film).element_spacing * 1e9:.6f} nm"
except Exception as err:
    text = str(err)
    result = text[text.find("the fold lies"):][:60] if "the fold lies" in text else text[:60]
print(json.dumps({"seconds": time.perf_counter() - t, "solves": film.reynolds_solves,
                  "factorizations": getattr(film, "factorizations", None), "result": result}))
"""


def fly(tree: Path, overrides: dict) -> dict:
    """One flight in a fresh process of ``tree`` (a folder holding solver/ and studies/)."""
    env = dict(os.environ, PYTHONPATH=str(tree), NUMBA_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", FLY, json.dumps(overrides)], cwd=tree, env=env, capture_output=True,
                         text=True)  # fmt: skip
    if out.returncode:
        raise SystemExit(f"the flight in {tree} with {overrides} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", nargs="+", choices=list(CASES), default=list(CASES), help="cases to time")
    ap.add_argument("--against", type=Path, nargs="+", default=[], help="folders holding other solver/ copies")
    ap.add_argument("--rounds", type=int, default=3, help="flights per case and tree")
    args = ap.parse_args()
    trees = [*args.against, ROOT]
    for tree in trees:
        if not (tree / "solver").is_dir():
            ap.error(f"--against {tree}: no solver/ folder there")
    for name in args.case:
        for tree in trees:  # compile or load the kernels, untimed
            fly(tree, WARM_UP)
        samples: dict[Path, list[dict]] = {tree: [] for tree in trees}
        for r in range(args.rounds):
            for tree in trees if r % 2 else trees[::-1]:
                s = fly(tree, CASES[name])
                samples[tree].append(s)
                lus = "" if s["factorizations"] is None else f" on {s['factorizations']} LUs"
                print(f"{name:18s} {str(tree):24s} {s['seconds']:7.2f} s, {s['solves']} solves{lus}; {s['result']}",
                      flush=True)  # fmt: skip
        base = statistics.median(x["seconds"] for x in samples[trees[0]])
        for tree in trees:
            med = statistics.median(x["seconds"] for x in samples[tree])
            print(f"{name:18s} {str(tree):24s} median {med:7.2f} s, ratio to {trees[0]} {med / base:.2f}")


if __name__ == "__main__":
    main()
