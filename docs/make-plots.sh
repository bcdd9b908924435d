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
backends = "exact-painter painter global-zbuffer zbuffer raycast arrangement"
plot for [b in backends] "< awk -F, -v b=".b." '$1==b && $2==\"cornell-box\"' bench-backends-patches.csv" \
       using 3:($7*1000) with linespoints lw 2 title b." (Cornell)", \
     for [b in backends] "< awk -F, -v b=".b." '$1==b && $2==\"fractal-terrain\"' bench-backends-patches.csv" \
       using 3:($7*1000) with linespoints dt 2 title b." (terrain)"
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
backends = "exact-painter painter global-zbuffer zbuffer raycast"
plot for [b in backends] "< awk -F, -v b=".b." '$1==b' bench-backends-resolution.csv" \
       using 4:($7*1000) with linespoints lw 2 title b
GP
fi

if [ -f bench-exact-patches.csv ]; then
gnuplot <<'GP'
set datafile separator ","
set terminal png size 1200,500 font ",11"
set output "bench-exact.png"
set multiplot layout 1,2 title "The exact painter against the painter and the global z-buffer (Cornell box, one thread, fastest of 7 interleaved rounds)"
set logscale xy
set ylabel "ms per direction"
set key left top
set grid
backends = "exact-painter painter global-zbuffer"
set title "vs patch count (512^2)"
set xlabel "patches"
plot for [b in backends] "< awk -F, -v b=".b." '$1==b' bench-exact-patches.csv" using 3:($7*1000) with linespoints lw 2 title b
set title "vs map resolution (3,352 patches)"
set xlabel "resolution (pixels per side)"
plot for [b in backends] "< awk -F, -v b=".b." '$1==b' bench-exact-resolution.csv" using 4:($7*1000) with linespoints lw 2 title b
unset multiplot
GP
fi

if [ -f resolution-study.csv ]; then
gnuplot <<'GP'
set datafile separator ","
set terminal pngcairo size 1000,600 font ",10"
set output "resolution-study.png"
set title "Residual error of stochastic iteration vs map resolution (Cornell box, 10,000 steps, jittered grid)"
set logscale xy
set xlabel "resolution (pixels per side)"
set ylabel "relative L1 error vs 1000^2 reference"
set key outside right
set grid
plot "< awk -F, '$3==\"yes\"' resolution-study-w-only.csv" using 1:4 with linespoints lw 2 lc 1 title "w only", \
     "< awk -F, '$3==\"yes\" && $6>1' resolution-study-w-only.csv" using 1:5 with linespoints lw 2 lc 1 dt 2 title "w only, mean of 16 streams", \
     "< awk -F, '$3==\"yes\"' resolution-study.csv" using 1:4 with linespoints lw 2 lc 2 title "w and -w (default)", \
     "< awk -F, '$3==\"yes\" && $6>1' resolution-study.csv" using 1:5 with linespoints lw 2 lc 2 dt 2 title "w and -w, mean of 16 streams", \
     "< awk -F, '$3==\"yes\"' resolution-study-diffuse-shot.csv" using 1:4 with linespoints lw 2 lc 3 title "w and -w, diffuse shot", \
     "< awk -F, '$3==\"yes\" && $6>1' resolution-study-diffuse-shot.csv" using 1:5 with linespoints lw 2 lc 3 dt 2 title "diffuse shot, mean of 16 streams", \
     "paper-table2.csv" every ::1 using 1:3 with linespoints lw 2 lc 8 dt 3 title "004 Table 2 ('<0.01' drawn at 0.01)", \
     0.01 with lines lc 0 dt 4 title "the issue's goal at 50^2"
GP
fi
ls -1 *.png

