#!/usr/bin/env bash
# The error estimate on every run, and rounds for a target error or a time budget;
# --filter-radius, --direct-samples, --correction.
# Usage: test_cli_rounds.sh PATH/TO/raybundle SOURCE_DIR
# shellcheck source=tests/cli/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"

# The error estimate on every run, and rounds for a target error or a time budget.
# --filter-radius: 0 (the default) chooses it from the image and the rays per pass, a
# number sets it; --direct-samples; both in the stats, and refused out of range.
"$bin" solve --builtin cornell-box --patch-size 100 --iterations 50 --width 64 --height 64 --gather 8 --spp 2 \
  --stats fr-auto.json -q &&
  "$bin" solve --builtin cornell-box --patch-size 100 --iterations 50 --width 64 --height 64 --gather 8 --spp 2 \
    --filter-radius 5 --direct-samples 3 --stats fr-5.json -q
check $? "--filter-radius / --direct-samples runs failed"
r_auto=$(json_number filter_radius fr-auto.json)
[ "$(json_number filter_radius fr-5.json)" = 5 ] && [ "$(json_number direct_samples fr-5.json)" = 3 ] &&
  [ -n "$r_auto" ] && [ "$r_auto" -ge 1 ]
check $? "--filter-radius 5 --direct-samples 3 not in the stats, or the automatic radius not >= 1 ($r_auto)"
expect_bad "--filter-radius out of range" "--filter-radius" solve good.json --gather 4 --filter-radius 2000
expect_bad "--direct-samples out of range" "--direct-samples" solve good.json --gather 4 --direct-samples -1
"$bin" solve --builtin homogeneous-box --width 16 --height 16 --iterations 100 --gather 8 --spp 4 --stats est.json \
  --csv est.csv >est.txt 2>&1
check $? "estimate run failed: $(cat est.txt)"
grep -q "estimated error [0-9.]* % (1 round[;)]" est.txt
check $? "summary line lacks the estimated error: $(cat est.txt)"
grep -q '"stopped": "one round: the budget as given"' est.json && grep -q '"field_estimated_error"' est.json
check $? "stats lack the estimate: $(head -c 400 est.json)"
awk -F, '$6 == 1 && $7 != "" { found = 1 } END { exit !found }' est.csv
check $? "convergence CSV has no row for the round with the image's estimate: $(tail -2 est.csv)"
awk -F, 'NR > 1 && $6 == "" && $5 != "" { found = 1 } END { exit !found }' est.csv
check $? "convergence CSV has no solve rows with the field's estimate: $(head -3 est.csv)"
"$bin" solve --builtin homogeneous-box --width 16 --height 16 --iterations 100 --gather 8 --spp 4 --target-error 0.003 \
  --stats target.json >target.txt 2>&1
check $? "--target-error failed: $(cat target.txt)"
e=$(json_number image_estimated_error target.json)
grep -q '"stopped": "the estimate reached the target"' target.json && awk -v e="${e:-1}" 'BEGIN { exit !(e <= 0.003) }' &&
  [ "$(grep -c '"scale"' target.json)" -ge 3 ]
check $? "--target-error 0.003: estimate ${e:-none}, or not reached in rounds: $(grep -A2 stopped target.json)"
"$bin" solve --builtin homogeneous-box --method pathtrace --spp 8 --width 8 --height 8 --target-error 0.01 \
  --stats pt-target.json --csv pt-target.csv -q
check $? "pathtrace with --target-error failed"
grep -q '"stopped": "the estimate reached the target"' pt-target.json && [ "$(wc -l <pt-target.csv)" -ge 3 ]
check $? "pathtrace --target-error: not reached in rounds, or no CSV rows: $(grep stopped pt-target.json)"
for v in 0 -0.1 1.5 nan inf abc; do
  expect_bad "--target-error $v" "--target-error" solve --builtin homogeneous-box --target-error "$v"
done
for v in 0 -1 inf nan; do
  expect_bad "--time-budget $v" "--time-budget" solve --builtin homogeneous-box --time-budget "$v"
