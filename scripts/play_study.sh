#!/usr/bin/env bash
# The two asynchronous loops measured (issue 15): irdm play on the cat's vertex model over the
# shipped device trajectories, each configuration repeated (this VM's scheduling varies from run
# to run), then one table over all repetitions (reports/play/study.md, study.csv).
# Usage: scripts/play_study.sh [MODEL.h5] [OUT_DIR]
#   MODEL.h5  default out/models/quick/cat_vertex.h5 (scripts/main.sh makes it)
#   OUT_DIR   default reports/play
# Each configuration's first repetition keeps its files in OUT_DIR/NAME/ (press_k100_1khz also
# its VTU frames and frames.png); the others keep play.md, summary.csv and surface_updates.csv
# in OUT_DIR/NAME/rK/. Every force step's and surface update's latency, of every repetition,
# goes to OUT_DIR/samples.csv.gz (run,repetition,kind,us) for percentiles pooled over the runs.
# About 10 minutes (each run first measures its baseline: the same loop with no work). Run it on an otherwise idle machine: it measures deadlines.
set -euo pipefail
cd "$(dirname "$0")/.."
model=${1:-out/models/quick/cat_vertex.h5}
out=${2:-reports/play}
[ -f "$model" ] || { echo "play_study: no model $model (scripts/main.sh makes it)" >&2; exit 2; }
mkdir -p "$out"
csv="$out/study.csv.part"
samples="$out/samples.csv.part"
echo "run,repetition,kind,us" > "$samples"
first=1
play() { # NAME REPETITIONS FRAMES [irdm play options]
  local name=$1 reps=$2 frames=$3
  shift 3
  for r in $(seq 1 "$reps"); do
    local dir="$out/$name"
    [ "$r" -gt 1 ] && dir="$out/$name/r$r"
    rm -rf "$dir.tmp"
    # Exit 3 (more than 0.1 % of deadlines missed) is a measurement, not a failure here.
    build/apps/irdm play "$model" --frames "$([ "$r" -eq 1 ] && echo "$frames" || echo 0)" \
      --out "$dir.tmp" --quiet "$@" > /dev/null || [ $? -eq 3 ]
    # The latencies by column name: force_step_us of forces.csv, surface_update_us of
    # surface_updates.csv.
    for f in forces.csv:force_step surface_updates.csv:surface_update; do
      awk -F, -v run="$name" -v rep="$r" -v kind="${f#*:}" -v col="${f#*:}_us" \
        'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == col) c = i; next }
         { printf "%s,%s,%s,%.4g\n", run, rep, kind, $c }' "$dir.tmp/${f%%:*}" >> "$samples"
    done
    if [ "$r" -gt 1 ]; then rm -rf "$dir.tmp/surface" "$dir.tmp/forces.csv" "$dir.tmp/histogram.csv"; fi
    rm -rf "$dir"
    mv "$dir.tmp" "$dir"
    if [ $first -eq 1 ]; then echo "run,repetition,$(head -1 "$dir/summary.csv")" > "$csv"; first=0; fi
    echo "$name,$r,$(tail -1 "$dir/summary.csv")" >> "$csv"
    echo "play_study: $name r$r: $(cut -d, -f4 <<< "$(tail -1 "$dir/summary.csv")") missed"
  done
}
T=examples/trajectories
coupled="--coupling-stiffness 300 --coupling-damping 0.5"
play press_k100_1khz       10 100 --trajectory $T/press_back.csv --rate-hz 1000 --force-modes 100
play press_k100_1khz_warmonce 3 0 --trajectory $T/press_back.csv --rate-hz 1000 --force-modes 100 --warm-once
play press_k100_1khz_nowarm 3 0  --trajectory $T/press_back.csv --rate-hz 1000 --force-modes 100 --warm-us 0
play press_k100_1khz_nowarmstep 3 0 --trajectory $T/press_back.csv --rate-hz 1000 --force-modes 100 --no-warm-step
play press_k100_1khz_sleep 5 0   --trajectory $T/press_back.csv --rate-hz 1000 --force-modes 100 --spin-us 0
play press_k100_500hz      3 0   --trajectory $T/press_back.csv --force-modes 100
play press_all_500hz       2 0   --trajectory $T/press_back.csv
play press_k100_10khz      3 0   --trajectory $T/press_back.csv --rate-hz 10000 --force-modes 100
play stroke_k100_1khz      3 0   --trajectory $T/stroke_back.csv --rate-hz 1000 --force-modes 100
play tap_k100_1khz         2 0   --trajectory $T/tap_back.csv --rate-hz 1000 --force-modes 100
# shellcheck disable=SC2086
play tap_coupled_k100_1khz 3 0   --trajectory $T/tap_back.csv --rate-hz 1000 --force-modes 100 $coupled
# shellcheck disable=SC2086
play tap_coupled_all_500hz 2 0   --trajectory $T/tap_back.csv $coupled
# Each file on disk before its rename (sync FILE fsyncs it), and the renames with the folder.
sync "$csv"
mv "$csv" "$out/study.csv"
gzip -n -c "$samples" > "$out/samples.csv.gz.part"
sync "$out/samples.csv.gz.part"
rm "$samples"
mv "$out/samples.csv.gz.part" "$out/samples.csv.gz"
sync "$out"
/usr/bin/python3 validation/summarize_play.py "$out/study.csv" "$out/study.md" "$out/samples.csv.gz"
/usr/bin/python3 validation/plot_frame_strip.py "$out/press_k100_1khz/surface" "$out/press_k100_1khz/frames.png"
echo "play_study: wrote $out/study.md"
