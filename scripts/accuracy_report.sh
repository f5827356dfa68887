#!/bin/sh
# Issue 3's accuracy report: runs bench/report_accuracy, then draws its two plots with gnuplot.
# Writes docs/accuracy.md and docs/accuracy-*.png; raw results stay in the build directory.
# Usage: scripts/accuracy_report.sh [report binary] [output dir]   (ACCURACY_REPORT_SIZE=quick
# for a smoke run on small scenes; its figures are not the ones to commit. TRIOCT_ACC_ORACLE=N
# checks the first N rays and N/5 triangle queries of each scene against the GMP oracle,
# instead of 4000 and 800; 0 skips the oracle.)
set -eu

BIN=${1:-build/bench/report_accuracy}
OUT=${2:-build/accuracy}
SIZE=${ACCURACY_REPORT_SIZE:-full}
DOCS=${ACCURACY_REPORT_DOCS:-docs}

mkdir -p "$OUT" "$DOCS"
"$BIN" "$OUT" "$DOCS/accuracy.md" "$SIZE" "$(date -u +%Y-%m-%d)"

# pngcairo draws anti-aliased text; the libgd png terminal is the fallback.
if gnuplot -e "set terminal" 2>/dev/null | grep -q pngcairo; then
    TERM_LINE="set terminal pngcairo size 1400,620 font 'Sans,11'"
    TERM_LINE_TALL="set terminal pngcairo size 1400,900 font 'Sans,11'"
else
    TERM_LINE="set terminal png size 1400,620"
    TERM_LINE_TALL="set terminal png size 1400,900"
fi

gnuplot <<EOF
$TERM_LINE
set output '$DOCS/accuracy-time-vs-error.png'
set datafile separator tab
set multiplot layout 1,2 title "Time per query against error rate (fully swept scenes; time = geometric mean over scenes; reference = exact mode at f = 1)" font ',13'
set logscale x
set xrange [5e-7:1.5]
set format x '10^{%L}'
set xtics add ('0' 1e-6)
set xlabel 'disagreements with exact mode at f = 1 / queries  (0 drawn at 10^{-6})'
set grid
set style line 1 lc rgb '#1f77b4' lw 2 pt 7 ps 1.2
set style line 2 lc rgb '#d62728' lw 2 pt 5 ps 1.2
set style line 3 lc rgb '#2ca02c' lw 2 pt 9 ps 1.4
set key outside below center horizontal maxcols 3
# Exact and fast are traced thin over the resolution factors (the second plot unpacks them);
# the large marker is the heuristic resolution f = 1, where the seed points also sit.
set logscale y
set title 'closest-hit ray'
set ylabel 'microseconds per ray (log scale)'
plot '$OUT/plot_tradeoff.tsv' index 0 using 3:2 with linespoints ls 1 lw 1 ps 0.7 title 'exact, f = 1/4 ... 4', \
     '' index 0 every ::2::2 using 3:2 with points ls 1 ps 2.5 title 'exact, f = 1', \
     '' index 1 using 3:2 with linespoints ls 2 lw 1 ps 0.7 title 'fast, f = 1/4 ... 4', \
     '' index 1 every ::2::2 using 3:2 with points ls 2 ps 2.5 title 'fast, f = 1', \
     '' index 2 using 3:2 with lines ls 3 title 'seed at f = 1, over epsilon', \
     '' index 2 every ::0::0 using 3:2 with points lc rgb '#2ca02c' pt 8 ps 2 title 'seed 1e-12', \
     '' index 2 every ::1::1 using 3:2 with points lc rgb '#2ca02c' pt 10 ps 2 title 'seed 1e-9', \
     '' index 2 every ::2::2 using 3:2 with points lc rgb '#2ca02c' pt 12 ps 2 title 'seed 1e-6', \
     '' index 2 every ::3::3 using 3:2 with points lc rgb '#2ca02c' pt 14 ps 2 title 'seed 1e-3'
