"""A picture of a diagram: blocks as boxes, the forward path left to right, one colour per rate.

:func:`draw_diagram` lays a built system out with Graphviz's ``dot`` where it is
installed, else in dependency layers; :func:`write_picture` is ``hybridsim draw``.
Importing this module lets Jupyter show a :class:`~hybridsim.engine.diagram.Diagram`
as its picture (it sets ``Diagram.to_svg``); matplotlib is imported only to draw.
"""
from pathlib import Path

from hybridsim.engine.diagram import DefaultValue, Diagram
from hybridsim.report.figures import literal, pyplot

BOX_W, BOX_H = 2.0, 0.9  # a block's box in the picture's units (inches for Graphviz)


def _dot_layout(nodes, edges, back):
    """Positions and edge paths from Graphviz's ``dot``, or None where it is not installed.

    ``edges`` are (a, b) node indices; the ``back`` ones (feedback: against the
    evaluation order) are given to dot reversed with ``dir=back``, so that the
    forward path is ranked left to right and feedback is routed around it.
    Returns ``(pos, paths)``: node -> (x, y) and edge -> [(x, y), ...] cubic
    Bezier control points from the source block to the destination block.
    """
    import shutil
    import subprocess

    dot = shutil.which("dot")
    if dot is None:
        return None
    lines = ["digraph G {", "rankdir=LR; nodesep=0.35; ranksep=0.7; splines=spline;",
             f'node [shape=box, fixedsize=true, width={BOX_W}, height={BOX_H}];']
    lines += [f'n{v};' for v in range(len(nodes))]
    for (a, b) in edges:
        lines.append(f"n{b} -> n{a} [dir=back];" if (a, b) in back else f"n{a} -> n{b};")
    lines.append("}")
    try:
        out = subprocess.run([dot, "-Tplain"], input="\n".join(lines), capture_output=True, text=True,
                             timeout=30, check=True).stdout
    except (OSError, subprocess.SubprocessError):
        return None  # a broken Graphviz falls back to the layered layout
    pos, paths = {}, {}
    for line in out.splitlines():
        f = line.split()
        if f and f[0] == "node":
            pos[int(f[1][1:])] = (float(f[2]), float(f[3]))
        elif f and f[0] == "edge":
            t, h, n = int(f[1][1:]), int(f[2][1:]), int(f[3])
            pts = [(float(f[4 + 2 * k]), float(f[5 + 2 * k])) for k in range(n)]
            paths[(h, t) if (h, t) in back else (t, h)] = pts[::-1] if (h, t) in back else pts
    if len(pos) != len(nodes):
        return None
    return pos, paths


def _layered_layout(n, first, edges, back):
    """Positions by dependency layer (the fallback without Graphviz) and feedback wires in lanes under the boxes.

    Returns ``(pos, paths, cols)``: node -> (x, y), feedback edge -> polyline, layer -> its nodes.
    """
    order = sorted(range(n), key=first.__getitem__)
    layer = [0] * n  # longest forward path from a source (edges against the order are feedback)
    for v in order:
        for (a, b) in edges:
            if b == v and first[a] < first[v]:
                layer[v] = max(layer[v], layer[a] + 1)
    cols = {}
    for v in order:
        cols.setdefault(layer[v], []).append(v)
    pos = {v: (lx * 3.0, -j * 1.4) for lx, vs in cols.items() for j, v in enumerate(vs)}
    bottom = min((y for _, y in pos.values()), default=0.0) - BOX_H
    paths = {}
    for k, (a, b) in enumerate(sorted(back)):  # feedback: down to a lane of its own, under every box
        (x0, y0), (x1, y1) = pos[a], pos[b]
        lane, out, into = bottom - 0.25 * k, x0 + BOX_W / 2 + 0.15 + 0.05 * k, x1 - BOX_W / 2 - 0.15 - 0.05 * k
        paths[(a, b)] = [(x0 + BOX_W / 2, y0), (out, y0), (out, lane), (into, lane), (into, y1),
                         (x1 - BOX_W / 2, y1)]
    return pos, paths, cols


