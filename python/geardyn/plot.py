"""Figures for notebooks, with matplotlib: a run (one-degree, or a gear train: a coupled case's
too) and its phase portraits, a frequency response, a branch of orbits."""
import numpy as np


def run(r, ax=None, title=None):
    """delta / b and F / (b k_m) over time, stacked as in the paper's Figs. 4-6.

    Separation and back-side contact are shaded where they occur (and in the legend only
    then); the backlash band -1 <= delta / b <= 1 is drawn in a neutral grey. A train's run
    (`TrainRunResult`, a coupled case's too) is drawn by `train_run`.

    Parameters
    ----------
    r : RunResult or TrainRunResult
    ax : pair of matplotlib Axes, optional
        Drawn into; new ones when None.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if hasattr(r, "meshes"):
        return train_run(r, title=title)

    if ax is None:
        fig, ax = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
    else:
        fig = ax[0].figure
    t_ms = r.t * 1e3
    separated = r.contact == 0
    back = r.contact == -1
    for a, y, label in ((ax[0], r.delta_bar, "delta / b"), (ax[1], r.force_bar, "F / (b k_m)")):
        if separated.any():
            a.fill_between(t_ms, 0, 1, where=separated, transform=a.get_xaxis_transform(),
                           color="#f4a6a6", alpha=0.6, linewidth=0, label="separated")
        if back.any():
            a.fill_between(t_ms, 0, 1, where=back, transform=a.get_xaxis_transform(),
                           color="#9cc3f0", alpha=0.6, linewidth=0, label="back side")
        a.plot(t_ms, y, color="#1f3b73", linewidth=0.9)
        a.set_ylabel(label)
        a.grid(color="#dddddd")
    ax[0].axhspan(-1, 1, color="#f0f0f0", zorder=0)
    for edge in (-1, 1):
        ax[0].axhline(edge, color="gray", linestyle="--", linewidth=0.8)
    # The limits follow the data, not the shading and the band.
    for a, y in ((ax[0], r.delta_bar), (ax[1], r.force_bar)):
        pad = 0.08 * (y.max() - y.min()) + 1e-12
        a.set_ylim(y.min() - pad, y.max() + pad)
    ax[1].set_xlabel("t (ms)")
    if separated.any() or back.any():
        ax[0].legend(loc="upper right", fontsize=8)
    if title:
        ax[0].set_title(title)
    fig.tight_layout()
    return fig


def _panel_stack(rows, height):
    """A figure of `rows` panels over a shared time axis, each `height` inches: (fig, axes)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(rows, 1, sharex=True, figsize=(9, height * rows), squeeze=False)
    return fig, [row[0] for row in ax]


