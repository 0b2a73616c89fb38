"""The look of every figure: one style, marker sizes from the point count, robust y-ranges.

What is logic here (the y-window, the marker size) is tested without pixels
(tests/figures/test_plot_style.py); the style is matplotlib's rcParams, which a user replaces by
their own style sheet (``[plot] style`` or ``cornerbif plot --style``).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import stat
import warnings

import numpy as np

from .errors import SweepError
from .model import cut, did_you_mean, shown, shown_path
from .outputs import save_figure

# one style for every figure: serif text in the paper's sizes, thin frames, vector fonts
# embedded as text (Type 42) so that a journal's PDF checks accept them, rasterised point
# clouds at 300 dpi inside vector output
STYLE = {
    "font.family": "serif",
    "mathtext.fontset": "dejavuserif",
    "font.size": 8,
    "axes.titlesize": 9,
    "axes.labelsize": 9,
    "legend.fontsize": 7,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.linewidth": 0.6,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "lines.linewidth": 1.0,
    "savefig.dpi": 300,
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "svg.fonttype": "none",
}
# the categorical colours are plot_attractors.PALETTE (keyed by the orbit's label); the
# magnitudes' colour map is this one
MAGNITUDE_CMAP = "viridis"

# a share of the finite values at each end that may fall outside the y-window
TAIL = 1e-3
# the window drops the tails only when the full range is this many times the tails' window
SQUEEZE = 2.0
# values beyond which the tails are read from a random sample (robust_range)
SAMPLE = 1_000_000


class StyleRefused(SweepError, ValueError):
    """A style sheet matplotlib would not take whole (exit 2, before drawing)."""


@contextlib.contextmanager
def style(user=None):
    """The project's style, then the user's style sheet (a name matplotlib knows or a
    .mplstyle path) over it; a sheet that is neither, or that matplotlib would not take
    whole, is refused before anything is drawn (``check_style``: ``SweepError``, exit 2)."""
    import matplotlib.pyplot as plt  # start-up: loads matplotlib
    problem = check_style(user)
    if problem:
        raise StyleRefused(problem)
    sheets = [STYLE] + ([user] if user else [])
    with plt.style.context(sheets):
        yield


# plot.style: a matplotlib style name or a path (a path's length, PATH_MAX) and the size of
# the sheet it names (an .mplstyle file is a few hundred lines)
MAX_STYLE_PATH = 4096
MAX_STYLE_BYTES = 2**20


def style_problem(style, key: str) -> str | None:
    """A problem with a style sheet given at ``key`` (``[plot] style``), or None: a name of
    matplotlib's styles, or the path of a regular file of at most MAX_STYLE_BYTES (a path
    with a '/' or ending in .mplstyle is a path; relative to the working directory, as
    ``cornerbif plot`` reads it)."""
    if not isinstance(style, str) or not style:
        return (f"{key}: {shown(style)} must be a matplotlib style name or the path of a "
                ".mplstyle file")
    if len(style) > MAX_STYLE_PATH or "\0" in style:
        return (f"{key}: {shown(style)} ({len(style)} characters) is neither a style name nor "
                f"a path (at most {MAX_STYLE_PATH} characters, no NUL)")
    try:
        st = os.stat(style)
    except OSError:
        st = None
    if st is None and ("/" in style or os.sep in style or style.endswith(".mplstyle")):
        return (f"{key}: {shown_path(style)}: no such style sheet (a path, relative to the "
                "working directory)")
    if st is not None:
        if not stat.S_ISREG(st.st_mode):
            return f"{key}: {shown(style)} is not a regular file (a .mplstyle style sheet)"
        if st.st_size > MAX_STYLE_BYTES:
            return (f"{key}: {shown(style)} is {st.st_size} bytes; a style sheet is at most "
                    f"{MAX_STYLE_BYTES} (a few hundred lines of rc settings)")
        if not os.access(style, os.R_OK):
            return f"{key}: {shown(style)}: cannot read the style sheet (permission denied)"
        return None
    import matplotlib.style as mstyle  # start-up: loads matplotlib
    if style in mstyle.available:
        return None
    return (f"{key}: {shown(style)} is neither a file nor one of matplotlib's styles"
            f"{did_you_mean(style, mstyle.available)} ({', '.join(sorted(mstyle.available)[:6])}, ...)")


def check_style(user, key: str = "style") -> str | None:
    """A problem with a user's style sheet given at ``key``, or None: a name of matplotlib's,
    or a readable file (``style_problem``, which ``validate`` uses for ``[plot]
    style``) of lines 'key: value', each key one of matplotlib's settings and each value one
    it takes (matplotlib itself would print a warning of its own and go on)."""
    if user is None:
        return None
    problem = style_problem(user, key)
    if problem or not os.path.isfile(user):
        return problem
    return _style_file_problem(user, key)


# the largest style sheet read (matplotlib's own are a few kB)
STYLE_BYTES = 1 << 20


def _style_file_problem(path: str, key: str) -> str | None:
    """What is wrong with the style sheet at ``path`` (``check_style``), or None."""
    import matplotlib as mpl  # start-up: loads matplotlib
    name = f"{key}: {bounded(path, 200)}"
    try:
        with open(path, "rb") as fh:
            raw = fh.read(STYLE_BYTES + 1)
    except OSError as e:
        return f"{name}: cannot be read ({e.strerror or e})"
    if len(raw) > STYLE_BYTES:
        return f"{name}: more than {STYLE_BYTES >> 20} MiB, not a style sheet"
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        return f"{name}: not a text file (a style sheet is lines 'key: value', UTF-8)"
    probe = mpl.RcParams()
    for n, line in enumerate(text.splitlines(), 1):
        body = re.sub(r"""#(?=(?:[^"]*"[^"]*")*[^"]*$).*""", "", line).strip()
        if not body:
            continue
        key, colon, val = (x.strip() for x in body.partition(":"))
        where = f"{name}, line {n} ({bounded(line.strip(), 80)!r})"
        if not colon:
            return f"{where}: not 'key: value'"
        if key not in mpl.rcParams:
            return f"{where}: {bounded(key)!r} is not a matplotlib setting"
        if len(val) >= 2 and val[0] == val[-1] == '"':
            val = val[1:-1]
        try:
            probe[key] = val
        except Exception as e:  # noqa: BLE001 - each validator raises its own kind
            return f"{where}: not a value of {key} ({bounded(str(e), 120)})"
        if key == "text.usetex" and probe[key] and not latex_available():
            return (f"{where}: text.usetex draws every text with LaTeX, which is not "
                    "installed here (no latex, dvipng or dvips on PATH); remove the line "
                    "(cornerbif's mathtext needs no LaTeX)")
    return None


