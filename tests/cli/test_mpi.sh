#!/usr/bin/env bash
# The solver on MPI ranks (render/ranks.h, docs/ranks.md), as a user starts it:
#   - one rank under mpirun writes byte for byte what the program alone writes, and
#     what the same program built without MPI writes;
#   - two ranks on the homogeneous box converge to 1 like one process, sharing out
#     the diffuse shot;
#   - the answer does not depend on the rank count (1, 2, 3 ranks agree within their
#     noise), and the same seed and rank count give the same bytes, for any threads;
#   - a rank that fails (its scene file missing) makes every rank exit with one line
#     naming it, exit code 2, and no output written; bad input on every rank gives one
#     line, not one per rank; the patch limit counts each rank's share of the
#     machine's memory; what ranks cannot do is refused with one line; ranks
#     started with different commands all exit at once with one line.
# Usage: test_mpi.sh PATH/TO/raybundle MPIEXEC PATH/TO/raybundle_without_mpi
set -uo pipefail
bin=$1
mpiexec=$2
single=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
passed=0
failed=0
fail() { echo "FAIL: $*"; failed=$((failed + 1)); }
ok() { passed=$((passed + 1)); }
# -q: without it mpirun adds its own banner to a rank's non-zero exit.
mpi() { local n=$1; shift; "$mpiexec" -q --allow-run-as-root --oversubscribe -np "$n" "$@"; }
json() { python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(eval(sys.argv[2], {}, {'d': d}))" "$@"; }

# One rank under mpirun is the single-process run, bit for bit (final gather included).
box=(solve --builtin homogeneous-box --iterations 300 --gather 8 -D camera.width=48 -D camera.height=48)
"$bin" "${box[@]}" -q -o alone.exr --patches alone.csv --stats alone.json || fail "alone: exit $?"
mpi 1 "$bin" "${box[@]}" -q -o one.exr --patches one.csv --stats one.json || fail "one rank: exit $?"
if cmp -s alone.exr one.exr && cmp -s alone.csv one.csv; then ok; else fail "one rank differs from the program alone"; fi
"$single" "${box[@]}" -q -o single.exr --patches single.csv || fail "the build without MPI: exit $?"
if cmp -s single.exr one.exr && cmp -s single.csv one.csv; then ok; else fail "one rank differs from the build without MPI"; fi
"$single" --version | grep -q "ranks *none" && ok || fail "the build without MPI: $("$single" --version | tail -1)"
[ "$(json one.json "d['ranks']")" = 1 ] && ok || fail "one rank: stats ranks $(json one.json "d['ranks']")"

# Two ranks on the homogeneous box: to 1 like one process.
conv=(solve --builtin homogeneous-box --gather 0 -q)
"$bin" "${conv[@]}" --iterations 4000 --threads 1 --stats c1.json || fail "convergence alone: exit $?"
mpi 2 "$bin" "${conv[@]}" --iterations 4000 --threads 1 --stats c2.json --patches c2.csv || fail "convergence on 2 ranks: exit $?"
read -r e1 e2 m2 r2 s2 <<<"$(python3 -c "
import json
a, b = json.load(open('c1.json')), json.load(open('c2.json'))
print(a['relative_l1_error'], b['relative_l1_error'], b['mean_radiance'], b['ranks'], b['steps_planned'])")"
python3 -c "import sys; e1, e2, m2 = map(float, sys.argv[1:4]); sys.exit(not (e2 < 0.01 and e2 < 1.5 * e1 and abs(m2 - 1) < 0.005))" \
  "$e1" "$e2" "$m2" && ok || fail "2 ranks: relative L1 error $e2 (alone $e1), mean radiance $m2"
[ "$r2" = 2 ] && [ "$s2" = 4000 ] && ok || fail "2 ranks: stats ranks $r2, steps_planned $s2"
# The diffuse shot is shared out, not computed by every rank: the same receivers and
# shadow rays in all as one process's.
[ "$(json c1.json "d['decisions']['diffuse_shot']")" = "$(json c2.json "d['decisions']['diffuse_shot']")" ] && ok ||
  fail "2 ranks: the diffuse shot $(json c2.json "d['decisions']['diffuse_shot']"), alone $(json c1.json "d['decisions']['diffuse_shot']")"

# The ranks' fields are averaged, each counted once: rank 0 of two runs what one
# process runs with half the iterations (chains 0 and 1, steps split alike), so
# G = 2 F_two - F_alone(half) is rank 1's field: a sample of its own (not rank 0's
# again) with the answer 1 and the noise of one process (not 3 or 0.5: a sum or a
# mean that leaves a rank out).
"$bin" "${conv[@]}" --iterations 2000 --threads 1 --patches half.csv || fail "half alone: exit $?"
python3 - <<'EOF' && ok || fail "the two ranks' fields are not averaged each once"
import csv, sys
rows = lambda f: list(csv.DictReader(open(f)))
half, two = rows("half.csv"), rows("c2.csv")
area = [float(r["area"]) for r in half]
total = 3 * sum(area)
f1 = [[float(r[k]) for k in "rgb"] for r in half]
g = [[2 * float(r[k]) - x for k, x in zip("rgb", p)] for r, p in zip(two, f1)]
l1 = lambda f, ref: sum(w * abs(v - r) for w, p, q in zip(area, f, ref) for v, r in zip(p, q)) / total
ones = [[1.0] * 3 for _ in area]
mean_g = sum(w * v for w, p in zip(area, g) for v in p) / total
e1, eg, apart = l1(f1, ones), l1(g, ones), l1(g, f1)
print(f"rank 1's field: mean {mean_g:.5f}, error {eg:.4g} (one process: {e1:.4g}), apart from rank 0's by {apart:.4g}")
sys.exit(not (abs(mean_g - 1) < 0.01 and eg < 2 * e1 and apart > 0.5 * e1))
EOF

# The same seed and rank count: the same bytes, with any threads per rank.
mpi 2 "$bin" "${conv[@]}" --iterations 4000 --threads 2 --patches c2-threads.csv || fail "2 ranks, 2 threads: exit $?"
cmp -s c2.csv c2-threads.csv && ok || fail "2 ranks: the result depends on the threads"

# Rank-count independence: the Cornell box's field on 1, 2 and 3 ranks, each pair
# within four times its noise (the fields' estimated errors), per patch and in the mean.
cb=(solve --builtin cornell-box --patch-size 100 --iterations 1200 --gather 0 --threads 1 -q)
for n in 1 2 3; do
  mpi "$n" "$bin" "${cb[@]}" --patches cb$n.csv --stats cb$n.json || fail "cornell box on $n ranks: exit $?"
done
python3 - <<'EOF' && ok || fail "the Cornell box's field depends on the rank count"
import csv, json, math, sys
fields, noise, means = {}, {}, {}
for n in (1, 2, 3):
    rows = list(csv.DictReader(open(f"cb{n}.csv")))
    fields[n] = [(float(r["area"]), [float(r[k]) for k in "rgb"]) for r in rows]
    stats = json.load(open(f"cb{n}.json"))
    noise[n], means[n] = stats["estimate"]["field_estimated_error"], stats["mean_radiance"]
bad = False
for a, b in ((1, 2), (1, 3), (2, 3)):
    diff = sum(w * abs(x - y) for (w, ca), (_, cb) in zip(fields[a], fields[b]) for x, y in zip(ca, cb))
    total = sum(w * abs(x) for w, ca in fields[a] for x in ca)
    allowed = 4 * math.hypot(noise[a], noise[b])
    print(f"ranks {a} vs {b}: relative L1 difference {diff / total:.4g} (noise {allowed / 4:.4g}), "
          f"means {means[a]:.6g} {means[b]:.6g}")
    bad |= diff / total > allowed or abs(means[a] - means[b]) > allowed * means[a]
sys.exit(bad)
EOF
# The ranks split the contact search and swap its lines: the scene they solve is the
# one a single process prepares (its patches' areas to the last digit, its contacts).
python3 - <<'EOF' && ok || fail "the scene prepared on 2 or 3 ranks differs from one rank's"
import csv, json, sys
def scene(n):
    stats = json.load(open(f"cb{n}.json"))
    return stats["patches"], stats["contacts"], [r["area"] for r in csv.DictReader(open(f"cb{n}.csv"))]
one = scene(1)
print("contacts on 1 rank:", one[1])
sys.exit(any(scene(n) != one for n in (2, 3)) or one[1]["lines"] == 0)
EOF

# A rank that fails: its scene file is missing on its node (the same command in another
# working directory, where the file is not). One line naming the rank, exit 2 on every
# rank, nothing written.
mkdir -p out node0 node1
printf '{"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0], "width": 16, "height": 16}, %s, %s}\n' \
  '"materials": {"w": {"albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]}}' \
  '"objects": [{"quad": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "material": "w"}]' >node0/s.json
node=(solve s.json --iterations 400 -o out/img.exr --stats out/s.json)
mpi 1 --wdir node0 "$bin" "${node[@]}" : -np 1 --wdir node1 "$bin" "${node[@]}" >stdout.txt 2>err.txt
rc=$?
if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "rank 1 of 2: s.json" err.txt &&
   [ ! -e node0/out ] && [ ! -e node1/out ]; then ok; else
  fail "a failing rank: exit $rc, outputs '$(ls node0 node1)', stderr: $(cat err.txt)"
fi

# Nodes whose scene files differ: the contact search, split among the ranks, finds it
# before any cut. One line, exit 2 on every rank, nothing written.
mkdir -p diff0 diff1
for k in 0 1; do
  printf '{"camera": {"eye": [0.5, 0.5, 3], "target": [0.5, 0.5, 0], "width": 16, "height": 16}, %s, %s, %s}\n' \
    '"materials": {"w": {"albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1]}}' "\"patch_size\": 0.$((k + 2))" \
    '"objects": [{"quad": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], "material": "w"}]' >diff$k/s.json
done
mpi 1 --wdir diff0 "$bin" "${node[@]}" : -np 1 --wdir diff1 "$bin" "${node[@]}" >stdout.txt 2>err.txt
rc=$?
if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "s.json: the ranks' scenes differ: rank 1 has" err.txt &&
   [ ! -e diff0/out ] && [ ! -e diff1/out ]; then ok; else
  fail "scenes that differ between nodes: exit $rc, stderr: $(cat err.txt)"
fi

# Ranks on one machine share its memory: the patch limit counts each rank's share
# (where the machine's memory is what bounds it: below 48 GB, 2 x 20 million patches'
# preparation; else the 20 million).
mpi 2 "$bin" solve --builtin cornell-box -D patch_size=0.3 -o out/img.exr >stdout.txt 2>err.txt
rc=$?
if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "patch_size: 0.3 would make about" err.txt &&
   { grep -q "KB each while the scene is prepared, and .* has .* for 2 ranks)" err.txt ||
     { ! grep -q "KB each" err.txt && grep -q "(limit 20,000,000)" err.txt; }; } && [ -z "$(ls out)" ]; then ok; else
  fail "the patch limit on 2 ranks: exit $rc, stderr: $(cat err.txt)"
fi

# Bad input on every rank: one line, not one per rank.
printf '{"camera": ' >broken.json
mpi 2 "$bin" solve broken.json -o out/img.exr >stdout.txt 2>err.txt
rc=$?
if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "broken.json" err.txt && [ -z "$(ls out)" ]; then ok; else
  fail "bad input on 2 ranks: exit $rc, stderr: $(cat err.txt)"
fi

# What ranks cannot do: one line before any work.
for args in "--time-budget 5" "--method pathtrace" "--checkpoint out/k.bin"; do
  # shellcheck disable=SC2086
  mpi 2 "$bin" solve --builtin homogeneous-box $args -o out/img.exr >stdout.txt 2>err.txt
  rc=$?
  if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -qF -- "${args%% *}" err.txt && [ -z "$(ls out)" ]; then ok; else
    fail "$args on 2 ranks: exit $rc, stderr: $(cat err.txt)"
  fi
done

# Ranks started with different commands (MPMD: solve beside check or --version): every
# rank exits at once, with one line, before any exchange (they hung before).
for other in "check --builtin homogeneous-box" "--version"; do
  start=$(date +%s)
  # shellcheck disable=SC2086
  timeout 60 "$mpiexec" -q --allow-run-as-root --oversubscribe -np 1 "$bin" solve --builtin homogeneous-box \
    --iterations 50 --gather 0 -o out/mixed.exr : -np 1 "$bin" $other >stdout.txt 2>err.txt
  rc=$?
  secs=$(($(date +%s) - start))
  if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q "runs another command than rank 0" err.txt &&
    [ "$secs" -le 5 ] && [ ! -e out/mixed.exr ]; then ok; else
    fail "solve beside $other: exit $rc after $secs s, stderr: $(cat err.txt)"
  fi
done

# A rank killed outright (kill -9) mid-solve: rank 0 names it (and only once: no
# "stopping" line follows), mpirun ends the run within seconds, nothing is written.
"$mpiexec" -q --allow-run-as-root --oversubscribe -np 2 "$bin" solve --builtin cornell-box --iterations 1000000000 \
  --gather 0 -q -o out/killed.exr >stdout.txt 2>err.txt &
launcher=$!
victim=
for _ in $(seq 1 100); do  # rank 1: the process whose environment says so
  for p in $(pgrep -P "$launcher"); do
    tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null | grep -qx OMPI_COMM_WORLD_RANK=1 && victim=$p
  done
  [ -n "$victim" ] && break
  sleep 0.1
done
sleep 2  # into the solve
start=$(date +%s)
[ -n "$victim" ] && kill -9 "$victim"
timeout 30 tail --pid="$launcher" -f /dev/null
wait "$launcher"
rc=$?
secs=$(($(date +%s) - start))
if [ -n "$victim" ] && [ "$rc" -ne 0 ] && grep -q "rank 1 of 2 (process $victim) ended before the run" err.txt &&
  ! grep -q stopping err.txt &&
  [ "$secs" -le 10 ] && [ ! -e out/killed.exr ]; then ok; else
  fail "rank 1 killed: exit $rc after $secs s, stderr: $(cat err.txt)"
fi

# The other ranks print nothing: one result line from two ranks.
mpi 2 "$bin" solve --builtin homogeneous-box --iterations 100 --gather 0 >stdout.txt 2>err.txt
[ "$(grep -c "homogeneous-box:" stdout.txt)" -eq 1 ] && ok || fail "2 ranks printed: $(cat stdout.txt)"

echo "mpi: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
