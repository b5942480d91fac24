#!/usr/bin/python3
"""The figures of README.md from the runs' files (commands.sh): per model, Newton stop and
tangent schedule, the range over rounds of irdm play's deformation-step percentiles, its
slowest steps and where they are, and the tangents made; then the benchmark's rows.

    cd reports/reduced/tangent_steps && /usr/bin/python3 summarize.py > summary.txt
"""
import collections
import csv
import glob
import os
import re
import statistics


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def span(values, fmt="{:.2f}"):
    return (fmt + " to " + fmt).format(min(values), max(values))


def piece_extra(rows, us, pieces):
    """What the steps carrying a piece of a staged tangent took beyond the run's median step
    of as many Newton iterations (us): the pieces' own cost, in place."""
    if pieces == 0:
        return []
    its = [int(float(r["newton_iterations"])) for r in rows]
    by = collections.defaultdict(list)
    for u, i in zip(us, its):
        by[i].append(u)
    median = {i: statistics.median(v) for i, v in by.items()}
    extra = []
    for k, r in enumerate(rows):
        if float(r["staged_tangents_taken"]) > 0:
            extra += [us[j] - median[its[j]] for j in range(k - pieces + 1, k + 1)]
    return extra


def play_runs():
    runs = collections.defaultdict(list)
    for d in sorted(glob.glob("play/*_tol*_steps*_*")):
        m = re.match(r"play/(.+)_tol([0-9e.-]+)_steps(\d+)_(\d+)$", d)
        if not m or not os.path.exists(os.path.join(d, "summary.csv")):
            continue
        s = read_rows(os.path.join(d, "summary.csv"))[0]
        rows = read_rows(os.path.join(d, "deformation.csv"))
        us = [float(r["deformation_step_us"]) for r in rows]
        made = [int(float(r["tangents_made"])) for r in rows]
        run = {
            "round": int(m.group(4)),
            "p50": float(s["deformation_step_p50_us"]) / 1e3,
            "p99": float(s["deformation_step_p99_us"]) / 1e3,
            "max": float(s["deformation_step_max_us"]) / 1e3,
            "first": us[0] / 1e3,
            "after_first": max(us[1:]) / 1e3,
            "over_1ms": 100.0 * sum(u > 1000 for u in us) / len(us),
            "over_1ms_n": sum(u > 1000 for u in us),
            # the slowest steps that made a tangent at once, and the slowest that did not
            "made_steps": [(int(r["step"]), int(float(r["newton_iterations"])), float(r["deformation_step_us"]) / 1e3)
                           for r, k in zip(rows, made) if k > 0],
            "slowest_without": max((u for u, k in zip(us[1:], made[1:]) if k == 0), default=0) / 1e3,
            "iterations": collections.Counter(int(float(r["newton_iterations"])) for r in rows),
            "tangents": int(float(s["tangent_evaluations"])),
            "staged": int(float(s["staged_tangent_evaluations"])),
            "lockstep": float(s["lockstep_force_error"]),
            "implicit": float(s["implicit_force_error"]),
            "failed": int(float(s["failed_steps"])),
            "cut": int(float(s["cut_steps"])),
            "missed": int(float(s["missed"])),
            "force_p99": float(s["force_step_p99_us"]),
            "piece_extra": piece_extra(rows, us, int(m.group(3))),
            # The same work at every step before the device touches (no iteration): the
            # machine's own pace in that run.
            "rest": statistics.median(us[1:390]) / 1e3,
            "lag_max": float(s["lag_max_ms"]),
        }
        runs[(m.group(1), m.group(2), int(m.group(3)))].append(run)
    return runs