def latex_available() -> bool:
    """Whether matplotlib's ``text.usetex`` can work here: latex and a DVI converter on PATH
    (matplotlib runs them for every text drawn, and fails mid-drawing without them)."""
    return bool(shutil.which("latex")) and bool(shutil.which("dvipng") or shutil.which("dvips"))


def robust_range(values, tail=TAIL, squeeze=SQUEEZE, pad=0.04):
    """The y-window of a diagram: (low, high, outside).

    The full range of the finite values, unless it is more than ``squeeze`` times the
    range of all but a share ``tail`` at each end (a few outlying points would press the
    structure into a thin band): then that central range.  Padded by ``pad`` of its width
    on each side; ``outside`` counts the values the window leaves out (said on the
    figure).  None when no value is finite (infinities are not).  Past SAMPLE values the
    tails are read from a random sample of SAMPLE positions (a fixed seed: the same window
    for the same file; not a stride, which could fall in step with a cycle's period and miss
    a branch), the count outside is exact.  ``values``: an array, or ``Rows`` read a slab
    at a time (``row_slabs``): memory is the sample's and one slab's, whatever the count.
    """
    if not isinstance(values, Rows):
        values = np.asarray(values, dtype=float).ravel()
    size = int(np.prod(values.shape))
    picks = (np.sort(np.random.default_rng(0).integers(0, size, SAMPLE)) if size > SAMPLE
             else None)
    n, lo, hi, sample = _scan(values, picks)
    if n == 0:
        return None
    squeezed = False
    if n >= 1.0 / tail:
        if sample.size < 1.0 / tail:
            sample = _scan(values, None)[3]
        qlo, qhi = (float(x) for x in np.quantile(sample, [tail, 1.0 - tail]))
        if qhi > qlo and hi - lo > squeeze * (qhi - qlo):
            lo, hi = qlo, qhi
            squeezed = True
    span = hi - lo if hi > lo else max(abs(hi), 1.0) * 1e-3
    lo, hi = lo - pad * span, hi + pad * span
    # the full range padded leaves nothing out: no pass to count
    return lo, hi, count_outside(values, lo, hi) if squeezed or pad < 0 else 0