def _finish_stack(fig, axes, title):
    """Each panel's grid and legend, the time label under the last, the title over all."""
    for a in axes:
        a.grid(color="#dddddd")
        a.legend(loc="upper left", fontsize=8)
    axes[-1].set_xlabel("t (ms)")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def train_run(r, title=None):
    """A gear train's run, one panel per mesh, as `geardyn run --plot` draws it: the mesh's
    (d - e) / b (separation shaded where it occurs, the contact edges dashed) and its force in
    N on a second axis; then, when the train has shafts or bearings, one panel of each shaft's
    torque (N m, solid) and each bearing's radial force |F| (N, dashed; on a second axis beside
    shafts); and, when bodies move along their axis (dof "axial" or "spatial"), one panel of
    their bearings' axial forces (N).

    Parameters
    ----------
    r : TrainRunResult
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    t_ms = r.t * 1e3
    parts = bool(r.shafts or r.bearings)
    axial = [q for q, b in enumerate(r.summary["bearings"]) if "max_axial_force_n" in b]
    fig, ax = _panel_stack(len(r.meshes) + parts + bool(axial), 2.4)
    for m, (name, reading) in enumerate(zip(r.meshes, r.summary["meshes"])):
        a = ax[m]
        separated = r.contact[:, m] == 0
        if separated.any():
            a.fill_between(t_ms, 0, 1, where=separated, transform=a.get_xaxis_transform(),
                           color="#f4a6a6", alpha=0.6, linewidth=0, label="separated")
        a.plot(t_ms, r.deflection_bar[:, m], color="#1f4e9c", linewidth=0.9, label="(d - e) / b")
        a.axhline(1, color="gray", linestyle="--", linewidth=0.8)
        if separated.any() or reading["double_sided"]:
            a.axhline(-1, color="gray", linestyle="--", linewidth=0.8)
        a.set_ylabel("(d - e) / b")
        f = a.twinx()
        f.plot(t_ms, r.force[:, m], color="gray", linewidth=0.7, label="force (N)")
        f.set_ylabel("force (N)")
        a.set_title(f"mesh {name} ({reading['mesh_frequency_hz']:.6g} Hz): {reading['regime']}, "
                    f"{reading['impacts']} impacts", fontsize=9)
    colours = ["#1f4e9c", "#c0392b", "#2e8b57", "#8e44ad", "#d35400", "#16a085"]
    if parts:
        a = ax[len(r.meshes)]
        for q, name in enumerate(r.shafts):
            a.plot(t_ms, r.shaft_torque[:, q], color=colours[q % 6], linewidth=1.0,
                   label=f"shaft {name} (N m)")
        b = a.twinx() if r.shafts and r.bearings else a
        for q, name in enumerate(r.bearings):
            style = {"color": colours[(len(r.shafts) + q) % 6], "linestyle": "--",
                     "linewidth": 1.0}
            b.plot(t_ms, np.hypot(r.bearing_force[:, q, 0], r.bearing_force[:, q, 1]), **style)
            a.plot([], [], label=f"bearing {name} |F| (N)", **style)  # in the panel's legend
        a.set_ylabel("shaft torque (N m)" if r.shafts else "bearing force (N)")
        if b is not a:
            b.set_ylabel("bearing force (N)")
        a.set_title("shafts and bearings" if r.shafts and r.bearings
                    else "shafts" if r.shafts else "bearings", fontsize=9)
    if axial:
        a = ax[-1]
        for q in axial:
            a.plot(t_ms, r.bearing_axial[:, q, 0], color=colours[(len(r.shafts) + q) % 6],
                   linewidth=1.0, label=f"bearing {r.bearings[q]} axial (N)")
        a.set_ylabel("axial force (N)")
        a.set_title("axial bearing forces", fontsize=9)
    return _finish_stack(fig, ax, title)


def phase(r, title=None):
    """Phase portraits, as `geardyn run --plot` draws them (run_phase, train_phase): delta / b
    against delta' for a one-degree run, and for a train's run one panel per mesh, its
    (d - e) / b against d' - e' (m/s); the whole run light grey, the part from where the
    summary's steady part starts in colour, the contact edges at +-1 dashed.

    Parameters
    ----------
    r : RunResult or TrainRunResult
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if hasattr(r, "meshes"):
        panels = [(f"mesh {name}", r.deflection_bar[:, m], r.deflection_rate[:, m])
                  for m, name in enumerate(r.meshes)]
        labels = ("(d - e) / b", "d' - e' (m/s)")
    else:
        from .data import _nondimensional
        panels = [(None, r.delta_bar, r.velocity)]
        labels = ("delta / b", "d delta / d tau (b omega_n)" if _nondimensional(r.case_toml)
                  else "delta' (m/s)")
    steady = r.t >= r.summary["steady"]["from_s"]
    columns = min(len(panels), 3)
    rows = -(-len(panels) // columns)
    fig, ax = plt.subplots(rows, columns, figsize=(4.5 * columns, 4 * rows), squeeze=False)
    colours = ["#1f4e9c", "#c0392b", "#2e8b57", "#8e44ad", "#d35400", "#16a085"]
    for k, (name, x, v) in enumerate(panels):
        a = ax[k // columns][k % columns]
        a.plot(x, v, color="#c8c8c8", linewidth=0.7, label="whole run")
        a.plot(x[steady], v[steady], color=colours[k % 6], linewidth=0.9, label="steady part")
        for edge in (-1, 1):
            a.axvline(edge, color="gray", linestyle="--", linewidth=0.8)
        # The limits follow the data, not the contact edges.
        pad = 0.05 * (x.max() - x.min()) + 1e-12
        a.set_xlim(x.min() - pad, x.max() + pad)
        a.set_xlabel(labels[0])
        a.set_ylabel(labels[1])
        a.grid(color="#dddddd")
        a.legend(loc="upper right", fontsize=8)
        if name:
            a.set_title(name, fontsize=9)
    for k in range(len(panels), rows * columns):
        ax[k // columns][k % columns].set_visible(False)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def load_sharing(r, title=None):
    """A planetary set's load sharing over a run, as `geardyn run --plot` draws it: one panel
    per load-sharing group (a sun's planets, a ring's), each planet's mesh force in N and the
    group's factor n max F / sum F at each sample on a second axis (its static value dashed;
    no value where the forces sum to 0 or less).

    Parameters
    ----------
    r : TrainRunResult
        a run of a train with load-sharing groups (its summary's "load_sharing").
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import numpy as np

    groups = r.summary.get("load_sharing", [])
    if not groups:
        raise ValueError("this run has no load-sharing group: no gear drives or is driven by "
                         "two or more meshes")
    t_ms = r.t * 1e3
    colours = ["#1f4e9c", "#c0392b", "#2e8b57", "#8e44ad", "#d35400", "#16a085"]
    fig, ax = _panel_stack(len(groups), 2.8)
    for g, group in enumerate(groups):
        a = ax[g]
        forces = np.column_stack([r.force[:, r.meshes.index(m)] for m in group["meshes"]])
        for k, name in enumerate(group["meshes"]):
            a.plot(t_ms, forces[:, k], color=colours[k % len(colours)], linewidth=0.9,
                   label=name)
        a.set_ylabel("mesh force (N)")
        total = forces.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            factor = np.where(total > 0, len(group["meshes"]) * forces.max(axis=1) / total,
                              np.nan)
        f = a.twinx()
        f.plot(t_ms, factor, color="black", linewidth=1.2, label="factor")
        if group["static_factor"] is not None:
            f.axhline(group["static_factor"], color="gray", linestyle="--", linewidth=0.8,
                      label="at rest")
        f.set_ylabel("load-sharing factor")
        worst = group["factor"] if group["factor"] is not None else group["factor_with_startup"]
        lost = f", lost contact: {' '.join(group['lost_contact'])}" if group["lost_contact"] else ""
        a.set_title(f"gear {group['gear']}: {len(group['meshes'])} meshes"
                    + (f", factor up to {worst:.4g}" if worst is not None else "") + lost,
                    fontsize=9)
        f.legend(loc="upper right", fontsize=8)
    return _finish_stack(fig, ax, title)


def frequency_response(s, param="parameter", ax=None, column="rms_force_bar"):
    """A sweep's response against the swept key, the up and down sweeps overlaid.

    Parameters
    ----------
    s : SweepResult
        What `geardyn.sweep` returned.
    param : str
        The x-axis label (the key and its unit).
    ax : matplotlib Axes, optional
    column : str
        The statistic plotted (a key of `s`, e.g. ``"pp_delta_bar"``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(9, 4.5))
    else:
        fig = ax.figure
    direction = np.asarray(s["direction"])
    for d, style in (("up", dict(color="#1f3b73", marker=".", label="up")),
                     ("down", dict(color="#b5532b", marker="o", fillstyle="none", label="down"))):
        mask = direction == d
        if mask.any():
            ax.plot(s["value"][mask], s[column][mask], linewidth=1, markersize=4, **style)
    ax.set_xlabel(param)
    ax.set_ylabel(column)
    ax.grid(color="#dddddd")
    ax.legend()
    fig.tight_layout()
    return fig


def branch(b, param="parameter", ax=None):
    """A continuation's branch: x_a against the key, stable parts solid, unstable dashed.

    Each period-doubled branch has its own colour and the bifurcations are marked; only what
    occurred is in the legend.

    Parameters
    ----------
    b : dict
        What `geardyn.continuation` returned.
    param : str
        The x-axis label.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    if ax is None:
        fig, ax = plt.subplots(figsize=(9, 5))
    else:
        fig = ax.figure
    p, x, stable, br = b["param"], b["x_a"], b["stable"] == 1, b["branch"].astype(int)
    titled = set()
    for k in np.unique(br):
        colour = "#1f3b73" if k == 0 else "#4a8f3c"
        for s, style, label in ((True, "-", "stable"), (False, "--", "unstable")):
            on = (br == k) & (stable == s)
            if not on.any():
                continue
            y = np.where(on, x, np.nan)
            ax.plot(p, y, style, color=colour, linewidth=1.6,
                    label=None if label in titled else label)
            titled.add(label)
    markers = {"fold": "s", "branch_point": "D", "period_doubling": "^", "neimark_sacker": "*",
               "grazing": "o"}
    for kind, marker in markers.items():
        at = [(f["param"], f["x_a"]) for f in b["bifurcations"] if f["type"] == kind]
        if at:
            ax.plot(*zip(*at), marker, color="black", linestyle="none", label=kind)
    ax.set_xlabel(param)
    ax.set_ylabel("x_a = (max - min)/2 of delta / b")
    ax.grid(color="#dddddd")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