def draw_diagram(system, title=None, expand=False):
    """Picture of a built system: the forward path left to right, feedback routed around it.

    Laid out by Graphviz's ``dot`` where it is installed (as Drake's diagrams
    are), else in dependency layers; one colour per rate.

    Parameters
    ----------
    system : hybridsim.engine.system.System
        A built system.
    title : str, optional
        The figure's title (default the system's name).
    expand : bool
        Draw every block of a subsystem (``ctrl.pid``, ...); by default a
        subsystem is one box named after it.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.patches import FancyBboxPatch

    plt = pyplot()

    keep = [i for i, b in enumerate(system.blocks) if not isinstance(b, DefaultValue)]
    key = (lambda name: name) if expand else (lambda name: name.split(".")[0])
    nodes, members = [], {}
    for i in keep:
        k = key(system.blocks[i].name)
        if k not in members:
            nodes.append(k)
            members[k] = []
        members[k].append(i)
    node_of = {i: nodes.index(key(system.blocks[i].name)) for i in keep}
    first = [min(members[k]) for k in nodes]  # evaluation order of a node: its first block's
    edges = sorted({(node_of[a], node_of[i]) for i in keep for (a, _) in system.sources[i]
                    if a in node_of and node_of[a] != node_of[i]})
    back = {(a, b) for (a, b) in edges if first[b] <= first[a]}
    laid = _dot_layout(nodes, edges, back)
    if laid is not None:
        pos, paths = laid
    else:
        pos, paths, cols = _layered_layout(len(nodes), first, edges, back)
    blocks = system.blocks
    rates = sorted({b.period for b in blocks if b.period is not None})
    palette = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    kind_color = {"continuous": "#cfe8cf", "direct": "#eeeeee", "constant": "#f5f5dc", "subsystem": "#dde6f5"}
    xs = [p[0] for p in pos.values()] or [0.0]
    ys = [p[1] for p in pos.values()] or [0.0]
    for pts in paths.values():
        xs += [p[0] for p in pts]
        ys += [p[1] for p in pts]
    if laid is not None:  # dot's units are inches: draw at that scale, whole
        width, height = max(6.0, max(xs) - min(xs) + 2.6), max(3.0, max(ys) - min(ys) + 2.0)
    else:
        width = max(8, 2.2 * len(cols))
        height = max(4, 1.0 * max((len(m) for m in cols.values()), default=1))
    fig, ax = plt.subplots(figsize=(width, height))
    for v, name in enumerate(nodes):
        x, y = pos[v]
        inside = members[name]
        b = blocks[inside[0]]
        if len(inside) > 1 or "." in b.name and not expand:
            fc, label = kind_color["subsystem"], f"subsystem ({len(inside)} blocks)"
        elif b.period is not None:
            fc, label = palette[rates.index(b.period) % len(palette)], getattr(type(b), "type_name", type(b).__name__)
        else:
            fc, label = kind_color[system.kind[inside[0]]], getattr(type(b), "type_name", type(b).__name__)
        ax.add_patch(FancyBboxPatch((x - BOX_W / 2 + 0.05, y - BOX_H / 2 + 0.05), BOX_W - 0.1, BOX_H - 0.1,
                                    boxstyle="round,pad=0.05",
                                    fc=fc, ec="k", lw=0.8, alpha=0.85))
        ax.text(x, y + 0.12, name, ha="center", va="center", fontsize=8, weight="bold")
        ax.text(x, y - 0.2, label, ha="center", va="center", fontsize=6.5)
    for (a, b) in edges:
        color = "tab:red" if (a, b) in back else "0.3"
        pts = paths.get((a, b))
        if pts:  # dot's cubic Bezier spline, or a feedback lane of the layered layout
            from matplotlib.patches import FancyArrowPatch
            from matplotlib.path import Path

            codes = [Path.MOVETO] + [Path.CURVE4 if laid is not None else Path.LINETO] * (len(pts) - 1)
            ax.add_patch(FancyArrowPatch(path=Path(pts, codes), arrowstyle="-|>", mutation_scale=8,
                                         lw=0.7, color=color))
            continue
        (x0, y0), (x1, y1) = pos[a], pos[b]
        ax.annotate("", xy=(x1 - 1.0, y1), xytext=(x0 + 1.0, y0),
                    arrowprops=dict(arrowstyle="->", lw=0.6, color=color,
                                    connectionstyle="arc3,rad=0.25" if x1 <= x0 else "arc3,rad=0.0"))
    handles = [plt.Rectangle((0, 0), 1, 1, fc=palette[k % len(palette)]) for k in range(len(rates))]
    labels = [f"{float(1 / r):g} Hz" for r in rates]
    for kind, c in kind_color.items():
        handles.append(plt.Rectangle((0, 0), 1, 1, fc=c, ec="k"))
        labels.append({"continuous": "continuous state", "direct": "direct (no rate)",
                       "constant": "piecewise constant", "subsystem": "subsystem"}[kind])
    ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncol=len(labels), fontsize=7)
    ax.set_xlim(min(xs) - 1.3, max(xs) + 1.3)
    ax.set_ylim(min(ys) - 0.8, max(ys) + 0.8)
    ax.set_axis_off()
    ax.set_title(title or system.name)
    literal(fig)
    fig.tight_layout()
    return fig


def diagram_svg(diagram):
    """A :class:`~hybridsim.engine.diagram.Diagram` (built first) as SVG text."""
    import io

    plt = pyplot()
    fig = draw_diagram(diagram.build(), diagram.name)
    buf = io.StringIO()
    fig.savefig(buf, format="svg")
    plt.close(fig)
    return buf.getvalue()


def image_formats():
    """The file suffixes matplotlib can write a picture as (``png``, ``svg``, ``pdf``, ...)."""
    from matplotlib.figure import Figure

    return sorted(Figure().canvas.get_supported_filetypes())


def write_picture(path_or_file, output=None, expand=False, **overrides):
    """Draw a diagram file (its first variant) into an image file; ``hybridsim draw``.

    Parameters
    ----------
    path_or_file : str, Path or DiagramFile
        The diagram (``overrides`` as ``--set`` gives them, for a path).
    output : path-like, optional
        The image (its suffix says the format). Default ``NAME.png`` in the working
        folder, where a file hybridsim did not write is kept and the next free name
        ``NAME-2.png``, ... is used.
    expand : bool
        Draw every block of a subsystem (default: a subsystem is one box).

    Returns
    -------
    (pathlib.Path, str or None)
        The file written, and a note saying why it is not the default name (or None).
    """
    from hybridsim.files import atomic_file, check_output_file, default_output_file, safe_name
    from hybridsim.format import standalone
    from hybridsim.format.build import load
    from hybridsim.format.diagram_file import DiagramFile

    plt = pyplot()
    given = isinstance(path_or_file, DiagramFile)
    f = path_or_file if given else DiagramFile(path_or_file)
    sub = standalone.is_subsystem(f)
    if given:
        overrides = {**(getattr(f, "overrides", None) or {}), **overrides}
    elif not sub:
        f = load(path_or_file, **overrides)
    if output is not None:
        out, note = check_output_file(output, image_formats()), None
    else:  # the default name: a file hybridsim did not write is kept, the next free name taken
        out, note = default_output_file(f"{safe_name(f.name)}.png")
        check_output_file(out, image_formats())
    if sub:  # a subsystem file: its blocks, fed by the sources its FMU export would read
        import tempfile

        with tempfile.TemporaryDirectory(prefix="hybridsim-draw-") as tmp:
            system = standalone.Staged(f.path, Path(tmp) / "diagram").build(**overrides)[0]
        fig = draw_diagram(system, f.description or f.name, expand=True)
    else:
        diagram, _ = f.build(f.variants()[0][1])
        fig = draw_diagram(diagram.build(), f.description or f.name, expand=expand)
    with atomic_file(out, "wb") as fh:
        fig.savefig(fh, format=out.suffix.lstrip(".") or "png", dpi=120)
    plt.close(fig)
    return out, note


Diagram.to_svg = diagram_svg
