#!/usr/bin/env bash
# Checkpoints and signals: a killed run resumes to byte-identical outputs, SIGINT
# and SIGTERM write partial outputs, hand-made checkpoints are refused by name,
# the memory guard.
# Usage: test_cli_checkpoint.sh PATH/TO/raybundle SOURCE_DIR
# shellcheck source=tests/cli/cli_common.sh
source "$(dirname "${BASH_SOURCE[0]}")/cli_common.sh"

# Checkpoints and signals (apps/checkpoint.h, apps/signals.h): a run killed with
# SIGKILL once its first checkpoint is written, then resumed, writes byte-identical
# outputs to an uninterrupted run; SIGINT writes the outputs of the steps done, marked
# partial, exits 130 and leaves a checkpoint that resumes to the same result again.
ck_base=(solve --builtin cornell-box --gather 0 --width 32 --height 32 --iterations 8000 -q)
ck=("${ck_base[@]}" --patch-size 150 --seed 5)
"$bin" "${ck[@]}" -o ck-full.exr --patches ck-full.csv
check $? "checkpoint: the uninterrupted run failed"
# Starts a run in the background, waits for its first checkpoint, sends the signal;
# the run's exit code in $rc.
interrupt() {
  local sig=$1 file=$2
  shift 2
  # A background job of a script starts with SIGINT ignored, which raybundle respects
  # (as under nohup): give it the default back.
  env --default-signal=INT "$bin" "${ck[@]}" --checkpoint "$file" --checkpoint-every 400 "$@" 2>signal-err.txt &
  local pid=$!
  for _ in $(seq 1 1200); do [ -f "$file" ] && break; sleep 0.05; done
  kill "-$sig" "$pid"
  wait "$pid"
  rc=$?
}
interrupt KILL ck-kill.bin -o ck-kill.exr
[ "$rc" -eq 137 ] && [ ! -e ck-kill.exr ]
check $? "checkpoint: the run was not killed part-way (exit $rc), or wrote its image"
"$bin" "${ck[@]}" --resume ck-kill.bin -o ck-kill.exr --patches ck-kill.csv --stats ck-kill.json
check $? "--resume after SIGKILL failed"
cmp -s ck-full.exr ck-kill.exr && cmp -s ck-full.csv ck-kill.csv && grep -q '"resumed"' ck-kill.json
check $? "killed and resumed: outputs differ from the uninterrupted run's"
interrupt INT ck-int.bin -o ck-int.exr --stats ck-int.json
[ "$rc" -eq 130 ] && [ -s ck-int.exr ] && grep -q '"partial": true' ck-int.json &&
  grep -q '"interrupted_by": "SIGINT"' ck-int.json && grep -q "stopped after" signal-err.txt &&
  [ "$(ls -a | grep -c -e '^\.raybundle-' -e 'partial-')" -eq 0 ]
check $? "SIGINT: exit $rc, or no partial image and stats, or temporaries left: $(cat signal-err.txt)"
"$bin" "${ck[@]}" --resume ck-int.bin --checkpoint ck-int.bin -o ck-int.exr --patches ck-int.csv --threads 1
check $? "--resume after SIGINT failed"
cmp -s ck-full.exr ck-int.exr && cmp -s ck-full.csv ck-int.csv
check $? "interrupted by SIGINT and resumed (on one thread): outputs differ from the uninterrupted run's"
interrupt TERM ck-term.bin -o ck-term.exr --stats ck-term.json
[ "$rc" -eq 143 ] && [ -s ck-term.exr ] && grep -q '"interrupted_by": "SIGTERM"' ck-term.json
check $? "SIGTERM: exit $rc (143 expected), or no partial image: $(cat signal-err.txt)"
# A signal while the run cannot stop cleanly (the path tracer) abandons it, with one
# line that says so and nothing written.
env --default-signal=INT "$bin" solve --builtin cornell-box --method pathtrace --spp 100000 --width 32 --height 32 \
  -o pt-abandoned.png 2>signal-err.txt &
