# Work-precision figure of one model from work_precision.cpp's CSV: error at the end time and invariant error
# against right-hand-side evaluations and CPU time. gnuplot -e "csv='wp.csv'; model='three_wave'; out='dir/wp_three_wave'"
set datafile separator ","
methods = "euler pc c_pc rk4 c_rk4 implicit_midpoint dopri5 dopri5_dense"
labels = "Euler PC C-PC RK4 C-RK4 implicit-midpoint odeint-dopri5 odeint-dopri5-dense"
colors = "#888888 #1f77b4 #d62728 #2ca02c #ff7f0e #9467bd #000000 #8c564b"
points = "1 4 5 6 7 8 2 3"
floor = 1e-17  # invariant errors of exactly 0 (or below) are drawn here
pick(col, m) = (strcol(1) eq model && strcol(2) eq m) ? column(col) : NaN
clip(v) = v < floor ? floor : v
title_of(m) = m eq "three_wave" ? "three-wave model" : m eq "lotka_volterra" ? "Lotka-Volterra model" : m eq "kepler" ? "Kepler problem" : m
set logscale xy
set format x "10^{%T}"
set format y "10^{%T}"
set grid
set key bottom left font ",9" spacing 0.9
set tics font ",10"

do for [term in "pngcairo svg"] {
  if (term eq "pngcairo") { set terminal pngcairo size 1400,1000 enhanced font "Sans,11"; set output out.".png" }
  else { set terminal svg size 1400,1000 enhanced font "Sans,11"; set output out.".svg" }
  set multiplot layout 2,2 title "Work-precision, ".title_of(model)." (error at t_{end} against the exact/reference solution)"
  do for [panel = 1:4] {
    xcol = (panel == 1 || panel == 3) ? 4 : 5
    ycol = panel <= 2 ? 6 : 7
    set xlabel (xcol == 4 ? "right-hand-side evaluations" : "CPU time per run [s]")
    set ylabel (ycol == 6 ? "relative state error at t_{end}" : sprintf("relative invariant error at t_{end} (< %.0e drawn at it)", floor))
    if (panel == 1) { set key bottom left } else { unset key }
    plot for [i = 1:words(methods)] csv using (pick(xcol, word(methods, i))):(clip(pick(ycol, word(methods, i)))) \
         with linespoints lw 1.5 pt int(word(points, i)) ps 0.8 lc rgb word(colors, i) title word(labels, i)
  }
  unset multiplot
  unset output
}
