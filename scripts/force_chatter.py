"""How much of a wall-force error is step-to-step chatter: for each case of a plane study's
forces.csv, each method's force error (relative L2 against the FEM truth) as it is and after both
forces are averaged over a moving window of 5, 10 and 25 steps, and the truth's own chatter
(the RMS of its force less its 10-step average, over the RMS of its force).

    /usr/bin/python3 scripts/force_chatter.py reports/reduced/planes/forces.csv [CASE ...]

Every case when none is named; every method column of the file."""
import csv
import sys

import numpy as np

WINDOWS = (5, 10, 25)


def averaged(x, w):
    return np.convolve(x, np.ones(w) / w, mode="same")


def relative(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    with open(sys.argv[1]) as fh:
        rows = list(csv.DictReader(fh))
    if not rows:
        sys.exit(f"{sys.argv[1]}: no rows")
    methods = [c[:-len("_force_N")] for c in rows[0] if c.endswith("_force_N") and c != "fem_force_N"]
    cases = sys.argv[2:] or list(dict.fromkeys(r["case"] for r in rows))
    print("case,method,force_error," + ",".join(f"force_error_avg{w}" for w in WINDOWS) + ",truth_chatter")
    for case in cases:
        r = [x for x in rows if x["case"] == case]
        if not r:
            sys.exit(f"no case '{case}' in {sys.argv[1]}")
        truth = np.array([float(x["fem_force_N"]) for x in r])
        chatter = relative(averaged(truth, 10), truth)
        for m in methods:
            if r[0][m + "_force_N"] == "":
                continue  # the method did not run on this case
            f = np.array([float(x[m + "_force_N"]) for x in r])
            errors = [relative(f, truth)] + [relative(averaged(f, w), averaged(truth, w)) for w in WINDOWS]
            print(f"{case},{m}," + ",".join(f"{e:.4f}" for e in errors) + f",{chatter:.4f}")


if __name__ == "__main__":
    main()