def _scan(values, picks):
    """One pass over ``values`` (an array or ``Rows``): the count of its finite values,
    their least and greatest, and the finite values among those at the sorted flat
    positions ``picks`` (repeats kept), or every finite value when ``picks`` is None."""
    n, lo, hi, got = 0, np.inf, -np.inf, []
    width = int(np.prod(values.shape[1:]))
    for a, block in row_slabs(values):
        v = np.asarray(block, dtype=float).ravel()
        fin = np.isfinite(v)
        n += int(np.count_nonzero(fin))
        lo = min(lo, float(np.min(v, where=fin, initial=np.inf)))
        hi = max(hi, float(np.max(v, where=fin, initial=-np.inf)))
        if picks is None:
            got.append(v[fin])
        else:
            i0, i1 = np.searchsorted(picks, [a * width, a * width + v.size])
            s = v[picks[i0:i1] - a * width]
            got.append(s[np.isfinite(s)])
    return n, lo, hi, (np.concatenate(got) if got else np.zeros(0))


def count_finite(values) -> int:
    """How many of ``values`` (an array or ``Rows``, read a slab at a time) are finite."""
    return sum(int(np.count_nonzero(np.isfinite(block))) for _, block in row_slabs(values))


def count_infinite(values) -> int:
    """How many of ``values`` (an array or ``Rows``, a slab at a time) are infinite (the
    escapes a figure does not draw: ``plot.beyond_drawing``)."""
    return sum(int(np.count_nonzero(np.isinf(block))) for _, block in row_slabs(values))


def count_outside(values, lo, hi) -> int:
    """How many finite ``values`` (an array or ``Rows``, a slab at a time) fall outside
    [lo, hi]."""
    n = 0
    with np.errstate(invalid="ignore"):
        for _, v in row_slabs(values):
            n += int(np.count_nonzero(np.isfinite(v) & ((v < lo) | (v > hi))))
    return n


def marker_size(n_points, lo=0.5, hi=3.0):
    """Marker size (points) of a point cloud of ``n_points``: large for a few thousand
    points, shrinking as the fourth root of the count, never below ``lo`` (at 300 dpi a
    marker of 0.5 pt still covers two pixels)."""
    if n_points <= 0:
        return hi
    return float(np.clip(2.4 / (n_points / 2e4) ** 0.25, lo, hi))


# where an inset may go, in axes fractions (x, y, width, height): the four corners
INSET_CORNERS = {"lower left": (0.07, 0.08), "upper left": (0.07, 0.56),
                 "lower right": (0.59, 0.08), "upper right": (0.59, 0.56)}


def emptiest_corner(ax, x, y, size=(0.34, 0.36), avoid=("upper right",)):
    """The inset rectangle [x0, y0, w, h] (axes fractions) over the fewest of the data
    points (x, y), among the axes' corners (``avoid``: corners kept for a legend); the
    first in ``INSET_CORNERS``' order on a tie.  The axes' limits must be final."""
    pts = ax.transLimits.transform(np.column_stack([np.ravel(x), np.ravel(y)]))
    ok = np.isfinite(pts).all(axis=1)
    pts = pts[ok]
    best, count = None, None
    for name, (x0, y0) in INSET_CORNERS.items():
        if name in avoid:
            continue
        inside = ((pts[:, 0] >= x0) & (pts[:, 0] <= x0 + size[0])
                  & (pts[:, 1] >= y0) & (pts[:, 1] <= y0 + size[1]))
        n = int(inside.sum())
        if count is None or n < count:
            best, count = name, n
    x0, y0 = INSET_CORNERS[best]
    return [x0, y0, size[0], size[1]]


