"""The figures of reports/reduced/step_kernels/README.md from its runs: the benchmark's times per
model, binary and variant (benchmarks.txt: two rounds of three repetitions), and each `irdm play`
variant's deformation step, force step, lag and force errors over its rounds (play_ab/*).

Usage: /usr/bin/python3 summarize.py > summary.txt   (in this folder)
"""
import collections
import csv
import glob
import re


def span(values, scale=1.0, fmt="{:.3g}"):
    lo, hi = min(values) * scale, max(values) * scale
    return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else f"{fmt.format(lo)} to {fmt.format(hi)}"


def benchmarks():
    times = collections.defaultdict(list)
    blocks = re.split(r"^=== ", open("benchmarks.txt").read(), flags=re.M)[1:]
    for block in blocks:
        model, commit = re.match(r"(\S+), (\S+), round", block).groups()
        for line in block.splitlines():
            m = re.match(r"  ((?:step|tangent U\^T \(K U\)), .*?)\s{2,}([\d.]+) us", line)
            if m and "sum to" not in line:
                times[(model, commit, m.group(1))].append(float(m.group(2)) / 1000)
    print("benchmark (ms; min to max of 2 rounds x 3 repetitions)")
    for (model, commit, name), t in sorted(times.items()):
        print(f"  {model:18s} {commit:8s} {name:50s} {span(t)}")


def play():
    runs = collections.defaultdict(list)
    for folder in sorted(glob.glob("play_ab/*_[0-9]")):
        variant = folder.split("/")[1].rsplit("_", 1)[0]
        s = next(csv.DictReader(open(f"{folder}/summary.csv")))
        steps = [float(r["deformation_step_us"]) for r in csv.DictReader(open(f"{folder}/deformation.csv"))]
        runs[variant].append(dict(
            p50=float(s["deformation_step_p50_us"]) / 1000, p99=float(s["deformation_step_p99_us"]) / 1000,
            max=float(s["deformation_step_max_us"]) / 1000,
            over_1ms=sum(x > 1000 for x in steps) / len(steps), over_2ms=sum(x > 2000 for x in steps),
            force_p99=float(s["force_step_p99_us"]), force_max=float(s["force_step_max_us"]),
            lag_p99=float(s["lag_p99_ms"]), lag_max=float(s["lag_max_ms"]),
            lockstep=float(s["lockstep_force_error"]), implicit=float(s["implicit_force_error"]),
            failed=int(s["failed_steps"]), cut=int(s["cut_steps"])))
    print("irdm play, press_head.csv at 500 Hz (per variant, min to max over its rounds)")
    for variant, rs in runs.items():
        col = lambda k: [r[k] for r in rs]
        print(f"  {variant} ({len(rs)} runs): deformation step p50 {span(col('p50'))} ms, p99 {span(col('p99'))} ms, "
              f"max {span(col('max'))} ms; steps over 1 ms {span(col('over_1ms'), 100)} %, over 2 ms {span(col('over_2ms'))}; "
              f"force step p99 {span(col('force_p99'))} us, max {span(col('force_max'))} us; lag p99 {span(col('lag_p99'))} ms, "
              f"max {span(col('lag_max'))} ms; force vs lockstep {span(col('lockstep'))}, vs one loop {span(col('implicit'))}; "
              f"not converged {sum(col('failed'))}, cut {sum(col('cut'))}")


benchmarks()
print()
play()
