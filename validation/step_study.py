#!/usr/bin/env python3
"""The free-body time-step study (reports/free-step): route 2 against the body-frame linear
FEM at each step, beside that FEM's own change with its step.

Usage: step_study.py TAU_MS=DIR [TAU_MS=DIR ...] [--method route2_modal]

Each DIR is an `irdm validate-free --truth-check` output folder (DIR/free/linearization.csv,
or DIR/linearization.csv as reports/free-step keeps them)
whose scene runs at TAU_MS milliseconds. Prints, per case, one Markdown row per step: the
method's error against the linear FEM at that step (over the first contact and the whole run)
and the linear FEM at half the step against itself (`<linear FEM>_half_step`): where the first
is no larger than the second, the step does not resolve it.
"""
import csv
import os
import sys

LINEAR = "fem_linear_body_frame"
FIRST = [("first_force_error", "force"), ("first_impulse_error", "impulse"),
         ("first_deformation_error", "deformation")]
WHOLE = [("com_error", "com"), ("angle_error_deg", "angle (deg)"), ("force_error", "force"),
         ("deformation_error", "deformation")]


def rows_of(folder):
    path = os.path.join(folder, "free", "linearization.csv")
    if not os.path.exists(path):  # a report's copy: the CSVs in the folder itself
        path = os.path.join(folder, "linearization.csv")
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def cell(row, key):
    if row is None or row.get(key, "") == "":
        return "-"
    v = float(row[key])
    return f"{v:.3g}" if key.endswith("_deg") else f"{100 * v:.3g} %"


def main(argv):
    method = "route2_modal"
    if "--method" in argv:
        i = argv.index("--method")
        method = argv[i + 1]
        del argv[i:i + 2]
    if not argv or any("=" not in a for a in argv):
        sys.exit(__doc__)
    runs = []
    for a in argv:
        tau, folder = a.split("=", 1)
        runs.append((float(tau), rows_of(folder)))
    runs.sort(key=lambda r: -r[0])
    cases = []
    for _, rows in runs:
        for r in rows:
            if r["case"] not in cases:
                cases.append(r["case"])
    head = ["case", "step (ms)", "run"] + [f"first contact: {n}" for _, n in FIRST] + \
           [f"whole run: {n}" for _, n in WHOLE]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for case in cases:
        for tau, rows in runs:
            pick = {r["method"]: r for r in rows if r["case"] == case and r["reference"] == LINEAR}
            for name, label in ((method, f"{method} against the linear FEM"),
                                (LINEAR + "_half_step", "the linear FEM at half the step against it")):
                r = pick.get(name)
                if r is None:
                    continue
                print("| " + " | ".join([case, f"{tau:g}", label] +
                                        [cell(r, k) for k, _ in FIRST] +
                                        [cell(r, k) for k, _ in WHOLE]) + " |")


if __name__ == "__main__":
    main(sys.argv[1:])
