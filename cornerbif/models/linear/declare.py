"""The ``[system]`` table of a ``linear`` scene: ``read_system`` builds a
``system.LinearSystem`` or lists what is wrong, each problem naming its key by its path
(``system.contact.R.gap``) and the value there; ``numeric_paths`` and ``with_value`` name and
set every number by its path (sweep axes, continuation parameters: ``"forcing.0.Omega"``,
``"contact.R.kappa"``, ``"mass.y"``, ``"stiffness.x.x"``); ``refusable`` flags at once which
of many settings of those numbers may be refused (a sweep's combinations).  Pure Python:
loads no numba.

The table::

    dofs = ["x", "y"]               # N <= MAX_DOFS distinct identifiers (<= MAX_NAME characters)
    mass = [1.0, 0.1]               # N numbers (a diagonal) or N rows of N numbers
    stiffness = [[1.0, 0.0], [0.0, 0.0]]          # the same two forms
    damping = [[0.05, 0.0], [0.0, 0.0]]           # the same two forms; default 0
    forcing = [{ on = "x", F = 0.7, Omega = 0.9, phi = 0.0 }]   # Omega, phi default 0
    [[system.contact]]              # at most MAX_CONTACTS
    name = "R"                      # one letter A-Z or a-z, distinct: the impact's symbol
    gap = { y = 1.0, x = -1.0 }     # a = (-1, 1); or a list of N numbers; dofs left out are 0
    obstacle = "fixed"              # default; or a kind of cornerbif.obstacles
    kappa = -0.4                    # z(t) = kappa + beta shape(omega t); default 0
    law = "impact"                  # default, with r (default 0.8); or "spring", with k, c

What is checked, and why:

* M symmetric positive-definite (Cholesky; a diagonal of positive numbers), its condition
  number at most MAX_CONDITION: the exact flight and the impact law v+ = v- - (1 + r) w-
  M^-1 a / (a^T M^-1 a) need M^-1, and a^T M^-1 a > 0 for every gap a != 0;
* K symmetric positive semi-definite (eigenvalues >= -PSD_TOL * max |K_ij|): the free motion
  stays bounded (a zero eigenvalue, a rigid-body mode such as a free ball, is allowed);
* M and K are symmetric to a relative SYMMETRY_TOL, and stored symmetrized; C is any N x N
  finite matrix whose symmetric part (C + C^T) / 2 is positive semi-definite, to PSD_TOL as
  K (negative damping feeds the free motion without bound; a gyroscopic part C - C^T is
  allowed);
* nothing overflows float64 (``_scales``): M^-1; the flight's matrix A, whose norm is at
  most MAX_RATE (the kernel steps by 1/|A| and takes A to its RATE_POWER-th power); each
  contact's a^T M^-1 a (the impact law divides by it) and |a| |A|^RATE_POWER;
* a dof's name: an identifier of at most MAX_NAME characters, not v_..., not a key of
  [initial], and none of its datasets (``dataset_names``: x, v_x) named as one the file
  holds beside them (FILE_NAMES: an impact's own, impacts/v_in, and the groups' scales);
* every number finite, and a number (a bool is not);
* forcing: ``on`` a declared dof, F finite, Omega >= 0 (0: the constant force F cos(phi)),
  and not below MIN_FREQUENCY when not 0 (its period a float);
* contacts: a gap over declared dofs, finite, not all zero (no coordinate: no contact); law
  "impact" with 0 <= r <= 1 (restitution, default 0.8 as the flow model's, so that the
  paper's scenes written as linear scenes keep their default); law "spring" (a soft stop)
  with k > 0 (required: no default stiffness of a stop makes sense) and c >= 0 (default
  0), on a fixed obstacle only, at most MAX_SOFT of them (each set of them acting is a
  flight of its own, prepared in advance: 2^MAX_SOFT); obstacle
  "fixed" (z = kappa: beta and omega are refused) or a registered kind without tables of
  its own (a cam ``profile`` needs [system.profile], which a contact cannot hold yet); a
  moving kind needs both beta (finite, not 0: that is the fixed obstacle) and omega (>=
  MIN_FREQUENCY > 0);
* unknown keys in [system], a forcing entry or a contact are refused, with a did-you-mean.
"""

from __future__ import annotations

import copy
import difflib
import math
import string

import numpy as np

from ... import obstacles
from ...model import KEY_CHARS, cut, did_you_mean, is_number, shown
from .system import MAX_CONTACTS, MAX_DOFS, MAX_SOFT, Contact, Forcing, LinearSystem, Words

