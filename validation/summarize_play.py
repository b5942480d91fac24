#!/usr/bin/python3
"""One table over repeated `irdm play` runs (scripts/play_study.sh).

Usage: /usr/bin/python3 validation/summarize_play.py STUDY.csv OUT.md [SAMPLES.csv.gz]

STUDY.csv: one row per run and repetition, the columns of play's summary.csv after `run` and
`repetition`. Per configuration: missed deadlines summed over the repetitions (with their
causes), the stalls in which the force thread did not run for more than a period, the
baseline's (the same loop with no work, run just before: the machine's own stalls), and the
median over the repetitions of each latency percentile (us). With SAMPLES (run,repetition,
kind,us: every force step's and surface update's latency), also the percentiles of all the
repetitions' samples pooled: a run has 100 to 300 surface updates, so its own p99 is its second
or third largest, while the pool's rests on several hundred. Standard library only.
"""
import csv
import gzip
import math
import os
import statistics
import sys
from report_files import stamp, write_text  # noqa: E402


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    if not rows:
        sys.exit("summarize_play: no runs in " + sys.argv[1])
    runs = {}
    for row in rows:
        runs.setdefault(row["run"], []).append({k: float(v) for k, v in row.items() if k != "run"})

    pooled = {}  # (run, kind) -> every sample of every repetition
    ordered = {}  # (run, repetition, kind) -> that repetition's samples in order
    if len(sys.argv) == 4:
        with gzip.open(sys.argv[3], "rt") as f:
            for row in csv.DictReader(f):
                pooled.setdefault((row["run"], row["kind"]), []).append(float(row["us"]))
                ordered.setdefault((row["run"], row["repetition"], row["kind"]), []).append(
                    float(row["us"]))
        for v in pooled.values():
            v.sort()

    # Slowed stretches: the host at times runs a vCPU several times slower for hundreds of ms
    # (seen: every force step of 0.2 s at 6 us against 1.4). A window of WINDOW consecutive
    # force steps whose median is over twice its repetition's median is slowed; the work is
    # the same in every window, so that is the machine, not the step. Per configuration: the
    # steps in slowed windows, the repetitions with any, and the pooled percentiles without them.
    WINDOW = 50

    def slowed(name):
        n_slow, reps, kept = 0, 0, []
        for (run, _, kind), v in ordered.items():
            if run != name or kind != "force_step":
                continue
            whole = statistics.median(v)
            any_slow = False
            for i in range(0, len(v), WINDOW):
                w = v[i:i + WINDOW]
                if len(w) == WINDOW and statistics.median(w) > 2 * whole:
                    n_slow += len(w)
                    any_slow = True
                else:
                    kept.extend(w)
            reps += any_slow
        if not kept:
            return "not recorded"
        kept.sort()
        return (f"{n_slow} ({reps}); {g(nearest_rank(kept, 0.5))} / {g(nearest_rank(kept, 0.99))} / "
                f"{g(nearest_rank(kept, 0.999))}")

    def nearest_rank(v, p):
        # As irdm play's percentile: the smallest sample with at least p of them at or below.
        return v[min(len(v) - 1, max(0, math.ceil(p * len(v)) - 1))]

    def pool(name, kind):
        v = pooled.get((name, kind))
        if not v:
            return "not recorded"
        return (f"{g(nearest_rank(v, 0.5))} / {g(nearest_rank(v, 0.99))} / "
                f"{g(nearest_rank(v, 0.999))} ({len(v)})")

    def over(name, kind, limit):
        # The share of the pooled samples over the goal (issue 15: 20 us per surface update).
        v = pooled.get((name, kind))
        if not v:
            return "not recorded"
        n = sum(1 for x in v if x > limit)
        return f"{n} of {len(v)} ({100 * n / len(v):.2g} %)"

    def med(group, key):
        return statistics.median(r[key] for r in group)

    def g(x):
        return f"{x:.3g}"

    def baseline(group):
        ran = [r for r in group if r["baseline_missed"] >= 0]
        if not ran:
            return "not run"
        ticks = sum(r["baseline_missed"] for r in ran)
        steps = sum(r["steps"] for r in ran)
        return (f"{int(ticks)} of {int(steps)} ({100 * ticks / steps:.3g} %) "
                f"({int(sum(r['baseline_stalls'] for r in ran))}, "
                f"{g(max(r['baseline_longest_stall_ms'] for r in ran))})")

    def warm(group):
        # Runs written before the warm-ups existed have no such columns.
        step = "" if "warm_step" not in group[0] else (
            "; step warmed" if group[0]["warm_step"] > 0 else "; step not warmed")
        if "warm_us" not in group[0] or group[0]["warm_us"] <= 0:
            return "none" + step
        # keep_warm: each warm-up repeated until its tick (absent: before it existed, once).
        how = "" if "keep_warm" not in group[0] else (
            "; kept warm" if group[0]["keep_warm"] > 0 else "; warmed once")
        return f"{g(group[0]['warm_us'])}; {g(med(group, 'surface_warm_p50_us'))}{step}{how}"

    def interruptions(group):
        # Gaps over 2 us between two clock reads while a thread spun (medians over the runs).
        if "force_interruptions_per_s" not in group[0]:
            return "not measured"
        d = (f"{g(med(group, 'display_interruptions_per_s'))} ({g(med(group, 'display_interruption_p50_us'))})"
             if group[0]["warm_us"] > 0 else "no spin")
        f = (f"{g(med(group, 'force_interruptions_per_s'))} ({g(med(group, 'force_interruption_p50_us'))})"
             if group[0]["spin_us"] > 0 else "no spin")
        return f"{f} / {d}"

    lines = [
        "| run | rate (Hz) | spin (us) | repetitions | missed deadlines (all repetitions) "
        "| of which step overran / woken late | stalls > 1 period (longest, ms) "
        "| baseline, no work: ticks > 1 period late (stalls, longest ms) | runs within 0.1 % | force step p50 / p99 / p99.9 (us) | wake-up lateness p50 / p99 (us) "
        "| surface update p50 / p99 (us) | surface warm-up before each frame (us ahead; p50); force step warm-up; repeated to the tick or once "
        "| interruptions of the spins per s, force / deformation thread (p50 length, us) | force error against all modes "
        "| pooled over the repetitions: force step p50 / p99 / p99.9 (us; samples) | pooled: surface update p50 / p99 / p99.9 (us; samples) "
        "| force steps in slowed stretches of the machine (repetitions with any); pooled p50 / p99 / p99.9 of the others (us) "
        "| surface updates over 20 us, pooled |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, group in runs.items():
        steps = sum(r["steps"] for r in group)
        missed = sum(r["missed"] for r in group)
        within = sum(1 for r in group if r["missed"] <= 0.001 * r["steps"])
        lines.append(
            f"| `{name}` | {g(group[0]['rate_hz'])} | {g(group[0]['spin_us'])} | {len(group)} "
            f"| {int(missed)} of {int(steps)} ({100 * missed / steps:.3g} %) "
            f"| {int(sum(r['missed_step_overrun'] for r in group))} / "
            f"{int(sum(r['missed_woken_late'] for r in group))} "
            f"| {int(sum(r['stalls'] for r in group))} ({g(max(r['longest_stall_ms'] for r in group))}) "
            f"| {baseline(group)} "
            f"| {within} of {len(group)} "
            f"| {g(med(group, 'force_step_p50_us'))} / {g(med(group, 'force_step_p99_us'))} / "
            f"{g(med(group, 'force_step_p999_us'))} "
            f"| {g(med(group, 'wake_late_p50_us'))} / {g(med(group, 'wake_late_p99_us'))} "
            f"| {g(med(group, 'surface_update_p50_us'))} / {g(med(group, 'surface_update_p99_us'))} "
            f"| {warm(group)} "
            f"| {interruptions(group)} "
            f"| {g(med(group, 'force_error'))} "
            f"| {pool(name, 'force_step')} | {pool(name, 'surface_update')} | {slowed(name)} "
            f"| {over(name, 'surface_update', 20)} |")
    text = ("# irdm play, repeated runs\n\n" + stamp() + "\n\n"
            "Made by `scripts/play_study.sh` from `" + os.path.basename(sys.argv[1]) + "`. Sums over "
            "the repetitions for deadlines; medians over the repetitions for latencies, and in the "
            "pooled columns the percentiles of every repetition's samples together. Slowed "
            f"stretches: windows of {WINDOW} consecutive force steps whose median is over twice "
            "its repetition's median (the same work each time: the host ran that vCPU slower); "
            "the last column's percentiles leave them out and say so.\n\n"
            + "\n".join(lines) + "\n")
    write_text(sys.argv[2], text)


if __name__ == "__main__":
    main()
