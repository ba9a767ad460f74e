# Work-precision figure of one problem from compare_methods.cpp's CSV: end-time error and invariant error against
# right-hand-side evaluations and CPU time. gnuplot -e "csv='compare.csv'; problem='rigid_body'; out='dir/cmp_rigid_body'"
set datafile separator ","
# The RK4 group (solid) and the Dormand-Prince 5(4) group (dashed, the same colour per family).
methods = "rk4 rrk-rk4 idt-rk4 mrrk-rk4 projected-rk4 stormer-verlet sb3a odeint-sb3a c-rk4 transformed-rk4 ".\
          "dp54 rrk-dp54 mrrk-dp54 projected-dp54 c-dp54 transformed-dp54"
colors = "#888888 #1f77b4 #17becf #9467bd #2ca02c #bcbd22 #8c564b #000000 #d62728 #d62728 ".\
         "#888888 #1f77b4 #9467bd #2ca02c #d62728 #d62728"
points = "1 4 12 6 8 3 5 2 7 7 1 4 6 8 7 7"
dashes = "1 1 1 1 1 1 1 1 1 1 2 2 2 2 2 2"
floor = 1e-17  # invariant errors of exactly 0 (or below) are drawn here
rows(m) = sprintf("< grep '^%s,%s,' '%s'", problem, m, csv)  # one method's rows: lines join its points
clip(v) = v < floor ? floor : v
set logscale xy
set format x "10^{%T}"
set format y "10^{%T}"
set grid
set key bottom left font ",9" spacing 0.9
set tics font ",10"

do for [term in "pngcairo svg"] {
  if (term eq "pngcairo") { set terminal pngcairo size 1400,1000 enhanced font "Sans,11"; set output out.".png" }
  else { set terminal svg size 1400,1000 enhanced font "Sans,11"; set output out.".svg" }
  set multiplot layout 2,2 title "Keeping invariants, ".problem.": work against precision (steps doubling)" noenhanced
  do for [panel = 1:4] {
    xcol = (panel == 1 || panel == 3) ? 6 : 11
    ycol = panel <= 2 ? 10 : 9
    set xlabel (xcol == 6 ? "right-hand-side evaluations" : "CPU time per run [s]")
    set ylabel (ycol == 10 ? "relative error at t_{end}" : sprintf("largest relative invariant change (< %.0e drawn at it)", floor))
    if (panel == 1) { set key bottom left } else { unset key }
    plot for [i = 1:words(methods)] rows(word(methods, i)) using xcol:(clip(column(ycol))) \
         with linespoints lw 1.5 dt int(word(dashes, i)) pt int(word(points, i)) ps 0.8 lc rgb word(colors, i) \
         title word(methods, i) noenhanced
  }
  unset multiplot
  unset output
}