SYSTEM_KEYS = ("dofs", "mass", "stiffness", "damping", "forcing", "contact", "words")
# [system] words: the two-particle model's words (system.Words)
WORDS_KEYS = ("impacts", "corners", "height", "velocity")
WORDS_EXAMPLE = 'words = { impacts = "U", corners = "W" }'
FORCING_KEYS = ("on", "F", "Omega", "phi")
CONTACT_KEYS = ("name", "gap", "obstacle", "kappa", "beta", "omega", "law", "r", "k", "c")
FIXED = "fixed"
# names a dof may not take: the keys of [initial] beside the coordinates (config.py)
RESERVED_DOFS = ("count", "seed", "points", "points_file", "t")
# ... nor a name that one of its datasets (``dataset_names``) shares with a dataset the file
# holds beside the coordinates': an impact's own (model.BASE_FIELDS and, with the paper's
# words, CORNER_FIELDS), and the scales io.create copies into each group (initial/ic,
# final/ic, impacts/ic, impacts/record): the writer would create one name twice
IMPACT_NAMES = ("t", "contact", "u", "v_in", "v_out", "corner_offset")
GROUP_SCALES = ("ic", "record")
FILE_NAMES = IMPACT_NAMES + GROUP_SCALES
MAX_NAME = 64             # characters of a dof's name (a coordinate's, not a title)
LAWS = ("impact", "spring")
LAW_KEYS = {"impact": ("r",), "spring": ("k", "c")}
SYMMETRY_TOL = 1e-12      # |M - M^T| <= SYMMETRY_TOL max |M|
PSD_TOL = 1e-12           # eigenvalues of K, and of C's symmetric part, >= -PSD_TOL max |K|
MAX_CONDITION = 1e12      # of M: M^-1 keeps about 4 digits
# the flight's matrix A (flight.augmented: M^-1 K, M^-1 C, M^-1 F and the forces'
# frequencies): the kernel steps by 1/|A| and its flight bounds take c A^(d + 16), d <= 4
# (kernel.flight_bounds), so |A| <= MAX_RATE and |a| |A|^RATE_POWER <= 10^MAX_POWER_EXP (room
# left for the state, up to run.escape), and a^T M^-1 a (the impact law divides by it)
# within 10^-FLOAT_EXP .. 10^FLOAT_EXP: nothing overflows float64
MAX_RATE = 1e12
RATE_POWER = 20
MAX_POWER_EXP = 290
FLOAT_EXP = 300
# a force's Omega (when not 0) and a moving obstacle's omega: their periods (2 pi / Omega,
# model.system_period) stay floats (seen: Omega = 5e-324, a period of inf, crashed a run)
MIN_FREQUENCY = 1e-300


def dataset_names(dof: str) -> tuple:
    """The names of a dof's datasets, in each group that holds them (model.for_system): its
    coordinate and velocity as state (initial/, final/) and at each impact (impacts/)."""
    return (dof, f"v_{dof}")


def obstacle_kinds() -> tuple:
    """The obstacles a contact may name: "fixed", then the registered kinds without tables
    of their own."""
    return (FIXED,) + tuple(n for n, o in obstacles.registered().items() if not o.tables)


def _finite(v) -> bool:
    return is_number(v) and math.isfinite(float(v))


