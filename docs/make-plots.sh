#!/usr/bin/env bash
# Draws the PNG figures in docs/ from the CSV files the benchmarks wrote. Needs
# gnuplot (Debian's gnuplot-nox; installed here if missing: a docs-only dependency).
set -euo pipefail
cd "$(dirname "$0")"
if ! command -v gnuplot >/dev/null; then
  sudo_cmd=(); [ "$(id -u)" -ne 0 ] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get install -y -qq gnuplot-nox
fi

if [ -f bench-backends-patches.csv ]; then
gnuplot <<'GP'
set datafile separator ","
set terminal png size 900,600 font ",11"
set output "bench-backends-patches.png"
set title "Seconds per global direction vs patch count (512^2 map; arrangement: exact)"
set logscale xy
set xlabel "patches"
set ylabel "ms per direction"
set key left top
set grid
backends = "painter global-zbuffer zbuffer raycast arrangement"
plot for [b in backends] "< awk -F, -v b=".b." '$1==b && $2==\"cornell-box\"' bench-backends-patches.csv" \
       using 3:($6*1000) with linespoints lw 2 title b." (Cornell)", \
     for [b in backends] "< awk -F, -v b=".b." '$1==b && $2==\"fractal-terrain\"' bench-backends-patches.csv" \
       using 3:($6*1000) with linespoints dt 2 title b." (terrain)"
GP
fi

if [ -f bench-backends-resolution.csv ]; then
gnuplot <<'GP'
set datafile separator ","
set terminal png size 900,600 font ",11"
set output "bench-backends-resolution.png"
set title "Seconds per global direction vs map resolution (Cornell box)"
set logscale xy
set xlabel "resolution (pixels per side)"
set ylabel "ms per direction"
set key left top
set grid
backends = "painter global-zbuffer zbuffer raycast"
plot for [b in backends] "< awk -F, -v b=".b." '$1==b' bench-backends-resolution.csv" \
       using 4:($6*1000) with linespoints lw 2 title b
GP
fi

if [ -f resolution-study.csv ]; then
gnuplot <<'GP'
set datafile separator ","
set terminal png size 900,600 font ",11"
set output "resolution-study.png"
set title "Residual error of stochastic iteration vs map resolution (Cornell box, 10,000 steps)"
set logscale xy
set xlabel "resolution (pixels per side)"
set ylabel "relative L1 error vs 1000^2 reference"
set key right top
set grid
plot "< awk -F, '$3==\"no\"' resolution-study.csv" using 1:4 with linespoints lw 2 title "fixed grid", \
     "< awk -F, '$3==\"yes\"' resolution-study.csv" using 1:4 with linespoints lw 2 title "jittered grid", \
     "< awk -F, '$3==\"yes\" && $6>1' resolution-study.csv" using 1:5 with linespoints lw 2 title "jittered, mean of 16 jitter streams", \
     "paper-table2.csv" every ::1 using 1:3 with linespoints lw 2 dt 2 title "004 Table 2 (upper bounds '<0.01' drawn at 0.01)"
GP
fi
ls -1 *.png
