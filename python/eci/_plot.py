"""SolveResult.plot: the picture `eci run MODEL --plot FILE` draws (apps/eci/run_plot.cpp), with matplotlib.

Imported on the first call of SolveResult.plot; matplotlib itself only inside plot() (importing eci imports neither).
"""

import math
import os
import sys

import numpy as np

_FORMATS = ("png", "svg", "pdf")
_MAX_COMPONENTS = 6          # the state panel's curves, as the CLI's
_MAX_PHASE_SEGMENTS = 100_000  # the phase plane's coloured segments: a longer run is drawn every k-th output


def _file_format(file):
    """The picture's format from the name's extension; ValueError (nothing written) for any other."""
    if not isinstance(file, (str, os.PathLike)):
        raise TypeError(f"file must be a path (str or os.PathLike), not {type(file).__name__}")
    name = os.fspath(file)
    ext = os.path.splitext(name)[1].lstrip(".").lower()
    if ext not in _FORMATS:
        raise ValueError(f"file {name!r}: the picture's name must end in .png, .svg or .pdf")
    return ext


def _matplotlib():
    try:
        import matplotlib  # noqa: F401
        from matplotlib.figure import Figure  # noqa: F401
    except ImportError as e:
        raise ImportError("SolveResult.plot needs matplotlib: install python3-matplotlib (Debian) or "
                          "`pip install matplotlib`") from e
    return matplotlib


def _new_figure(size):
    """A figure of pyplot's where pyplot is in use (imported, or a backend chosen by MPLBACKEND, as a notebook
    does): it then shows as every other (plt.show(), inline). Otherwise a figure of its own on the Agg canvas: no
    window, no backend chosen for the user, nothing global changed."""
    if "matplotlib.pyplot" in sys.modules or os.environ.get("MPLBACKEND"):
        import matplotlib.pyplot as plt
        return plt.figure(figsize=size, layout="constrained")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _real_columns(y):
    """The state as real columns (n_real, m): y itself, or a complex y's (re, im) of each component, interleaved
    as the CLI's columns re_psi_0, im_psi_0, ..."""
    y = np.asarray(y)
    if y.dtype.kind != "c":
        return y
    out = np.empty((2 * y.shape[0], y.shape[1]))
    out[0::2], out[1::2] = y.real, y.imag
    return out


def _column_names(model, y):
    if model is not None and list(model.component_names):
        return list(model.component_names)
    if np.asarray(y).dtype.kind == "c":
        return [f"{part} y[{i}]" for i in range(y.shape[0]) for part in ("Re", "Im")]
    return [f"y[{i}]" for i in range(y.shape[0])]


def _phase_request(phase, model):
    """(x, y, equal_axes) to draw, or None: the model's plot_plane by default; phase=False none."""
    if phase is None:
        return None if model is None else model.plot_plane
    if phase is False:
        return None
    if isinstance(phase, (str, bytes)) or not hasattr(phase, "__len__") or len(phase) not in (2, 3):
        raise ValueError(f"phase must be (x, y) or (x, y, equal_axes), each a component's index or name, or "
                         f"False, not {phase!r}")
    return (phase[0], phase[1], bool(phase[2]) if len(phase) == 3 else False)


def _phase_column(key, names, columns, model, y):
    """The column called (or indexed) key: a component of the state or a model's derived column."""
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        if not 0 <= key < len(columns):
            raise ValueError(f"phase: component {key} is not one of the {len(columns)} real components")
        return names[key], columns[key]
    if isinstance(key, str):
        if key in names:
            return key, columns[names.index(key)]
        derived = model.derived_columns(y) if model is not None else {}
        if key in derived:
            return key, np.asarray(derived[key])
        raise ValueError(f"phase: no component or derived column named {key!r} (there are: "
                         f"{', '.join(names + list(derived))})")
    raise ValueError(f"phase: {key!r} is neither a component's index nor its name")


def _relative_changes(values):
    """Each invariant's change from its initial value, relative to it, or absolute where it is 0 or not finite:
    name -> (change, relative)."""
    out = {}
    for name, v in values.items():
        v = np.asarray(v, dtype=float)
        first = v[0]
        relative = bool(math.isfinite(first) and first != 0.0)
        out[name] = ((v - first) / abs(first) if relative else v - first, relative)
    return out


def _legend_right(ax):
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small")