class _Reader:
    def __init__(self):
        self.problems = []

    def bad(self, key, v, what):
        self.problems.append(f"system.{key}: {shown(v)} {what}")

    def unknown(self, key, table, allowed):
        for k in table:
            if k not in allowed:
                self.problems.append(f"system.{key}{cut(k, KEY_CHARS)}: unknown key"
                                     f"{did_you_mean(str(k), allowed)}; allowed: {', '.join(allowed)}")

    def number(self, key, table, name, default=None, *, test=None, need="", missing=""):
        """``table[name]`` as a finite float passing ``test`` (``need`` says what it must
        be), or ``default`` when absent (a problem saying ``missing`` when there is no
        default); None when refused."""
        if name not in table:
            if default is None:
                self.problems.append(f"system.{key}.{name}: missing; {missing or 'it must be ' + need}")
            return default
        v = table[name]
        if not _finite(v) or (test is not None and not test(float(v))):
            self.bad(f"{key}.{name}", v, f"must be a finite number{need and ' ' + need}")
            return None
        return float(v)

    def dofs(self, v):
        if not isinstance(v, list) or not v:
            self.bad("dofs", v, "must be a non-empty list of coordinate names, e.g. [\"x\", \"y\"]")
            return None
        if len(v) > MAX_DOFS:
            self.bad("dofs", v, f"names {len(v)} coordinates; at most {MAX_DOFS}")
            return None
        ok = True
        for i, d in enumerate(v):
            why = self.dof_problem(d, v[:i])
            if why:
                self.bad(f"dofs.{i}", d, why)
                ok = False
        return tuple(v) if ok else None

    @staticmethod
    def dof_problem(d, before) -> str | None:
        """What is wrong with the dof name ``d`` after the names ``before``, or None."""
        if isinstance(d, str) and len(d) > MAX_NAME:
            return f"is {len(d)} characters long; a coordinate's name has at most {MAX_NAME}"
        if not (isinstance(d, str) and d.isidentifier()):
            return "must be a name (letters, digits and _, not starting with a digit)"
        if d in before:
            return "is named twice; coordinate names must be distinct"
        if d.startswith("v_") or d in RESERVED_DOFS:
            return ("is a name the scene uses for something else (v_<dof> is a velocity; "
                    f"{', '.join(RESERVED_DOFS)} are [initial] keys)")
        clash = next((n for n in dataset_names(d) if n in FILE_NAMES), None)
        if clash is None:
            return None
        own = "is" if clash == d else f"would name its velocity's dataset {clash}, which is"
        return (f"{own} the name of a dataset the file holds beside the coordinates' "
                f"(impacts/{clash}; an impact's own: {', '.join(IMPACT_NAMES)}; the scales "
                f"of each group: {', '.join(GROUP_SCALES)}): the writer would create it "
                "twice; name the coordinate otherwise, for example x")

    def matrix(self, key, v, dofs):
        """(the (N, N) array, whether given as a diagonal), or None."""
        n = len(dofs)
        shape = (f"must be {n} numbers (a diagonal) or {n} rows of {n} numbers, one per dof "
                 f"({', '.join(dofs)})")
        if not isinstance(v, list) or len(v) != n:
            self.bad(key, v, shape)
            return None
        rows = [isinstance(row, list) for row in v]
        if any(rows) and not (all(rows) and all(len(row) == n for row in v)):
            self.bad(key, v, shape)
            return None
        out, ok = np.zeros((n, n)), True
        cells = (((i, j), f"{key}.{dofs[i]}.{dofs[j]}", x) for i, row in enumerate(v)
                 for j, x in enumerate(row)) if all(rows) else \
            (((i, i), f"{key}.{dofs[i]}", x) for i, x in enumerate(v))
        for ij, path, x in cells:
            if _finite(x):
                out[ij] = float(x)
            else:
                self.bad(path, x, "must be a finite number")
                ok = False
        return (out, not all(rows)) if ok else None

    def symmetric(self, key, v, a):
        with np.errstate(all="ignore"):
            asym = np.abs(a - a.T)
            if not asym.max() <= SYMMETRY_TOL * np.abs(a).max():
                i, j = np.unravel_index(np.argmax(asym), a.shape)
                self.bad(key, v, f"is not symmetric (entries [{i}][{j}] = {float(a[i, j])!r} "
                                 f"and [{j}][{i}] = {float(a[j, i])!r})")
                return None, None
            s = 0.5 * (a + a.T)
            eig = np.linalg.eigvalsh(s) if np.all(np.isfinite(s)) else np.array([np.nan])
        if not np.all(np.isfinite(eig)):
            self.bad(key, v, "is too large: its eigenvalues overflow float64")
            return None, None
        return s, eig

    def mass(self, v, dofs):
        got = self.matrix("mass", v, dofs)
        if got is None:
            return None
        m, diagonal = got
        if diagonal and np.any(np.diag(m) <= 0):
            for i in np.flatnonzero(np.diag(m) <= 0):
                self.bad(f"mass.{dofs[i]}", v[i], "must be a positive number (a diagonal mass)")
            return None
        m, eig = self.symmetric("mass", v, m)
        if m is None:
            return None
        try:
            np.linalg.cholesky(m)
        except np.linalg.LinAlgError:
            self.bad("mass", v, f"is not positive-definite (its smallest eigenvalue is "
                                f"{eig[0]:.6g}): the flight and the impact law need M^-1")
            return None
        if _singular(eig):
            self.bad("mass", v, f"is nearly singular (eigenvalues {eig[0]:.3g} to {eig[-1]:.3g}, "
                                f"a condition number past {MAX_CONDITION:g}): M^-1 would lose "
                                "its digits")
            return None
        return m

    def stiffness(self, v, dofs):
        got = self.matrix("stiffness", v, dofs)
        if got is None:
            return None
        k, eig = self.symmetric("stiffness", v, got[0])
        if k is not None and _not_psd(eig, k):
            self.bad("stiffness", v, f"is not positive semi-definite (its smallest eigenvalue "
                                     f"is {eig[0]:.6g}): the free motion would grow without bound")
            return None
        return k

    def damping(self, v, dofs):
        """C: any N x N matrix (a gyroscopic part C - C^T is allowed) whose symmetric part is
        positive semi-definite (negative damping feeds the motion without bound)."""
        got = self.matrix("damping", v, dofs)
        if got is None:
            return None
        c = got[0]
        eig = _sym_eig(c)
        if _not_psd(eig, c):
            self.bad("damping", v, f"is not positive semi-definite (the smallest eigenvalue of "
                                   f"its symmetric part (C + C^T) / 2 is {eig[0]:.6g}): negative "
                                   "damping feeds energy in, and the free motion would grow "
                                   "without bound")
            return None
        return c

    def scales(self, table, m, k, c, forcing, contacts):
        """The problems of a system otherwise valid whose sizes pass float64 (``_scales``):
        M^-1, the flight's matrix A, each contact's a^T M^-1 a and |a| |A|^RATE_POWER."""
        n, nf = len(m), len(forcing)
        got = _scales(m[None], k[None], c[None], [f.on for f in forcing],
                      np.array([f.F for f in forcing]).reshape(1, nf),
                      np.array([f.Omega for f in forcing]).reshape(1, nf),
                      np.array([x.gap for x in contacts]).reshape(1, len(contacts), n))
        if not got["minv"][0]:
            self.bad("mass", table["mass"], "is too small: its inverse M^-1 overflows float64")
            return
        rate = got["rate"][0]
        if not rate <= MAX_RATE:
            # the largest block of A names its number, or the mass when M^-1 makes the most
            # of it (a tiny mass under a force of 1)
            key = max(got["terms"], key=lambda t: np.nan_to_num(got["terms"][t][0], nan=np.inf))
            head, *rest = key.split(".")
            v = table.get(head) if not rest else table["forcing"][int(rest[0])].get(rest[1], 0.0)
            own = {"stiffness": k, "damping": c}.get(key, v)
            with np.errstate(all="ignore"):
                by_mass = rest[-1:] != ["Omega"] and np.linalg.norm(own) ** 2 < got["terms"][key][0]
            name, v, other = ("mass", table["mass"], f"with {key} = {shown(v, 40)}") if by_mass \
                else (key, v, f"the mass is {shown(table['mass'], 40)}")
            self.bad(name, v, f"gives the flight's matrix A (M^-1 K, M^-1 C, M^-1 F and the forces' "
                              f"frequencies; {other}) a norm up to {rate:.3g}, past {MAX_RATE:g}: "
                              f"a run steps by 1/|A| and takes A to its {RATE_POWER}th power; "
                              "scale the scene's time or units")
            return
        for i, x in enumerate(contacts):
            q, power = got["q"][0, i], got["power"][0, i]
            given = table["contact"][i]["gap"]
            if not 10.0 ** -FLOAT_EXP <= q <= 10.0 ** FLOAT_EXP:
                self.bad(f"contact.{x.name}.gap", given, f"gives a^T M^-1 a = {q:.3g} with the mass, "
                         f"outside 1e-{FLOAT_EXP} to 1e{FLOAT_EXP}: the impact law divides by it")
            elif not power <= MAX_POWER_EXP:
                self.bad(f"contact.{x.name}.gap", given, f"is too large for the flight's rates: "
                         f"|a| |A|^{RATE_POWER} (the certified flight's bounds) reaches "
                         f"1e{power:.0f}, past float64")

    def forcing(self, v, dofs):
        if not isinstance(v, list):
            self.bad("forcing", v, "must be a list of { on = .., F = .., Omega = .., phi = .. }")
            return None
        out = []
        for i, f in enumerate(v):
            key = f"forcing.{i}"
            if not isinstance(f, dict):
                self.bad(key, f, "must be a table { on = .., F = .., Omega = .., phi = .. }")
                continue
            self.unknown(key + ".", f, FORCING_KEYS)
            on = f.get("on")
            if "on" not in f:
                self.problems.append(f"system.{key}.on: missing; a force names the dof it acts on")
            elif not isinstance(on, str):
                self.bad(f"{key}.on", on, "must be the name of a dof")
            elif dofs is not None and on not in dofs:
                self.bad(f"{key}.on", on, f"is not a dof{did_you_mean(on, dofs)}; "
                                          f"dofs: {', '.join(dofs)}")
            F = self.number(key, f, "F", missing="the force's amplitude in F cos(Omega t + phi)")
            Om = self.number(key, f, "Omega", 0.0, test=lambda x: x == 0 or x >= MIN_FREQUENCY,
                             need=f">= 0 (0: a constant force F cos(phi)), and if not 0 at least "
                                  f"{MIN_FREQUENCY:g} (its period 2 pi / Omega a float)")
            phi = self.number(key, f, "phi", 0.0)
            if dofs is not None and on in dofs and None not in (F, Om, phi):
                out.append(Forcing(dofs.index(on), F, Om, phi))
        return tuple(out)

    def gap(self, key, v, dofs):
        n, given = len(dofs), v
        if isinstance(v, list):
            if len(v) != n:
                self.bad(key, v, f"has {len(v)} coefficients; it needs {n}, one per dof "
                                 f"({', '.join(dofs)}), or a table {{ dof = coefficient }}")
                return None
            v = dict(zip(dofs, v))
        elif not isinstance(v, dict):
            self.bad(key, v, "must be a table { dof = coefficient } or a list of one number per dof")
            return None
        a, ok = np.zeros(n), True
        for d, x in v.items():
            if d not in dofs:
                self.bad(f"{key}.{cut(d, KEY_CHARS)}", d, f"is not a dof{did_you_mean(str(d), dofs)}; "
                                                          f"dofs: {', '.join(dofs)}")
                ok = False
            elif not _finite(x):
                self.bad(f"{key}.{d}", x, "must be a finite number")
                ok = False
            else:
                a[dofs.index(d)] = float(x)
        if ok and not np.any(a):
            self.bad(key, given, "is all zero; a gap g = a . x - z(t) needs a coordinate")
            return None
        return a if ok else None

    def contacts(self, v, dofs):
        if not isinstance(v, list):
            self.bad("contact", v, "must be a list of tables ([[system.contact]])")
            return None
        if len(v) > MAX_CONTACTS:
            self.bad("contact", v, f"declares {len(v)} contacts; at most {MAX_CONTACTS}")
            return None
        out, names = [], []
        for i, c in enumerate(v):
            if not isinstance(c, dict):
                self.bad(f"contact.{i}", c, "must be a table ([[system.contact]])")
                continue
            name = c.get("name")
            key = f"contact.{name}" if _letter(name) and name not in names else f"contact.{i}"
            self.unknown(key + ".", c, CONTACT_KEYS)
            if "name" not in c:
                self.problems.append(f"system.{key}.name: missing; a contact's name is one letter, "
                                     "its impacts' symbol in words")
            elif not _letter(name):
                self.bad(f"{key}.name", name, "must be one letter, A-Z or a-z (its impacts' symbol "
                                              "in words)")
            elif name in names:
                self.bad(f"{key}.name", name, f"names contact {names.index(name)} too; contact "
                                              "names must be distinct")
            names.append(name)
            got = self.contact(key, c, dofs)
            if _letter(name) and got is not None:
                out.append(Contact(name, *got))
        soft = [c.name for c in out if c.law == "spring"]
        if len(soft) > MAX_SOFT:
            self.bad("contact", soft, f"names {len(soft)} soft stops (law \"spring\"); at most "
                                      f"{MAX_SOFT}: the flight of each set of them acting is "
                                      f"prepared (2^{MAX_SOFT} flights)")
        return tuple(out)

    def words(self, v, dofs, contacts):
        """``[system] words`` (``system.Words``): two distinct contacts by name, the impacts'
        and the corners', and optionally the dofs of the impacts' height and velocity."""
        if not isinstance(v, dict):
            self.bad("words", v, f"must be a table naming two contacts, e.g. {WORDS_EXAMPLE} "
                                 "(the two-particle model's words: the impacts on U named by "
                                 "their offsets to the impacts on W)")
            return None
        n_before = len(self.problems)
        self.unknown("words.", v, WORDS_KEYS)
        names = [c.name for c in contacts] if contacts is not None else None
        got = {}
        for key, what in (("impacts", "the contact whose impacts are recorded and named"),
                          ("corners", "the contact whose impacts are their corners")):
            if key not in v:
                self.problems.append(f"system.words.{key}: missing; {what} (e.g. {WORDS_EXAMPLE})")
            elif not _letter(v[key]):
                self.bad(f"words.{key}", v[key], f"must be a contact's name (one letter): {what}")
            elif names is not None and v[key] not in names:
                self.bad(f"words.{key}", v[key], f"is not a contact of the system; its contacts: "
                                                 f"{', '.join(names) or 'none'}")
            else:
                got[key] = names.index(v[key]) if names is not None else -1
        if "impacts" in got and "corners" in got and v["impacts"] == v["corners"]:
            self.bad("words.corners", v["corners"], "is the impacts' contact too; the corners are "
                                                    "another contact's impacts")
        for key, what in (("height", "its position at each impact is the impact's height u"),
                          ("velocity", "its velocities before and after each impact are v_in "
                                       "and v_out")):
            if key not in v:
                got[key] = -1
            elif dofs is None:
                continue
            elif not (isinstance(v[key], str) and v[key] in dofs):
                self.bad(f"words.{key}", v[key], f"is not a dof of the system ({what}); its dofs: "
                                                 f"{', '.join(dofs)}")
            else:
                got[key] = dofs.index(v[key])
        if len(self.problems) > n_before or names is None or dofs is None:
            return None
        return Words(got["impacts"], got["corners"], got["height"], got["velocity"])

    def contact(self, key, c, dofs):
        a = None
        if "gap" not in c:
            self.problems.append(f"system.{key}.gap: missing; e.g. gap = {{ x = 1.0 }}: g = x - z(t)")
        elif dofs is not None:
            a = self.gap(f"{key}.gap", c["gap"], dofs)
        kinds = obstacle_kinds()
        obstacle = c.get("obstacle", FIXED)
        if obstacle not in kinds:
            own = isinstance(obstacle, str) and obstacle in obstacles.registered()
            why = (" here: it needs its own table, which a contact cannot hold yet" if own
                   else f" kind{did_you_mean(str(obstacle), kinds)}")
            self.bad(f"{key}.obstacle", obstacle, f"is not an obstacle{why}; allowed: {', '.join(kinds)}")
            obstacle = None
        kappa = self.number(key, c, "kappa", 0.0)
        beta = omega = 0.0
        if obstacle == FIXED:
            for p in ("beta", "omega"):
                if p in c:
                    self.bad(f"{key}.{p}", c[p], "is given, but the obstacle is 'fixed' (z = kappa): "
                                                 "remove it, or name a moving obstacle")
        elif obstacle is not None:
            need = f"the obstacle {obstacle!r} is z = kappa + beta shape(omega t)"
            beta = self.number(key, c, "beta", missing=need)
            if beta == 0.0:
                # (a triangle of no height has slopes 0 and pieces of 0 / 0 time)
                self.bad(f"{key}.beta", c.get("beta"), f"is 0: {need}, which is then the "
                         "fixed obstacle z = kappa; write obstacle = \"fixed\"")
            omega = self.number(key, c, "omega", test=lambda x: x >= MIN_FREQUENCY,
                                need=f"> 0 (at least {MIN_FREQUENCY:g}: its period a float); {need}")
        law = c.get("law", "impact")
        if law not in LAWS:
            self.bad(f"{key}.law", law, f"is not a law{did_you_mean(str(law), LAWS)}; allowed: "
                                        f"{', '.join(LAWS)}")
            law = None
        r, k, cc = Contact.r, 0.0, 0.0
        for p, other in ((p, o) for o in LAWS if law not in (None, o) for p in LAW_KEYS[o] if p in c):
            self.bad(f"{key}.{p}", c[p], f"is given, but the law is {law!r}; {p} belongs to law {other!r}")
        if law == "impact":
            r = self.number(key, c, "r", Contact.r, test=lambda x: 0 <= x <= 1,
                            need="in [0, 1] (the restitution: w+ = -r w-)")
        elif law == "spring":
            if obstacle not in (None, FIXED):
                self.bad(f"{key}.obstacle", obstacle, "is a moving obstacle, but the law is "
                                                      "'spring': a soft stop is on a fixed "
                                                      "obstacle (obstacle = \"fixed\", z = kappa) "
                                                      "for now")
            k = self.number(key, c, "k", test=lambda x: x > 0, need="> 0 (the stop's stiffness)")
            cc = self.number(key, c, "c", 0.0, test=lambda x: x >= 0, need=">= 0 (the stop's damping)")
        got = (a, obstacle, kappa, beta, omega, law, r, k, cc)
        return None if any(x is None for x in got) else got