pid=$!
sleep 1
kill -INT "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 130 ] && [ ! -e pt-abandoned.png ] &&
  grep -q "raybundle: SIGINT: the run abandoned: the files it had not written yet are left as they were" signal-err.txt
check $? "SIGINT while path tracing: exit $rc, $(cat signal-err.txt)"
# A signal the run was started ignoring stays ignored (nohup: SIGHUP).
nohup "$bin" "${ck[@]}" -o ck-hup.exr >/dev/null 2>&1 &
pid=$!
sleep 0.5
kill -HUP "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 0 ] && cmp -s ck-full.exr ck-hup.exr
check $? "SIGHUP under nohup: exit $rc, or the run did not complete"
# The same scene given by another path resumes: ./s.json is s.json.
scene "$quad" > same.json
"$bin" solve same.json --gather 0 --iterations 100 --checkpoint same.bin --checkpoint-every 20 -q &&
  "$bin" solve ./same.json --gather 0 --iterations 100 --resume same.bin -q
check $? "--resume with the scene named ./same.json refused"
# The same run by other spellings: -D's assignments in another order, numbers spelt
# otherwise (02000, 0.50).
"$bin" solve same.json --gather 0 --iterations 2000 -D camera.width=16 -D camera.height=8 -D patch_size=0.5 \
  --checkpoint spelt.bin --checkpoint-every 400 -q &&
  "$bin" solve same.json --gather 0 --iterations 02000 -D patch_size=0.50 -D camera.height=8 -D camera.width=16 \
    --resume spelt.bin -q 2>err.txt
check $? "--resume with -D in another order and numbers spelt otherwise refused: $(cat err.txt)"
expect_bad "--resume with a -D value changed" "the scene differs" solve same.json --gather 0 --iterations 2000 -D camera.width=16 \
  -D camera.height=9 -D patch_size=0.5 --resume spelt.bin
head -c 2000 ck-kill.bin >ck-cut.bin
expect_bad "--resume of a cut checkpoint" "--resume ck-cut.bin: its checksum does not match" "${ck[@]}" --resume ck-cut.bin
expect_bad "--resume of an image" "--resume ck-full.exr: not a raybundle checkpoint" "${ck[@]}" --resume ck-full.exr
expect_bad "--resume of a missing file" "--resume missing.bin" "${ck[@]}" --resume missing.bin
expect_bad "--resume with another seed" "--seed was 5, now 6" "${ck_base[@]}" --patch-size 150 --seed 6 --resume ck-kill.bin
expect_bad "--resume with another option" "--ambient true is given now, not then" "${ck[@]}" --ambient --resume ck-kill.bin
scene "$quad" > edited.json
"$bin" solve edited.json --gather 0 --iterations 100 --checkpoint edited.bin --checkpoint-every 20 -q
sed -i 's/0.5, 0.5, 0.5/0.5, 0.5, 0.6/' edited.json
expect_bad "--resume of an edited scene" "the scene differs" solve edited.json --gather 0 --iterations 100 --resume edited.bin
# A sun is part of the scene: added, or turned, the checkpoint's scene differs.
sun='directional_lights=[{"direction": [0.3, -1, 0.2], "irradiance": [2, 2, 2]}]'
"$bin" solve edited.json -D "$sun" --gather 0 --iterations 100 --checkpoint sun.bin --checkpoint-every 20 -q
check $? "a run with a sun and a checkpoint failed"
expect_bad "--resume without the sun" "the scene differs" solve edited.json --gather 0 --iterations 100 --resume sun.bin
expect_bad "--resume with the sun turned" "the scene differs" solve edited.json -D "$sun" \
  -D 'directional_lights[0].direction=[0.3, -1, 0.3]' --gather 0 --iterations 100 --resume sun.bin
expect_bad "--checkpoint with a target" "--checkpoint works for runs of one round: not with --target-error" \
  "${ck[@]}" --checkpoint c.bin --target-error 0.01