def main():
    runs = play_runs()
    print("irdm play, press of the head (1500 steps of 2 ms): ranges over rounds")
    for key in sorted(runs):
        rs = sorted(runs[key], key=lambda r: r["round"])
        model, tol, steps = key
        print(f"\n{model}, stop {tol}, tangent over {steps} steps ({len(rs)} rounds; 0: in the step)")
        print("  p50 {} ms, p99 {} ms, max {} ms".format(span([r["p50"] for r in rs]), span([r["p99"] for r in rs]),
                                                      span([r["max"] for r in rs])))
        print("  p99 by round: " + ", ".join(f"{r['p99']:.2f}" for r in rs))
        print("  the machine's pace, median of steps 1 to 389 (at rest, no iteration) by round: " +
              ", ".join(f"{r['rest']:.2f}" for r in rs) + " ms; largest lag by round: " +
              ", ".join(f"{r['lag_max']:.1f}" for r in rs) + " ms")
        print("  first step {} ms; slowest after it {} ms; slowest after it making no tangent {} ms".format(
            span([r["first"] for r in rs]), span([r["after_first"] for r in rs]),
            span([r["slowest_without"] for r in rs])))
        print("  steps over 1 ms: {} ({} %)".format(span([r["over_1ms_n"] for r in rs], "{:.0f}"),
                                                 span([r["over_1ms"] for r in rs], "{:.1f}")))
        print("  tangents made at once {} (the one before the loops included), over steps {}".format(
            span([r["tangents"] for r in rs], "{:.0f}"), span([r["staged"] for r in rs], "{:.0f}")))
        extra = [e for r in rs for e in r["piece_extra"]]
        if extra:
            print("  steps carrying a piece: beyond the median step of as many iterations, median {:.2f} ms, "
                  "per run {} ms, largest {:.2f} ms ({} steps)".format(
                      statistics.median(extra) / 1e3,
                      span([statistics.median(r["piece_extra"]) / 1e3 for r in rs if r["piece_extra"]]),
                      max(extra) / 1e3, len(extra)))
        made = [m for r in rs for m in r["made_steps"]]
        if made:
            print("  steps making one at once (step, iterations, ms): " +
                  ", ".join(f"({s}, {i}, {t:.2f})" for s, i, t in sorted(made)[:12]) +
                  (" ..." if len(made) > 12 else ""))
        its = collections.Counter()
        for r in rs:
            its.update(r["iterations"])
        print("  Newton iterations a step (all rounds): " + ", ".join(f"{k}: {v}" for k, v in sorted(its.items())))
        print("  lockstep force error {}, against the coupling in the step {}; failed {}, cut {}, missed deadlines {}; "
              "force step p99 {} us".format(span([r["lockstep"] for r in rs], "{:.1e}"),
                                            span([r["implicit"] for r in rs], "{:.1e}"),
                                            sum(r["failed"] for r in rs), sum(r["cut"] for r in rs),
                                            sum(r["missed"] for r in rs), span([r["force_p99"] for r in rs], "{:.1f}")))
    print("\nThe split with its force loop behind (offline, deterministic; lag.csv): force error against the "
          "coupling solved in the step, peak window force, most Newton iterations a step")
    for path in sorted(glob.glob("lag/*/lag.csv")):
        cells = ["{} steps ({} ms): {:.3g}, {:.3f} N, {}".format(int(float(r["lag_steps"])), float(r["lag_ms"]),
                                                               float(r["force_error"]), float(r["peak_force_N"]),
                                                               int(float(r["most_newton_iterations"])))
                 for r in read_rows(path)]
        print(f"  {path.split('/')[1]}: " + "; ".join(cells))
    for name, what in (("benchmarks.txt", ""), ("benchmarks_at_once_ratio_0.5.txt", ", tangent_at_once_ratio 0.5")):
        if not os.path.exists(name):
            continue
        print(f"\nirdm_reduced_kernels (a plane pressing 0 to 5 mm into the top with a period of 0.2 s{what}):")
        head = None
        for line in open(name):
            if line.startswith("== "):
                head = line[3:].strip()
            elif "ratio to Newton" in line:
                name, rest = line[2:48].strip(), line[48:]  # "  %-46s %9.1f us  ratio to Newton ..."
                t = re.search(r"([0-9.]+) us", rest).group(1)
                detail = rest.split("ratio to Newton")[1].split("  ", 1)[1].strip()
                print(f"  {head}: {name}: {float(t) / 1e3:.2f} ms a step; {detail}")


if __name__ == "__main__":
    main()