def _sym_eig(c, halve=True):
    """The eigenvalues of the symmetric parts (C + C^T) / 2 of C (..., N, N), ascending
    (halved first: no overflow), or of C itself (not ``halve``: C symmetric already); NaN
    for a matrix that is not finite."""
    with np.errstate(all="ignore"):
        s = 0.5 * c + 0.5 * np.swapaxes(c, -1, -2) if halve else c
        fin = np.isfinite(s).all(axis=(-2, -1))
        eig = np.linalg.eigvalsh(np.where(fin[..., None, None], s, 0.0))
    return np.where(fin[..., None], eig, np.nan)


def _singular(eig, slack=1.0):
    """Whether a symmetric M of eigenvalues ``eig`` (..., N), ascending, is not
    positive-definite or has a condition number past MAX_CONDITION (a ratio: no overflow;
    ``slack`` < 1 flags a little more, for ``refusable``)."""
    with np.errstate(all="ignore"):
        return ~(eig[..., 0] > 0) | ~(eig[..., -1] / eig[..., 0] <= MAX_CONDITION * slack)


def _not_psd(eig, a, slack=1.0):
    """Whether a symmetric matrix (of) ``a`` (..., N, N), of eigenvalues ``eig`` (..., N),
    ascending, is not positive semi-definite to PSD_TOL of its largest entry."""
    with np.errstate(all="ignore"):
        return ~(eig[..., 0] >= -PSD_TOL * slack * np.abs(a).max(axis=(-2, -1)))