def plot(result, file=None, phase=None):
    """See SolveResult.plot."""
    fmt = None if file is None else _file_format(file)  # (refused before anything is drawn or written)
    _matplotlib()
    from matplotlib.collections import LineCollection

    model = getattr(result, "_model", None)
    t = np.asarray(result["t"], dtype=float)
    y = np.asarray(result["y"])
    if t.size == 0:
        raise ValueError("the result has no outputs to plot (t_eval=[])")
    style = {} if t.size > 1 else {"marker": "o"}  # (a single output: a point)
    values = result.get("invariant_values") or {}
    flow = result.get("budget_residual_values") is not None
    name = model.name if model is not None else "fun(t, y)"
    title = f"{name}: {result['method']}, {result['stats']['steps']} steps"
    if result.get("status", 0) < 0:
        title += f" (stopped at t = {t[-1]:.6g})"

    if flow:  # a spectral flow: E and Z over time, each one's budget residual per step, and the last field
        own = list(model.invariant_names if model is not None else list(values)[:2])
        # the user's invariants= (measured at every output too): their relative change in a panel of their own
        extra = {k: v for k, v in values.items() if k not in own}
        fig = _new_figure((15.0, 10.0 if extra else 7.6))
        grid = fig.add_gridspec(3 if extra else 2, 2, width_ratios=(1.2, 1.0))
        top = fig.add_subplot(grid[0, 0])
        bottom = fig.add_subplot(grid[1, 0], sharex=top)
        if extra:
            user = fig.add_subplot(grid[2, 0], sharex=top)
            changes = _relative_changes(extra)
            for inv, (change, relative) in changes.items():
                user.plot(t, change, label=inv if relative else inv + " (abs.)", **style)
            user.set_ylabel("invariants=: (value - initial)\n/ |initial|")
            user.ticklabel_format(axis="y", style="sci", scilimits=(0, 0))
            user.set_xlabel("t")
        for inv in own:
            top.plot(t, values[inv], label=inv, **style)
        top.set_yscale("log")
        top.set_ylabel("invariant")
        for inv, r in result["budget_residual_values"].items():
            bottom.plot(t, r, label=inv, marker=".", markersize=3)  # (isolated nonzero residuals seen)
        bottom.set_yscale("log", nonpositive="mask")  # (a step that kept its budget exactly: 0, not drawn)
        bottom.set_ylabel("|change - (injection - dissipation)| / invariant\n(largest per step since the last output)")
        bottom.set_xlabel("t")
        for ax in (top, bottom) + ((user,) if extra else ()):
            ax.margins(x=0)
            ax.grid(True)
            _legend_right(ax)
        # the field at the last output, as the snapshots draw it: a diverging map symmetric about 0, y upward
        field = np.asarray(model.to_physical(y[:, -1]))
        big = float(np.max(np.abs(field))) if field.size else 0.0
        image_ax = fig.add_subplot(grid[:, 1])
        image = image_ax.imshow(field, origin="lower", cmap="RdBu_r", vmin=-big, vmax=big,
                                extent=(0.0, 2.0 * math.pi, 0.0, 2.0 * math.pi), interpolation="nearest")
        image_ax.set_title(f"{model.field} at t = {t[-1]:.6g}")
        image_ax.set_xlabel("x")
        image_ax.set_ylabel("y")
        fig.colorbar(image, ax=image_ax, label=model.symbol, shrink=0.8)
        fig.suptitle(title)
    else:
        columns = _real_columns(y)
        names = _column_names(model, y)
        plane = _phase_request(phase, model)
        fig = _new_figure((12.4 if plane else 10.0, 7.6))
        grid = fig.add_gridspec(2 if values else 1, 2 if plane else 1, width_ratios=(1.3, 1.0) if plane else None)
        state = fig.add_subplot(grid[0, 0])
        shown = min(_MAX_COMPONENTS, columns.shape[0])
        for i in range(shown):
            state.plot(t, columns[i], label=names[i], **style)
        state.set_ylabel("state" if shown == columns.shape[0]
                         else f"state (first {shown} of {columns.shape[0]} components)")
        state.set_xlabel("t")
        state.margins(x=0)  # (the time axes end at the run's ends, as the CLI's)
        state.grid(True)
        _legend_right(state)
        if plane:
            xname, xv = _phase_column(plane[0], names, columns, model, y)
            yname, yv = _phase_column(plane[1], names, columns, model, y)
            ax = fig.add_subplot(grid[0, 1])
            stride = max(1, math.ceil((t.size - 1) / _MAX_PHASE_SEGMENTS))
            keep = np.r_[np.arange(0, t.size - 1, stride), t.size - 1] if t.size > 1 else np.arange(1)
            points = np.column_stack((xv[keep], yv[keep]))
            segments = np.stack((points[:-1], points[1:]), axis=1)
            lines = LineCollection(segments, cmap="viridis", linewidths=1.2)
            lines.set_array(t[keep][:-1])
            lines.set_clim(t[0], t[-1])
            ax.add_collection(lines)
            ax.plot([xv[0]], [yv[0]], "o", color="black", markersize=6, label="start", zorder=3)
            ax.update_datalim(points)
            ax.autoscale_view()
            if plane[2]:
                ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel(xname)
            ax.set_ylabel(yname)
            ax.grid(True)
            ax.legend(loc="best", fontsize="small")
            fig.colorbar(lines, ax=ax, label="t")
        if values:
            changes = _relative_changes(values)
            inv_ax = fig.add_subplot(grid[1, :])
            for inv, (change, relative) in changes.items():
                inv_ax.plot(t, change, label=inv if relative else inv + " (abs.)", **style)
            absolute = not all(rel for _, rel in changes.values())
            inv_ax.set_ylabel("(invariant - initial) / |initial|" + ("\n(abs.): invariant - initial" if absolute
                                                                      else ""))
            inv_ax.set_xlabel("t")
            inv_ax.ticklabel_format(axis="y", style="sci", scilimits=(0, 0))
            inv_ax.margins(x=0)
            inv_ax.grid(True)
            # (inside: a key outside a panel spanning both columns pushes the phase plane's colorbar away from it)
            inv_ax.legend(loc="best", fontsize="small")
        fig.suptitle(title)
    if file is not None:
        fig.savefig(file, format=fmt)
    return fig
