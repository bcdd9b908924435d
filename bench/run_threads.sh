#!/usr/bin/env bash
# Thread scaling, phase by phase (docs/benchmarks.md, "Threads").
#
# Runs `raybundle solve` on 1, 2, ... N threads (N: the machine's hardware threads, or
# the first argument) for three workloads, each REPEATS times (default 3) in turns
# (1, 2, ..., N, 1, 2, ...: a slow spell of the machine hits every count), and keeps
# each phase's least seconds (the stats' "phases": wall seconds and threads of each)
# and the least wall seconds of the whole command. The workloads of issue 27 (its
# measurements on 16 cores, and the ones its criteria name):
#   default    the built-in Cornell box, default pipeline (final gather), 8,000 steps
#   walks      the same, bidirectional walks, 4,000 walks, no gather
#   100k       the Cornell box at --patch-size 10 (121,324 patches), 2,000 steps, no gather
# and the same at a quarter (walks, default) or a twentieth (100k) of the steps, where
# the parts that do not grow with the steps (the scene, the shots, the image, the
# program's start and its outputs) weigh 4-20x more: default-short, walks-short,
# 100k-short (WORKLOADS="default-short walks-short 100k-short").
# Then, per workload and phase, the speed-up over one thread, and the serial fraction s
# of the whole run fitted to Amdahl's law, wall(T) = wall(1) (s + (1 - s) / T), by
# least squares over T = 2..N, with the speed-up it predicts at 16 and 64 threads.
#
# The machine's own ceiling, per workload and repeat: N single-thread runs at once, as
# separate processes. N times one alone over their mean wall time is what N cores give
# when nothing is shared but the hardware (caches, memory bandwidth, a host's other
# guests); a shared 2-core machine can stay well below N. The threads' speed-up at N is
# reported as a share of it, and a serial fraction with it divided out.
#
# Writes OUT (default docs/bench-threads.csv: one row per workload, threads and phase)
# and prints the table. Usage: bench/run_threads.sh [N] [OUT]; WORKLOADS="default walks"
# to run some of them; THREADS="1 2 4 8 16" to run those counts instead of 1..N (1 and N
# are added when missing); RAYBUNDLE=path for another binary (a build for another
# machine). Build first (scripts/build.sh); python3 only.
set -euo pipefail
cd "$(dirname "$0")/.."
raybundle=${RAYBUNDLE:-$PWD/build/apps/raybundle}
[ -x "$raybundle" ] || { echo "run_threads: $raybundle missing (build first: scripts/build.sh)" >&2; exit 1; }
max=${1:-$(nproc)}
out=${2:-docs/bench-threads.csv}
export RAYBUNDLE=$raybundle MAX_THREADS=$max OUT=$out REPEATS=${REPEATS:-3} WORKLOADS=${WORKLOADS:-default walks 100k} THREADS=${THREADS:-}
exec python3 - <<'EOF'
import json, os, subprocess, sys, tempfile, time

raybundle, out = os.environ["RAYBUNDLE"], os.environ["OUT"]
max_threads, repeats = int(os.environ["MAX_THREADS"]), int(os.environ["REPEATS"])
workloads = {
    "default": ["--builtin", "cornell-box", "--iterations", "8000"],
    "walks": ["--builtin", "cornell-box", "--method", "bidirectional", "--iterations", "4000", "--gather", "0"],
    "100k": ["--builtin", "cornell-box", "--patch-size", "10", "--iterations", "2000", "--gather", "0"],
    "default-short": ["--builtin", "cornell-box", "--iterations", "2000"],
    "walks-short": ["--builtin", "cornell-box", "--method", "bidirectional", "--iterations", "1000", "--gather", "0"],
    "100k-short": ["--builtin", "cornell-box", "--patch-size", "10", "--iterations", "100", "--gather", "0"],
}
chosen = os.environ["WORKLOADS"].split()
for w in chosen:
    if w not in workloads:
        sys.exit(f"run_threads: unknown workload '{w}' (known: {', '.join(workloads)})")
threads = sorted({1, max_threads, *map(int, os.environ["THREADS"].split())}) if os.environ["THREADS"] \
    else list(range(1, max_threads + 1))
if threads[0] < 1 or threads[-1] > max_threads:
    sys.exit(f"run_threads: THREADS must lie in 1..{max_threads}")
work = tempfile.mkdtemp(prefix="raybundle-threads.")


def solve(args, t, tag):
    stats = os.path.join(work, f"{tag}.json")
    cmd = [raybundle, "solve", *args, "--seed", "1", "--threads", str(t), "-q",
           "-o", os.path.join(work, f"{tag}.png"), "--stats", stats]
    start = time.monotonic()
    subprocess.run(cmd, check=True)
    wall = time.monotonic() - start
    with open(stats) as f:
        s = json.load(f)
    return wall, {p["phase"]: p["seconds"] for p in s["phases"]}, {p["phase"]: p["threads"] for p in s["phases"]}