def _scales(m, k, c, on, F, Om, gaps) -> dict:
    """The sizes of R systems that must stay within float64, at once: ``m``, ``k``, ``c``
    (R, N, N) the symmetric M and K and C; ``on`` (nf,) each force's dof, ``F`` and ``Om``
    (R, nf) its amplitude and frequency; ``gaps`` (R, nc, N).  A dict: "minv" (R,), whether
    M^-1 is finite; "terms", {key: (R,)} the norm each block brings to the flight's matrix A
    (the key of its number: "stiffness", "damping", "forcing.<i>.F", "forcing.<i>.Omega");
    "rate" (R,), 1 + their sum, a bound of |A|_2 that grows with each |F| and Omega; "q"
    (R, nc), a^T M^-1 a; "power" (R, nc), log10 |a| |A|^RATE_POWER."""
    with np.errstate(all="ignore"):
        minv = np.linalg.inv(m)
        fin = np.isfinite(minv).all(axis=(-2, -1))
        minv = np.where(fin[:, None, None], minv, np.inf)
        terms = {"stiffness": np.linalg.norm(minv @ k, axis=(-2, -1)),
                 "damping": np.linalg.norm(minv @ c, axis=(-2, -1))}
        cols = np.linalg.norm(minv, axis=-2)           # (R, N): |M^-1 e_j|
        for i, j in enumerate(on):
            terms[f"forcing.{i}.F"] = np.abs(F[:, i]) * cols[:, j]
            terms[f"forcing.{i}.Omega"] = np.abs(Om[:, i])
        rate = 1.0 + sum(terms.values())
        q = np.einsum("rci,rij,rcj->rc", gaps, minv, gaps)
        power = (np.log10(np.linalg.norm(gaps, axis=-1))
                 + RATE_POWER * np.log10(np.maximum(rate, 1.0))[:, None])
    return {"minv": fin, "terms": terms, "rate": rate, "q": q, "power": power}