# point clouds of more values than this are drawn as one image (``raster_runs``), and
# never held whole (``Rows``)
RASTER_POINTS = 1_000_000
RASTER_VALUES = 1 << 18   # values read, counted or put into the image at a time


class Rows:
    """An array read a slab of rows at a time: ``shape``, ``ndim``, ``size``, and
    ``rows[a:b]``, rows a..b-1 of the first axis read (or computed) on demand by
    ``read(a, b)``; ``opened`` (optional) a context manager factory that holds what the
    reads need (a file) open over one pass.  A diagram of millions of points goes
    through one (``row_slabs``: ``robust_range``, ``raster_runs``) and is never whole in
    memory."""

    def __init__(self, shape, read, opened=None):
        self.shape = tuple(int(n) for n in shape)
        self.ndim = len(self.shape)
        self.size = int(np.prod(self.shape))
        self._read = read
        self._opened = opened

    def __getitem__(self, rows):
        if not isinstance(rows, slice) or rows.step not in (None, 1):
            raise TypeError(f"Rows are read by a slice of consecutive rows, not {rows!r}")
        a, b, _ = rows.indices(self.shape[0])
        return self._read(a, max(a, b))

    def opened(self):
        """A context in which a pass of reads goes (``opened``, else nothing to hold)."""
        return self._opened() if self._opened else contextlib.nullcontext()


