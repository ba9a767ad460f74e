# Long-run drift figure from drift.cpp's CSV: ensemble-RMS relative energy and enstrophy error against step count
# on the three-wave model (dt = 0.01), with eps*sqrt(n) as a guide. gnuplot -e "csv='drift.csv'; out='dir/drift'"
set datafile separator ","
methods = "pc rk4 c_pc c_rk4 c_pc_compensated"
labels = "PC RK4 C-PC C-RK4 C-PC-compensated"
colors = "#1f77b4 #2ca02c #d62728 #ff7f0e #9467bd"
points = "4 6 5 7 9"
eps = 2.220446049250313e-16
floor = 1e-18
pick(col, m) = strcol(1) eq m ? column(col) : NaN
clip(v) = v < floor ? floor : v
set logscale xy
set format x "10^{%T}"
set format y "10^{%T}"
set grid
set tics font ",10"
set xlabel "steps (dt = 0.01)"
set yrange [1e-18:10]

do for [term in "pngcairo svg"] {
  if (term eq "pngcairo") { set terminal pngcairo size 1400,560 enhanced font "Sans,11"; set output out.".png" }
  else { set terminal svg size 1400,560 enhanced font "Sans,11"; set output out.".svg" }
  set multiplot layout 1,2 title "Three-wave invariant drift, RMS over an ensemble of initial conditions (< 1e-18 drawn at it)"
  do for [panel = 1:2] {
    col = panel + 2
    set ylabel (panel == 1 ? "relative energy error" : "relative enstrophy error")
    if (panel == 1) { set key top left font ",9" } else { unset key }
    plot for [i = 1:words(methods)] csv using (pick(2, word(methods, i))):(clip(pick(col, word(methods, i)))) \
           with linespoints lw 1.5 pt int(word(points, i)) ps 0.7 lc rgb word(colors, i) title word(labels, i), \
         [1:*] eps * sqrt(x) with lines dt 2 lc rgb "#444444" title "{/Symbol e} n^{1/2}"
  }
  unset multiplot
  unset output
}