"$bin" solve --builtin homogeneous-box --method pathtrace --resume ck-kill.bin -o pt.exr 2>err.txt
[ $? -eq 2 ] && grep -q -- "--resume does not apply to --method pathtrace" err.txt && [ ! -e pt.exr ]
check $? "--resume with pathtrace: $(cat err.txt)"
# Hand-made checkpoints with their checksums recomputed (render/checkpoint.cpp: magic,
# byte order, the JSON header, the chains, FNV-1a of it all): a header value of the
# wrong type or out of range is refused by name, with exit 2 and one line.
forge() {  # IN OUT PYTHON-EXPRESSION-ON-h (the header, a dict)
  python3 - "$1" "$2" "$3" <<'PY'
import json, struct, sys
data = open(sys.argv[1], "rb").read()[:-8]
magic_end = data.index(b"\n") + 1 + 4
n = struct.unpack("<Q", data[magic_end:magic_end + 8])[0]
h = json.loads(data[magic_end + 8:magic_end + 8 + n])
exec(sys.argv[3])
header = json.dumps(h).encode()
out = data[:magic_end] + struct.pack("<Q", len(header)) + header + data[magic_end + 8 + n:]
f = 0xcbf29ce484222325
for b in out:
    f = ((f ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
open(sys.argv[2], "wb").write(out + struct.pack("<Q", f))
PY
}
forge ck-kill.bin ck-same.bin "pass"
"$bin" "${ck[@]}" --resume ck-same.bin -o ck-same.exr --patches ck-same.csv 2>err.txt && cmp -s ck-same.csv ck-full.csv
check $? "--resume of a checkpoint rewritten as it was: $(cat err.txt)"
forge ck-kill.bin ck-type.bin "h['identity'] = 5"
expect_bad "--resume of an identity of the wrong type" "ck-type.bin: its header is damaged (identity: not an object)" \
  "${ck[@]}" --resume ck-type.bin
forge ck-kill.bin ck-steps.bin "h['steps_done'] = 400.5"
expect_bad "--resume of a fractional step count" "ck-steps.bin: its header is damaged (steps_done" "${ck[@]}" --resume ck-steps.bin
forge ck-kill.bin ck-seconds.bin "h['seconds'] = -1"
expect_bad "--resume of negative seconds" "ck-seconds.bin: its header is damaged (seconds" "${ck[@]}" --resume ck-seconds.bin
forge ck-kill.bin ck-rows.bin "h['rows'] = {}"
expect_bad "--resume of rows that are not a list" "ck-rows.bin: its header is damaged (rows" "${ck[@]}" --resume ck-rows.bin
# A checkpoint larger than half this machine's memory: refused at once, not read (a
# sparse file of 60 % of the memory, its magic line right).
printf 'raybundle checkpoint 2\n' >huge.bin
truncate -s $(($(awk '/MemTotal/ {print $2}' /proc/meminfo) * 1024 * 6 / 10)) huge.bin
expect_bad "--resume of a checkpoint larger than half the memory" "this process may hold" \
  "${ck[@]}" --resume huge.bin
rm -f huge.bin
expect_bad "--checkpoint-every alone" "--checkpoint-every needs --checkpoint FILE" "${ck[@]}" --checkpoint-every 10
for v in 0 -3 1.5 abc 0s -2s s; do
  expect_bad "--checkpoint-every $v" "--checkpoint-every" "${ck[@]}" --checkpoint c.bin --checkpoint-every "$v"
done
expect_bad "--checkpoint onto a device" "--checkpoint /dev/null: is a device" "${ck[@]}" --checkpoint /dev/null
expect_bad "--checkpoint onto the scene file" "--checkpoint good.json: is the scene file" \
  solve good.json --checkpoint good.json

# The memory guard: a run that cannot fit is refused before any work (16384^2 pixels,
# 16384^2 global z-buffer maps on 1024 threads: some 16 TB on any machine).
expect_bad "memory guard" "need about" solve --builtin homogeneous-box --width 16384 --height 16384 \
  --visibility global-zbuffer --resolution 16384 --threads 1024

finish cli-checkpoint