done
# The default is auto, said in the stats' final_gather and decisions; --correction 0 reads the field.
"$bin" solve --builtin homogeneous-box --width 8 --height 8 --iterations 20 --gather 16 --stats auto.json -q
check $? "the default correction (auto) failed"
grep -q '"correction": "auto"' auto.json && grep -q '"correction": "auto: ' auto.json
check $? "--correction auto: not in the stats' final_gather and decisions: $(grep correction auto.json)"
"$bin" solve --builtin homogeneous-box --width 8 --height 8 --iterations 20 --gather 16 --correction 0 --stats read.json -q
check $? "--correction 0 failed"
grep -q '"correction": "the field read as the answer (--correction 0)"' read.json
check $? "--correction 0: not in the stats' decisions: $(grep correction read.json)"
for v in -0.1 1.5 nan abc; do
  expect_bad "--bias-probe $v" "--bias-probe" solve --builtin homogeneous-box --bias-probe "$v"
done
expect_bad "--bias-probe with pathtrace" "--bias-probe" solve --builtin homogeneous-box --method pathtrace --bias-probe 0.1
expect_bad "--bias-probe without the gather" "--bias-probe" solve --builtin homogeneous-box --gather 0 --bias-probe 0.1
# A budget the scene's preparation takes whole: one round all the same, said in a
# warning. Its wall time is the least this run takes (the preparation and one first
# round) on this machine as loaded now: the budgets below are multiples of it, so that
# a slow build (the sanitizers') or a busy machine asks for the same rounds.
budget_run=(solve --builtin homogeneous-box --width 16 --height 16 --iterations 20 --gather 4 --spp 1)
now() { date +%s.%N; }
t0=$(now)
"$bin" "${budget_run[@]}" --time-budget 0.000001 -o tiny-budget.exr --stats tiny-budget.json -q 2>tiny-budget.txt
rc=$?
least=$(awk -v a="$t0" -v b="$(now)" 'BEGIN { print b - a }')
check $rc "--time-budget 1e-6 failed: $(cat tiny-budget.txt)"
grep -q "preparing the scene took .* nothing is left for the image; one first round runs" tiny-budget.txt &&
  [ -s tiny-budget.exr ] && [ "$(grep -c '"scale"' tiny-budget.json)" -eq 2 ]
check $? "--time-budget 1e-6: no warning, no image or not one round: $(cat tiny-budget.txt)"
# The budget spent in several rounds, and kept: the command's wall time within
# 1.15 S + the least + 0.5 s, for S = max(2 s, 6 x the least).
budget=$(awk -v l="$least" 'BEGIN { s = 6 * l; printf "%.2f", (s > 2 ? s : 2) }')
t0=$(now)
"$bin" "${budget_run[@]}" --time-budget "$budget" -o kept.exr --stats budget.json -q
rc=$?
t=$(awk -v a="$t0" -v b="$(now)" 'BEGIN { print b - a }')
check $rc "--time-budget $budget failed"
grep -q '"stopped": "the time budget"' budget.json && [ "$(grep -c '"scale"' budget.json)" -ge 3 ]
check $? "--time-budget $budget: not stopped by the budget after several rounds: $(grep -A2 stopped budget.json)"
awk -v t="$t" -v s="$budget" -v l="$least" 'BEGIN { exit !(t <= 1.15 * s + l + 0.5) }'
check $? "--time-budget $budget: the command took $t s (the least it takes: $least s)"
# The field as a control variate: on, in the stats; a probability, else refused.
"$bin" solve --builtin homogeneous-box --width 8 --height 8 --iterations 20 --gather 16 --correction 0.5 \
  --stats corrected.json -q
check $? "--correction 0.5 failed"
grep -q '"correction": 0.5' corrected.json
check $? "--correction 0.5: not in the stats' final_gather"
for v in -0.1 1.5 nan abc Auto; do
  expect_bad "--correction $v" "--correction" solve --builtin homogeneous-box --correction "$v"
done
expect_bad "--csv-every with pathtrace" "--csv-every does not apply to --method pathtrace" \
  solve --builtin homogeneous-box --method pathtrace --csv-every 5

finish cli-rounds
