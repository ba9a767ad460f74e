# Work-precision figure of one model from adaptive.cpp's CSV: eci's adaptive pairs against odeint's,
# error at t_end and invariant error against RHS evaluations and CPU time. gnuplot -e "csv='adaptive.csv'; model='rigid_body'; out='dir/adaptive_rigid_body'"
set datafile separator ","
methods = "c-dp54 dp54 c-f78 dopri5 dopri5_dense fehlberg78"
labels = "eci-c-dp54 eci-dp54 eci-c-f78 odeint-dopri5 odeint-dopri5-dense odeint-fehlberg78"
colors = "#d62728 #1f77b4 #ff7f0e #000000 #8c564b #2ca02c"
points = "7 6 5 2 3 4"
floor = 1e-17  # invariant errors of exactly 0 (or below) are drawn here
pick(col, m) = (strcol(1) eq model && strcol(2) eq m) ? column(col) : NaN
clip(v) = v < floor ? floor : v
title_of(m) = m eq "three_wave" ? "three-wave model, t = 100" : m eq "lotka_volterra" ? "Lotka-Volterra, t = 100" : \
              m eq "kepler_e0.9" ? "Kepler e = 0.9, 100 orbits" : m eq "rigid_body" ? "rigid body near its unstable axis, t = 100" : \
              m eq "n_wave30" ? "random real n-wave, 30 modes, t = 20" : m
set logscale xy
set format x "10^{%T}"
set format y "10^{%T}"
set grid
set key bottom left font ",9" spacing 0.9
set tics font ",10"

do for [term in "pngcairo svg"] {
  if (term eq "pngcairo") { set terminal pngcairo size 1400,1000 enhanced font "Sans,11"; set output out.".png" }
  else { set terminal svg size 1400,1000 enhanced font "Sans,11"; set output out.".svg" }
  set multiplot layout 2,2 title "Adaptive work-precision, ".title_of(model)." (rtol = atol = 10^{-3}..10^{-12})"
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