set title 'triangle query, all ids'
set ylabel 'microseconds per triangle query (log scale)'
plot '$OUT/plot_tradeoff.tsv' index 0 using 5:4 with linespoints ls 1 lw 1 ps 0.7 title 'exact, f = 1/4 ... 4', \
     '' index 0 every ::2::2 using 5:4 with points ls 1 ps 2.5 title 'exact, f = 1', \
     '' index 1 using 5:4 with linespoints ls 2 lw 1 ps 0.7 title 'fast, f = 1/4 ... 4', \
     '' index 1 every ::2::2 using 5:4 with points ls 2 ps 2.5 title 'fast, f = 1', \
     '' index 2 using 5:4 with lines ls 3 title 'seed at f = 1, over epsilon', \
     '' index 2 every ::0::0 using 5:4 with points lc rgb '#2ca02c' pt 8 ps 2 title 'seed 1e-12', \
     '' index 2 every ::1::1 using 5:4 with points lc rgb '#2ca02c' pt 10 ps 2 title 'seed 1e-9', \
     '' index 2 every ::2::2 using 5:4 with points lc rgb '#2ca02c' pt 12 ps 2 title 'seed 1e-6', \
     '' index 2 every ::3::3 using 5:4 with points lc rgb '#2ca02c' pt 14 ps 2 title 'seed 1e-3'
unset multiplot

$TERM_LINE_TALL
set output '$DOCS/accuracy-resolution.png'
set datafile separator tab
unset logscale
unset format
set multiplot layout 2,2 title "Cost against resolution: leaf side = f x heuristic d (fully swept scenes; query times = geometric mean over scenes)" font ',13'
set logscale x 2
set xrange [0.2:5]
set xtics ('1/4' 0.25, '1/2' 0.5, '1' 1, '2' 2, '4' 4)
set xlabel 'resolution factor f'
set grid
set key inside top left box opaque
set style line 1 lc rgb '#1f77b4' lw 2 pt 7 ps 1.2
set style line 2 lc rgb '#d62728' lw 2 pt 5 ps 1.2
set style line 3 lc rgb '#2ca02c' lw 2 pt 9 ps 1.4
set yrange [0:*]
set title 'closest-hit ray'
set ylabel 'microseconds per ray'
plot '$OUT/plot_resolution.tsv' index 0 using 1:2 with linespoints ls 1 title 'exact', \
     '' index 1 using 1:2 with linespoints ls 2 title 'fast', \
     '' index 2 using 1:2 with linespoints ls 3 title 'seed 1e-9'
set title 'triangle query, all ids'
set ylabel 'microseconds per triangle query'
plot '$OUT/plot_resolution.tsv' index 0 using 1:3 with linespoints ls 1 title 'exact', \
     '' index 1 using 1:3 with linespoints ls 2 title 'fast', \
     '' index 2 using 1:3 with linespoints ls 3 title 'seed 1e-9'
set key top right box opaque
set title 'memory (octree\\_info.bytes\\_total)'
set ylabel 'bytes per triangle'
plot '$OUT/plot_resolution.tsv' index 0 using 1:4 with linespoints ls 1 title 'exact', \
     '' index 1 using 1:4 with linespoints ls 2 title 'fast', \
     '' index 2 using 1:4 with linespoints ls 3 title 'seed 1e-9'
set title 'build time'
set logscale y
set yrange [*:*]
set ylabel 'microseconds per triangle (log scale)'
plot '$OUT/plot_resolution.tsv' index 0 using 1:5 with linespoints ls 1 title 'exact', \
     '' index 1 using 1:5 with linespoints ls 2 title 'fast', \
     '' index 2 using 1:5 with linespoints ls 3 title 'seed 1e-9'
unset multiplot
EOF
echo "accuracy report: wrote $DOCS/accuracy.md, $DOCS/accuracy-time-vs-error.png, $DOCS/accuracy-resolution.png"