def _letter(name) -> bool:
    return isinstance(name, str) and len(name) == 1 and name in string.ascii_letters


def read_system(table: dict) -> tuple[LinearSystem | None, list[str]]:
    """The scene's ``[system]`` table (as ``tomllib`` reads it) as a ``LinearSystem``, and
    the problems found (empty when it is valid; the system is None when it is not)."""
    r = _Reader()
    if not isinstance(table, dict):
        return None, [f"system: {shown(table)} must be a table"]
    r.unknown("", table, SYSTEM_KEYS)
    dofs = r.dofs(table.get("dofs"))
    m = k = c = None
    for key in ("mass", "stiffness"):
        if key not in table:
            r.problems.append(f"system.{key}: missing; one number per dof (a diagonal) or a row "
                              "of them per dof")
    if dofs is not None:
        m = r.mass(table["mass"], dofs) if "mass" in table else None
        k = r.stiffness(table["stiffness"], dofs) if "stiffness" in table else None
        c = r.damping(table["damping"], dofs) if "damping" in table else np.zeros((len(dofs), len(dofs)))
    forcing = r.forcing(table.get("forcing", []), dofs)
    contacts = r.contacts(table.get("contact", []), dofs)
    words = r.words(table["words"], dofs, contacts) if "words" in table else None
    if not r.problems:
        r.scales(table, m, k, c, forcing, contacts)
    if r.problems:
        return None, r.problems
    for a in (m, k, c, *(x.gap for x in contacts)):
        a.flags.writeable = False
    return LinearSystem(dofs, m, k, c, forcing, contacts, words), []