def at_once(args, n, tag):
    """n single-thread runs of `args` started together: their mean wall seconds."""
    procs, start, ends = [], time.monotonic(), []
    for k in range(n):
        procs.append(subprocess.Popen([raybundle, "solve", *args, "--seed", "1", "--threads", "1", "-q",
                                       "-o", os.path.join(work, f"{tag}-{k}.png")]))
    for p in procs:
        if p.wait() != 0:
            sys.exit("run_threads: a run of the ceiling failed")
        ends.append(time.monotonic() - start)
    return sum(ends) / len(ends)


best = {}  # (workload, threads) -> (wall, {phase: seconds}, {phase: threads})
together = {}  # workload -> least mean wall of max_threads single-thread runs at once
for w in chosen:
    for r in range(repeats):
        for t in threads:
            print(f"run_threads: {w}, {t} thread(s), run {r + 1} of {repeats}", file=sys.stderr)
            wall, phases, used = solve(workloads[w], t, f"{w}-{t}")
            old = best.get((w, t))
            if old is None:
                best[(w, t)] = (wall, phases, used)
            else:
                best[(w, t)] = (min(old[0], wall), {k: min(v, old[1].get(k, v)) for k, v in phases.items()}, used)
        if max_threads > 1:
            print(f"run_threads: {w}, {max_threads} single-thread runs at once, run {r + 1} of {repeats}",
                  file=sys.stderr)
            mean = at_once(workloads[w], max_threads, f"{w}-ceiling")
            together[w] = min(together.get(w, mean), mean)


def amdahl(walls):
    """Serial fraction s fitted to wall(T)/wall(1) = 1/T + s (1 - 1/T), least squares over T >= 2."""
    num = den = 0.0
    for t, wall in walls.items():
        if t < 2:
            continue
        x = 1.0 - 1.0 / t
        num += (wall / walls[1] - 1.0 / t) * x
        den += x * x
    return num / den if den > 0 else float("nan")


def predicted(s, t):
    return 1.0 / (s + (1.0 - s) / t)


rows = ["workload,threads,phase,phase_threads,seconds,speedup,share_of_run_1_thread"]
print()
for w in chosen:
    one_wall, one_phases, _ = best[(w, 1)]
    walls = {t: best[(w, t)][0] for t in threads}
    s = amdahl(walls)
    print(f"{w} ({' '.join(workloads[w])}), least of {repeats} runs:")
    header = f"  {'phase':<16}{'1 thread: s':>13}{'share':>8}" + "".join(f"{f'{t} thr: s':>12}{'speed-up':>10}" for t in threads[1:])
    print(header)
    names = list(one_phases) + ["whole command"]
    for name in names:
        base = one_wall if name == "whole command" else one_phases[name]
        line = f"  {name:<16}{base:>13.3f}{100 * base / one_wall:>7.1f}%"
        for t in threads:
            wall, phases, used = best[(w, t)]
            sec = wall if name == "whole command" else phases.get(name, 0.0)
            speed = base / sec if sec > 0 else float("nan")
            phase_threads = t if name == "whole command" else used.get(name, t)
            rows.append(f"{w},{t},{name},{phase_threads},{sec:.4f},{speed:.4f},{base / one_wall:.4f}")
            if t > 1:
                line += f"{sec:>12.3f}{speed:>9.2f}x"
        print(line)
    print(f"  Amdahl: serial fraction {100 * s:.2f} %; predicted {predicted(s, 16):.1f}x at 16 threads, "
          f"{predicted(s, 64):.1f}x at 64")
    rows.append(f"{w},fit,serial_fraction,,{s:.5f},,")
    rows.append(f"{w},16,predicted_speedup,,,{predicted(s, 16):.3f},")
    rows.append(f"{w},64,predicted_speedup,,,{predicted(s, 64):.3f},")
    if w in together:
        # What N cores give N independent processes; the threads' speed-up against it,
        # and the serial fraction left when the machine's own shortfall is divided out.
        n = max_threads
        ceiling = n * one_wall / together[w]
        ours = one_wall / walls[n]
        relative = ours / ceiling
        s_code = (n / min(n, relative * n) - 1.0) / (n - 1)
        print(f"  ceiling: {n} single-thread runs at once go {ceiling:.2f}x; {n} threads reach {100 * relative:.0f} % "
              f"of it; serial fraction with the ceiling divided out {100 * s_code:.2f} % "
              f"(predicts {predicted(s_code, 16):.1f}x at 16 threads, {predicted(s_code, 64):.1f}x at 64 on cores "
              f"that scale)")
        rows.append(f"{w},{n},ceiling_processes_at_once,1,{together[w]:.4f},{ceiling:.4f},")
        rows.append(f"{w},{n},share_of_ceiling,,,{relative:.4f},")
        rows.append(f"{w},fit,serial_fraction_ceiling_divided_out,,{s_code:.5f},,")
    print()
with open(out, "w") as f:
    f.write("\n".join(rows) + "\n")
print(f"run_threads: wrote {out}", file=sys.stderr)
EOF