if [ -f convergence.csv ]; then
# One curve per method and sampler: colour by method, dash by sampler.
curves() {  # x column
  local x=$1 sep="" c dt
  for m in walk combined bidirectional; do
    case $m in walk) c=1 ;; combined) c=2 ;; bidirectional) c=3 ;; esac
    for s in random halton sobol; do
      case $s in random) dt=1 ;; halton) dt=2 ;; sobol) dt=4 ;; esac
      printf '%s"< awk -F, '"'"'$1==\\"%s\\" \&\& $2==\\"%s\\"'"'"' convergence.csv" using %s:5 with lines lw 2 lc %s dt %s title "%s %s"' \
        "$sep" "$m" "$s" "$x" "$c" "$dt" "$m" "$s"
      sep=", "
    done
  done
  printf ', "< awk -F, '"'"'$1==\\"bidirectional-unbiased\\"'"'"' convergence.csv" using %s:5 with lines lw 2 lc 4 title "bidirectional random --unbiased (vs 1)"' "$x"
}
gnuplot <<GP
set datafile separator ","
set terminal pngcairo size 1100,600 font ",10"
set logscale xy
set grid
set key outside right
set output "convergence-walks.png"
set title "Global walks on the homogeneous box (D = 5): error vs walks, mean of 4 seeds (cf. 004 Fig. 6)"
set xlabel "global walks (5 directions each)"
set ylabel "relative L1 error vs own exact value"
plot $(curves 3)
set output "convergence-seconds.png"
set title "Run time vs error on the homogeneous box: walks (D = 5) and stochastic iteration, mean of 4 seeds"
set xlabel "seconds"
plot $(curves 4), \
  "< awk -F, '\$1==\"iteration\"' convergence.csv" using 4:5 with lines lw 3 lc 7 title "iteration (w and -w)", \
  "< awk -F, '\$1==\"iteration-w-only\"' convergence.csv" using 4:5 with lines lw 3 lc 8 title "iteration (w only)"
GP
fi

if [ -f gather-pipeline.csv ]; then
gnuplot <<'GP'
set datafile separator ","
set terminal pngcairo size 900,600 font ",10"
set output "gather-pipeline.png"
set title "Final gather on the Cornell box (256^2): image MSE vs seconds (solve + gather)\nlabels: gather rays = direct samples per pixel"
set logscale xy
set grid
set key outside right
set xlabel "seconds (solve + final gather, 2 threads for the gather)"
set ylabel "MSE against a 20,000-step, 2,048-ray reference"
plot for [it in "250 1000 4000"] "< awk -F, -v it=".it." '$1==it && $3==\"none\"' gather-pipeline.csv" \
       using 6:7 with linespoints lw 2 dt 2 title it." steps, unfiltered", \
     for [it in "250 1000 4000"] "< awk -F, -v it=".it." '$1==it && $3==\"guided\"' gather-pipeline.csv" \
       using 6:7 with linespoints lw 2 title it." steps, guided filter"
GP
fi

if [ -f bench-importance-mean.csv ]; then
gnuplot <<'GP'
set datafile separator ","
set terminal pngcairo size 1200,900 font ",10"
set output "bench-importance.png"
set multiplot layout 2,2 title "Importance sampling of global walks (D = 3, patch image): relative L1 against a reference, mean of 6 seeds (cf. 004 Fig. 24)"
set logscale xy
set grid
set key top right
configs = "random sobol vegas metropolis_0.03 metropolis_0.1 metropolis_0.3"
do for [scene in "partition cornell-box"] {
  set title scene.": error against global directions"
  set xlabel "global directions (seed walks included)"
  set ylabel "relative L1 error"
  plot for [c in configs] sprintf("< awk -F, '$1==\"%s\" && $2==\"%s\"' bench-importance-mean.csv", scene, system("echo ".c." | tr _ ' '")) \
       using 4:6 with linespoints lw 2 title system("echo ".c." | tr _ ' '")
  set title scene.": error against seconds (2 threads)"
  set xlabel "seconds of solve"
  plot for [c in configs] sprintf("< awk -F, '$1==\"%s\" && $2==\"%s\"' bench-importance-mean.csv", scene, system("echo ".c." | tr _ ' '")) \
       using 5:6 with linespoints lw 2 title system("echo ".c." | tr _ ' '")
}
unset multiplot
GP
fi