# ------------------------------------------------------------------ paths of the numbers
def _cells(table):
    """(path, container, index, where) of every number of ``table`` (a bool is not one),
    valid or not: dofs and contacts named where they can be, by position where they cannot;
    ``where`` places it in the system (``refusable``): ("mass", i, j), ("stiffness", i, j),
    ("damping", i, j), ("forcing", i, key), ("contact", i, key), ("gap", i, j), or None."""
    if not isinstance(table, dict):
        return
    dofs = table.get("dofs") if isinstance(table.get("dofs"), list) else []

    def dof(i):
        return dofs[i] if i < len(dofs) and isinstance(dofs[i], str) else str(i)

    for key in ("mass", "stiffness", "damping"):
        for i, row in enumerate(table.get(key) if isinstance(table.get(key), list) else []):
            if isinstance(row, list):
                yield from ((f"{key}.{dof(i)}.{dof(j)}", row, j, (key, i, j))
                            for j, x in enumerate(row) if is_number(x))
            elif is_number(row):
                yield f"{key}.{dof(i)}", table[key], i, (key, i, i)
    forcing = table.get("forcing") if isinstance(table.get("forcing"), list) else []
    for i, f in enumerate(forcing):
        if isinstance(f, dict):
            yield from ((f"forcing.{i}.{k}", f, k, ("forcing", i, k)) for k, x in f.items() if is_number(x))
    seen = set()
    for i, c in enumerate(table.get("contact") if isinstance(table.get("contact"), list) else []):
        if not isinstance(c, dict):
            continue
        name = c.get("name")
        label = name if isinstance(name, str) and name not in seen and not name.isdigit() else str(i)
        seen.add(name if isinstance(name, str) else None)
        for k, x in c.items():
            if is_number(x):
                yield f"contact.{label}.{k}", c, k, ("contact", i, k)
            elif k == "gap" and isinstance(x, dict):
                yield from ((f"contact.{label}.gap.{d}", x, d, ("gap", i, dofs.index(d)) if d in dofs
                             else None) for d, y in x.items() if is_number(y))
            elif k == "gap" and isinstance(x, list):
                yield from ((f"contact.{label}.gap.{dof(j)}", x, j, ("gap", i, j))
                            for j, y in enumerate(x) if is_number(y))


def numeric_paths(table) -> dict[str, float]:
    """Every number given in ``table`` by its path: ``"forcing.0.Omega"``,
    ``"contact.R.kappa"``, ``"contact.R.gap.x"``, ``"mass.y"`` (a diagonal entry),
    ``"mass.x.y"`` (a matrix entry), ``"stiffness.x.x"``, ``"damping.x.y"``.  A default not
    written in the table (r = 0.8, damping 0) has no path: write it to sweep it."""
    return {path: float(c[i]) for path, c, i, _ in _cells(table)}


def with_value(table: dict, path: str, value) -> dict:
    """A deep copy of ``table`` with the number at ``path`` (a key of ``numeric_paths``)
    set to ``value``.  A mass or stiffness entry off the diagonal, ``"stiffness.x.y"``, sets
    its mirror ``"stiffness.y.x"`` too (those matrices are symmetric); a damping entry sets
    only itself.  A path that is not there raises KeyError naming it and its near matches."""
    new = copy.deepcopy(table)
    cells = {p: (c, i) for p, c, i, _ in _cells(new)}
    if path not in cells:
        near = difflib.get_close_matches(str(path), list(cells), n=3, cutoff=0.6)
        raise KeyError(f"system: {shown(path)} is not a number of the [system] table"
                       + (f" (near: {', '.join(near)})" if near else "")
                       + "; a default not written in the scene has no path: write it to sweep it")
    c, i = cells[path]
    c[i] = value
    parts = path.split(".")
    if parts[0] in ("mass", "stiffness") and len(parts) == 3:
        mirror = cells.get(f"{parts[0]}.{parts[2]}.{parts[1]}")
        if mirror is not None:
            mirror[0][mirror[1]] = value
    return new


# ------------------------------------------------------------------ many systems at once
SLACK = 1e-6      # ``refusable``'s bounds flag a little more than ``read_system`` refuses


def refusable(table: dict, paths, rows) -> np.ndarray:
    """(R,) whether ``read_system`` may refuse the valid ``table`` with the numbers at
    ``paths`` (keys of ``numeric_paths``) set to each row of ``rows`` (R, len(paths)), as
    ``with_value`` sets them (a mass or stiffness entry with its mirror, where it differs
    from the table's): every row it refuses, and perhaps a few more near its limits (read
    each flagged row whole for its message).  All the rows at once: each matrix checked once
    per distinct value (its eigenvalues), the sizes of ``_scales`` bounded by products of
    norms (|M^-1 K| <= |K| / the least eigenvalue of M) rather than computed per row; a
    sweep's combinations are checked so before it runs (``LinearModel.check``)."""
    paths = list(paths)
    rows = np.asarray(rows, dtype=float).reshape(-1, len(paths))
    system, problems = read_system(table)
    if problems:
        return np.ones(len(rows), bool)
    cells = {p: (float(c[i]), where) for p, c, i, where in _cells(table)}
    at = [cells[p] for p in paths]
    with np.errstate(all="ignore"):
        bad = ~np.isfinite(rows).all(axis=1)
        mass, stiffness, damping = (_matrices(table, system, key, rows, at) for key in
                                    ("mass", "stiffness", "damping"))
        bad |= mass["bad"] | stiffness["bad"] | damping["bad"]
        inv_norm = 1.0 / mass["low"]                   # |M^-1|_2
        rate = 1.0 + inv_norm * (stiffness["norm"] + damping["norm"])
        for i, f in enumerate(system.forcing):
            F, Om = (_column(rows, at, ("forcing", i, p), getattr(f, p)) for p in ("F", "Omega"))
            bad |= ~((Om == 0) | (Om >= MIN_FREQUENCY))
            rate += np.abs(F) * inv_norm + np.abs(Om)
        a2 = np.zeros((len(rows), len(system.contacts)))
        for i, c in enumerate(system.contacts):
            bad |= _contact_refusable(rows, at, i, c)
            gap = np.repeat(c.gap[None], len(rows), 0)
            for (_, where), col in zip(at, rows.T):
                if where[:2] == ("gap", i):
                    gap[:, where[2]] = col
            a2[:, i] = (gap * gap).sum(axis=1)
        lim = 10.0 ** FLOAT_EXP * (1 - SLACK)
        power = 0.5 * np.log10(a2) + RATE_POWER * np.log10(np.maximum(rate, 1.0))[:, None]
        bad |= ~(inv_norm <= lim) | ~(rate <= MAX_RATE * (1 - SLACK))
        bad |= ~((a2 > 0) & (a2 * inv_norm[:, None] <= lim) & (a2 / mass["high"][:, None] >= 1 / lim)
                 & (power <= MAX_POWER_EXP - SLACK)).all(axis=1)
    return bad