def slab_rows(shape):
    """The first axis of an array of ``shape`` in slabs of whole rows of about RASTER_VALUES
    values each: a list of slices."""
    step = max(1, RASTER_VALUES // max(1, int(np.prod(shape[1:]))))
    return [slice(a, min(a + step, shape[0])) for a in range(0, shape[0], step)]


def row_slabs(values):
    """(first row, the rows as an array) of ``values`` (an array or ``Rows``, held
    ``opened`` over the pass), a slab at a time (``slab_rows``)."""
    with values.opened() if isinstance(values, Rows) else contextlib.nullcontext():
        for rows in slab_rows(values.shape):
            yield rows.start, np.asarray(values[rows])


def raster_runs(ax, x, y, layer, colors, xlim, ylim, ms, dpi):
    """A diagram's point cloud as one RGBA image at ``dpi``, for millions of points.

    ``x`` (n,) the swept values, ``y`` (n, starts, record) the drawn values, ``layer``
    (n, starts) each run's layer (an index into ``colors``, -1: not drawn); a higher layer
    is drawn over a lower one.  Each value sets its pixel, then the image is grown to a
    marker of ``ms`` points.  ``y`` and ``layer`` are arrays or ``Rows``, read in slabs of
    RASTER_VALUES (``row_slabs``): memory is the image's (an int16 and 4 floats per pixel)
    and one slab's, whatever the number of points.  Sets the axes' limits to ``xlim``,
    ``ylim``."""
    from matplotlib.colors import to_rgba  # start-up: loads matplotlib
    fig = ax.figure
    pos = ax.get_position()
    W = max(16, int(round(pos.width * fig.get_figwidth() * dpi)))
    H = max(16, int(round(pos.height * fig.get_figheight() * dpi)))
    (x0, x1), (y0, y1) = xlim, ylim
    top = np.full((H, W), -1, np.int16)
    for a, ys in row_slabs(y):
        b = a + ys.shape[0]
        lay = np.broadcast_to(np.asarray(layer[a:b])[:, :, None], ys.shape)
        xs = np.broadcast_to(x[a:b, None, None], ys.shape)
        ok = (lay >= 0) & np.isfinite(ys) & (ys >= y0) & (ys <= y1) & (xs >= x0) & (xs <= x1)
        px = np.minimum(((xs[ok] - x0) * (W / (x1 - x0))).astype(np.int32), W - 1)
        py = np.minimum(((ys[ok] - y0) * (H / (y1 - y0))).astype(np.int32), H - 1)
        np.maximum.at(top, (py, px), lay[ok].astype(np.int16))
    r = int(round(ms * dpi / 72.0 / 2.0))            # the marker's radius in pixels
    if r > 0:
        grown = top.copy()
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                if dx * dx + dy * dy > r * r or (dx == 0 and dy == 0):
                    continue
                src = top[max(-dy, 0):H - max(dy, 0), max(-dx, 0):W - max(dx, 0)]
                dst = grown[max(dy, 0):H - max(-dy, 0), max(dx, 0):W - max(-dx, 0)]
                np.maximum(dst, src, out=dst)
        top = grown
    rgba = np.zeros((H, W, 4), np.float32)
    drawn = top >= 0
    rgba[drawn] = np.array([to_rgba(c) for c in colors], np.float32)[top[drawn]]
    ax.imshow(rgba, extent=(x0, x1, y0, y1), origin="lower", aspect="auto",
              interpolation="nearest", zorder=2)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


# ------------------------------------------------------------------ titles
# the Greek names a scene's title spells in ASCII (omega, kappa_C, omega0_C, beta^N gamma)
_GREEK = ("alpha", "beta", "gamma", "delta", "kappa", "omega", "Omega", "phi", "mu", "sigma",
          "Sigma", "lambda", "tau")
_SYMBOL = re.compile(r"(?<![\w\\$])(" + "|".join(_GREEK) + r")(0)?(?:_(\w+?))?(?:\^(\w+))?"
                     r"(?!\w)")
_LETTER_SUB = re.compile(r"(?<![\w$])([A-Z])_(alpha|beta|gamma)(?!\w)")
_WORD_GAP = re.compile(r"(\\(?:alpha|beta|gamma)(?:\^\{\w+\})?)\$ \$(?=\\(?:alpha|beta|gamma))")
# what a title's line never breaks: a formula, |...|, an 'a = b', a reference '(eq 11)'
_UNBROKEN = re.compile(r"(?:\$[^$]*\$|[^\s$]+) = (?:\$[^$]*\$|[^\s$]+)|\$[^$]*\$|\|[^|]*\|"
                       r"|\(eqs? [^()]*\)")


def title_tex(text: str) -> str:
    r"""A title in the paper's notation: the Greek names a scene's title spells in ASCII as
    mathtext (omega -> $\omega$, kappa_CC -> $\kappa_{CC}$, omega0_C -> $\omega_{0,C}$,
    kappa_beta -> $\kappa_{\beta}$, Sigma_1, S_alpha), an orbit's letters side by side
    (beta^11 gamma -> $\beta^{11}\gamma$, as the paper writes words); text already in
    $...$ is left as it is."""
    def symbol(m):
        name, zero, sub, sup = m.groups()
        sub = "\\" + sub if sub in _GREEK else sub
        subs = ",".join(x for x in (zero, sub) if x)
        return ("$\\" + name + (f"_{{{subs}}}" if subs else "") + (f"^{{{sup}}}" if sup else "")
                + "$")
    parts = re.split(r"(\$[^$]*\$)", text)
    for i in range(0, len(parts), 2):
        s = _LETTER_SUB.sub(lambda m: f"${m.group(1)}_{{\\{m.group(2)}}}$",
                            _SYMBOL.sub(symbol, parts[i]))
        joined = None
        while joined != s:
            joined, s = s, _WORD_GAP.sub(r"\1", s)
        parts[i] = s
    return "".join(parts)


def title_lines(text: str, width: int) -> str:
    """A figure's title (``title_tex``) in lines of about ``width`` characters as drawn (a
    formula counts its glyphs, not its markup), broken between words but never inside a
    formula, a |...|, an 'a = b' or an equation's reference '(eq 11)'.  At most TITLE_MAX
    characters of ``text`` (``bounded``: a file's title may be of any length); a text whose
    formulas matplotlib cannot draw (a crafted file's) is drawn as it is, its $ signs
    literal (``mathtext_problem``).  A word of plain text longer than a line is cut into lines."""
    text = bounded(text or "", TITLE_MAX)
    tex = title_tex(text)
    if mathtext_problem(tex):
        tex = text.replace("\\$", "$").replace("$", "\\$")
    words = []
    for w in _UNBROKEN.sub(lambda m: m.group(0).replace(" ", "\0"), tex).split():
        plain_text = "$" not in w and "\0" not in w
        words += ([w[i:i + width] for i in range(0, len(w), width)]
                  if plain_text and len(w) > width > 0 else [w])
    lines, line, used = [], [], 0
    for w in words:
        n = _drawn_length(w.replace("\0", " "))
        if line and used + 1 + n > width:
            lines.append(" ".join(line))
            line, used = [], 0
        used += n + (1 if line else 0)
        line.append(w)
    if line:
        lines.append(" ".join(line))
    return "\n".join(lines).replace("\0", " ")


def _drawn_length(word: str) -> int:
    """About how many characters ``word`` takes when drawn: a TeX command is one glyph,
    $, braces, ^ and _ none."""
    return len(re.sub(r"[${}^_]", "", re.sub(r"\\[A-Za-z]+", "x", word)))


# ------------------------------------------------------------------ free text
# the longest free text a figure or ``cornerbif info`` shows of a file (a title; a scene's
# name, a word, a command, a label): the rest is cut, with an ellipsis
TITLE_MAX = 500
LABEL_MAX = 60
ELLIPSIS = "..."


def bounded(text, limit: int = LABEL_MAX) -> str:
    """``text`` for a figure: one printable line of at most ``limit`` characters
    (``model.cut``: line breaks, tabs and other control characters become spaces); a longer
    text is cut and ends with an ellipsis, never inside a $...$ formula (which would then
    not parse).  Reads no more of ``text`` than it shows (a title of 50 MB costs nothing)."""
    s = cut(text, limit + 1, mark="")         # one more than is shown: tells a longer text
    if len(s) <= limit:
        return s
    s = s[:limit - len(ELLIPSIS)]
    if (s.count("$") - s.count("\\$")) % 2:
        s = s[: s.rfind("$")]
    return s.rstrip() + ELLIPSIS


def plain(text, limit: int = LABEL_MAX) -> str:
    """A file's text for a legend or a note: ``bounded``, its $ signs drawn as dollars
    (matplotlib would read them as the start of a formula)."""
    return bounded(text, limit).replace("\\$", "$").replace("$", "\\$")


_PARSER = []


def mathtext_problem(text: str) -> tuple | None:
    """(line, why) for the first line of ``text`` that matplotlib cannot draw: a line of
    mathtext (an even number of unescaped $, at least two) that its parser refuses, or
    nests past what it can recurse; None when every line can be drawn.  matplotlib is
    imported only when some line is mathtext (``config.undrawable`` checks every title and
    label of a scene with it; ``title_lines`` a file's title)."""
    lines = [x for x in text.split("\n") if x.count("$") - x.count("\\$") >= 2]
    if not lines:
        return None
    from matplotlib import cbook  # start-up: loads matplotlib
    from matplotlib.mathtext import MathTextParser  # start-up: loads matplotlib
    if not _PARSER:
        _PARSER.append(MathTextParser("path"))
    for line in lines:
        if not cbook.is_math_text(line):
            continue
        try:
            _PARSER[0].parse(line, dpi=72)
        except RecursionError:
            return line, "its formula nests too deeply for matplotlib's parser"
        except Exception as e:  # noqa: BLE001 - pyparsing's and matplotlib's own errors
            return line, cut((str(e).strip().splitlines() or [type(e).__name__])[-1], 120)
    return None


def legend(ax, *args, **kw):
    """``ax.legend`` when something in the axes is labelled (matplotlib warns of an empty
    legend, and draws nothing); None otherwise."""
    if args or "handles" in kw or ax.get_legend_handles_labels()[0]:
        return ax.legend(*args, **kw)
    return None


@contextlib.contextmanager
def quiet():
    """Drawing, without the warnings numpy and matplotlib give on what a file holds by
    design: NaN where a run has no value and infinities where it escaped (numpy's overflow,
    invalid value, All-NaN slice: the figure counts what it leaves out), and a layout that
    cannot be tightened around long texts (the figure keeps its layout)."""
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=RuntimeWarning)
        warnings.filterwarnings("ignore", message=".*[Tt]ight.?layout")
        yield


def save(fig, out, **kw):
    """Write ``fig`` to ``out`` whole or not at all (``outputs.save_figure``), then free it;
    a failed write is ``WriteFailed`` naming ``out`` (the previous figure is unchanged)."""
    import matplotlib.pyplot as plt  # start-up: loads matplotlib

    try:
        with quiet():
            save_figure(fig, out, **kw)
    finally:
        plt.close(fig)
    return out