def _column(rows, at, where, default) -> np.ndarray:
    """(R,) the number at ``where`` in each row: its column, or the table's ``default``."""
    cols = [k for k, (_, w) in enumerate(at) if w == where]
    return rows[:, cols[-1]] if cols else np.full(len(rows), float(default))


def _contact_refusable(rows, at, i, c) -> np.ndarray:
    """(R,) whether contact ``i`` (``c``, as the table declares it) is refused for its own
    numbers in each row: a moving obstacle's beta 0 or omega <= 0, r outside [0, 1], a
    spring's k <= 0 or c < 0."""
    def col(p):
        return _column(rows, at, ("contact", i, p), getattr(c, p))
    bad = np.zeros(len(rows), bool)
    if c.obstacle != FIXED:
        bad |= (col("beta") == 0) | ~(col("omega") >= MIN_FREQUENCY)
    if c.law == "impact":
        bad |= ~((col("r") >= 0) & (col("r") <= 1))
    else:
        bad |= ~(col("k") > 0) | ~(col("c") >= 0)
    return bad


def _matrices(table, system, key, rows, at) -> dict:
    """For the matrix ``key`` of each row, as ``read_system`` reads it (R,) arrays: "bad",
    whether its own checks may refuse it (symmetric, positive-definite or semi-definite);
    "norm", its Frobenius norm (of the symmetrized K, of C); "low" and "high", its least and
    largest eigenvalues (M).  Each distinct matrix is checked once."""
    cols = [k for k, (_, w) in enumerate(at) if w[0] == key]
    which = np.zeros(len(rows), np.int64)
    for k in cols:               # each distinct row of these columns: a code per column, combined
        code = np.unique(rows[:, k], return_inverse=True)[1].reshape(-1)
        which = np.unique(which * (code.max() + 1) + code, return_inverse=True)[1].reshape(-1)
    first = np.unique(which, return_index=True)[1]
    values = rows[first][:, cols]
    n = system.n
    raw, diagonal = (_Reader().matrix(key, table[key], system.dofs) if key in table
                     else (np.zeros((n, n)), False))
    a = np.repeat(raw[None], len(values), 0)
    for k, col in zip(cols, values.T):
        default, (_, i, j) = at[k]
        w = col != default                   # (with_value: not written at the table's value)
        a[w, i, j] = col[w]
        if key != "damping":
            a[w, j, i] = col[w]
    at_ = np.swapaxes(a, 1, 2)
    out = {"bad": np.zeros(len(values), bool)}
    if key == "damping":
        eig = _sym_eig(a)
        out["bad"] |= _not_psd(eig, a, 1 - SLACK)
        out["norm"] = np.linalg.norm(a, axis=(1, 2))
    else:
        out["bad"] |= ~(np.abs(a - at_).max(axis=(1, 2))
                        <= SYMMETRY_TOL * (1 - SLACK) * np.abs(a).max(axis=(1, 2)))
        sym = 0.5 * (a + at_)                # (as ``symmetric``)
        eig = _sym_eig(sym, halve=False)
        if key == "mass":
            if diagonal:
                out["bad"] |= (np.diagonal(a, axis1=1, axis2=2) <= 0).any(axis=1)
            out["bad"] |= _singular(eig, 1 - SLACK)
            out["low"], out["high"] = eig[:, 0], eig[:, -1]
        else:
            out["bad"] |= _not_psd(eig, sym, 1 - SLACK)
            out["norm"] = np.linalg.norm(sym, axis=(1, 2))
    return {k: v[which] for k, v in out.items()}


def paper_words(system: LinearSystem) -> bool:
    """Whether the system's words are the paper's corner clusters (a, b, g, x: the flow's
    ``analysis.detect_cycle``, its period in clusters) rather than its contacts' names: one
    contact, on an obstacle kind with corners, with beta > 0 (corners at z's valleys, as
    the paper's |sin|).  The paper's flow written as a linear scene then has the flow's
    words and periods."""
    if len(system.contacts) != 1:
        return False
    c = system.contacts[0]
    return (c.obstacle != FIXED and c.beta > 0.0
            and obstacles.registered()[c.obstacle].has_corners(None))


def system_period(system: LinearSystem) -> float:
    """The period T of the system's time dependence: the common period of its harmonic
    forces (2 pi / Omega) and moving obstacles (their ``shape`` period over omega); 0 when
    there is none (an autonomous system: periods are then counted in impacts) or when those
    periods have no common multiple within 1000 of the longest (to 1e-9)."""
    periods = [2.0 * math.pi / f.Omega for f in system.forcing if f.Omega > 0.0]
    kinds = obstacles.registered()
    periods += [kinds[c.obstacle].period(c.omega) for c in system.contacts
                if c.obstacle != FIXED]
    if not periods:
        return 0.0
    longest = max(periods)
    for mult in range(1, 1001):
        T = mult * longest
        if all(abs(T / p - round(T / p)) <= 1e-9 * (T / p) for p in periods):
            return T
    return 0.0
